"""Fusing a neighbour's tracks (issue 40): the geometric average of two Gaussian Bernoulli tracks is covariance
intersection for the density and Fantacci et al.'s rule for the existence; the same track twice is itself; tracks
are paired by label first, then by assignment within the gate."""

import numpy as np
import pytest

from swarmtrack.estimation.track_fusion import ga_bernoulli, match


def _spd(rng, n=4):
    a = rng.standard_normal((n, n))
    return a @ a.T + n * np.eye(n)


def test_the_same_track_twice_is_itself():
    rng = np.random.default_rng(0)
    m, P = rng.standard_normal(4), _spd(rng)
    r, mf, Pf = ga_bernoulli(0.7, m, P, 0.7, m, P)
    assert r == pytest.approx(0.7, abs=1e-12)
    np.testing.assert_allclose(mf, m, atol=1e-12)
    np.testing.assert_allclose(Pf, P, rtol=1e-12)


def test_the_density_is_covariance_intersection_and_the_existence_fantaccis_rule():
    rng = np.random.default_rng(1)
    m1, m2, P1, P2 = rng.standard_normal(4), rng.standard_normal(4), _spd(rng), _spd(rng)
    w = 0.3
    r, m, P = ga_bernoulli(0.9, m1, P1, 0.4, m2, P2, w)
    info = w * np.linalg.inv(P1) + (1 - w) * np.linalg.inv(P2)
    np.testing.assert_allclose(P, np.linalg.inv(info), rtol=1e-10)
    eta = w * np.linalg.solve(P1, m1) + (1 - w) * np.linalg.solve(P2, m2)
    np.testing.assert_allclose(m, np.linalg.solve(info, eta), rtol=1e-10)
    # K = ∫ N1^w N2^(1-w) dx: the integrand is K times the fused Gaussian, so K = N1(x)^w N2(x)^(1-w) / N(x; m, P)
    # at any x
    def log_n(x, mu, S):
        d = x - mu
        return -0.5 * (len(x) * np.log(2 * np.pi) + np.linalg.slogdet(S)[1] + d @ np.linalg.solve(S, d))

    x = rng.standard_normal(4)
    log_k = w * log_n(x, m1, P1) + (1 - w) * log_n(x, m2, P2) - log_n(x, m, P)
    yes = 0.9**w * 0.4 ** (1 - w) * np.exp(log_k)
    assert r == pytest.approx(yes / (0.1**w * 0.6 ** (1 - w) + yes), rel=1e-10)


def test_a_certain_and_an_absent_track():
    rng = np.random.default_rng(2)
    m, P = rng.standard_normal(4), _spd(rng)
    assert ga_bernoulli(1.0, m, P, 0.3, m, P)[0] == 1.0
    assert ga_bernoulli(0.0, m, P, 0.9, m, P)[0] == 0.0


def test_tracks_are_paired_by_label_then_by_assignment_within_the_gate():
    P = np.tile(np.eye(4), (3, 1, 1))
    own_labels = np.array([10, 20, 30])
    own_m = np.array([[0.0, 0, 0, 0], [50, 0, 0, 0], [100, 0, 0, 0]])
    labels = np.array([20, 77, 88, 99])
    m = np.array([[0.0, 0, 0, 0], [1.0, 0.5, 0, 0], [101, 0, 0, 0], [300, 0, 0, 0]])
    pairs, left = match(own_labels, own_m, P, labels, m, np.tile(np.eye(4), (4, 1, 1)), gate=9.21)
    # label 20 pairs with own 20 wherever it is; 77 with own 10 (the nearest left), 88 with own 30; 99 is too far
    assert sorted(pairs) == [(0, 1), (1, 0), (2, 2)]
    assert left.tolist() == [3]
