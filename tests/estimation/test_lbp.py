"""Loopy belief propagation for association marginals (estimation/lbp.py) against exact enumeration of the joint
association, against textbook sum-product on the association's factor graph, and kernel against reference."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from swarmtrack.estimation.lbp import lbp, lbp_reference

IMPLEMENTATIONS = [lbp, lbp_reference]


def exact_marginals(psi0, psi):
    """Brute force over every one-to-one association (each track at most one measurement, each measurement at most
    one track): ``p`` (K, M + 1) and ``p_free`` (M,) of the distribution ``∝ ∏_i ψ_i,a(i)``."""
    k, m = psi.shape
    p = np.zeros((k, m + 1))
    free = np.zeros(m)
    total = 0.0
    for a in itertools.product(range(m + 1), repeat=k):
        taken = [x for x in a if x]
        if len(taken) != len(set(taken)):
            continue
        w = np.prod([psi0[i] if a[i] == 0 else psi[i, a[i] - 1] for i in range(k)])
        total += w
        for i in range(k):
            p[i, a[i]] += w
        for j in range(m):
            if j + 1 not in a:
                free[j] += w
    return p / total, free / total


def sum_product(psi0, psi, iterations=300):
    """Textbook sum-product on the pairwise factor graph of Williams & Lau 2014: variables ``a_i ∈ {0..M}`` (track
    ``i``'s measurement, unary weights ``[ψ0_i, ψ_i·]``) and ``b_j ∈ {0..K}`` (measurement ``j``'s track), one factor
    per pair that is 0 when exactly one of ``a_i = j + 1`` and ``b_j = i + 1`` holds. Vector messages, normalised."""
    k, m = psi.shape
    unary = np.column_stack([psi0, psi])
    factor = {}
    for i, j in itertools.product(range(k), range(m)):
        a = np.arange(m + 1)[:, None] == j + 1
        b = np.arange(k + 1)[None, :] == i + 1
        factor[i, j] = (a == b).astype(float)  # (M + 1, K + 1)
    to_b = {key: np.ones(k + 1) for key in factor}
    to_a = {key: np.ones(m + 1) for key in factor}
    for _ in range(iterations):
        new_b, new_a = {}, {}
        for i, j in factor:
            h = unary[i] * np.prod([to_a[i, jj] for jj in range(m) if jj != j], axis=0)
            v = factor[i, j].T @ h
            new_b[i, j] = v / v.sum()
            h = np.prod([to_b[ii, j] for ii in range(k) if ii != i] or [np.ones(k + 1)], axis=0)
            v = factor[i, j] @ h
            new_a[i, j] = v / v.sum()
        to_b, to_a = new_b, new_a
    belief = unary * np.prod([[to_a[i, j] for j in range(m)] for i in range(k)], axis=1)
    return belief / belief.sum(axis=1, keepdims=True)


def _random_problem(rng, k, m, density=0.6):
    psi0 = rng.uniform(0.05, 1.0, k)
    psi = rng.uniform(0.0, 5.0, (k, m)) * (rng.random((k, m)) < density)
    return psi0, psi


# Gating graphs without cycles: every measurement gated by one track (a forest of stars), and a chain
# track 0 - z0 - track 1 - z1 - track 2 - z2 - track 3 - z3 (measurements shared by two tracks, still a tree).
TREES = {
    "stars": (np.array([0.3, 0.05, 0.6]), np.array([[2.0, 0.7, 0.0, 0.0], [0.0, 0.0, 4.0, 0.0], [0.0, 0.0, 0.0, 0.2]])),
    "chain": (np.array([0.3, 0.5, 0.2, 0.7]),
              np.array([[2.0, 0.0, 0.0, 0.0], [1.5, 2.0, 0.0, 0.0], [0.0, 0.8, 1.2, 0.0], [0.0, 0.0, 3.0, 0.4]])),
    "certain track": (np.array([0.0, 0.4, 0.5]), np.array([[3.0, 0.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.5, 1.0]])),
}


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
@pytest.mark.parametrize("name", sorted(TREES))
def test_lbp_marginals_equal_exact_enumeration_on_unambiguous_problems(impl, name):
    psi0, psi = TREES[name]
    p, p_free = impl(psi0, psi)
    p_exact, free_exact = exact_marginals(psi0, psi)
    np.testing.assert_allclose(p, p_exact, atol=1e-9, rtol=0)
    np.testing.assert_allclose(p_free, free_exact, atol=1e-9, rtol=0)


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
def test_lbp_marginals_are_close_to_exact_enumeration_on_a_small_ambiguous_problem(impl):
    # two crossing tracks that both gate both their measurements (one cycle), and a clutter detection near track 0
    psi0 = np.array([0.2, 0.3])
    psi = np.array([[5.0, 1.0, 0.5], [1.0, 4.0, 0.0]])
    p, p_free = impl(psi0, psi)
    p_exact, free_exact = exact_marginals(psi0, psi)
    assert np.abs(p - p_exact).max() < 0.05
    assert np.abs(p_free - free_exact).max() < 0.05
    assert np.abs(p - p_exact).max() > 1e-4  # a loopy problem: approximate, not exact (the test above would not see)


def test_lbp_scalar_messages_are_textbook_sum_product_on_the_association_factor_graph():
    rng = np.random.default_rng(7)
    for k, m in [(2, 2), (3, 3), (3, 2)]:
        psi0, psi = _random_problem(rng, k, m, density=0.8)
        p, _ = lbp(psi0, psi, tol=1e-13, max_iter=1000)
        np.testing.assert_allclose(p, sum_product(psi0, psi), atol=1e-9, rtol=0)


@pytest.mark.parametrize("shape", [(1, 1), (3, 4), (7, 5), (12, 20)])
def test_lbp_kernel_equals_reference(shape):
    rng = np.random.default_rng(sum(shape))
    psi0, psi = _random_problem(rng, *shape)
    psi0[0] = 0.0  # a track certain to exist and be detected
    p, p_free = lbp(psi0, psi)
    p_ref, free_ref = lbp_reference(psi0, psi)
    np.testing.assert_allclose(p, p_ref, rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(p_free, free_ref, rtol=1e-12, atol=1e-300)


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
def test_lbp_rows_are_distributions_and_free_probabilities_are_probabilities(impl):
    psi0, psi = _random_problem(np.random.default_rng(3), 9, 11)
    p, p_free = impl(psi0, psi)
    assert (p >= 0).all() and np.allclose(p.sum(axis=1), 1.0, rtol=0, atol=1e-14)
    assert (p[:, 1:][psi == 0] == 0).all()  # nothing outside the gate
    assert ((0 <= p_free) & (p_free <= 1)).all()
    # a measurement is taken by some track at most with probability 1: Σ_i p_i,j+1 ≤ 1 (≈ 1 − p_free on trees)
    assert (p[:, 1:].sum(axis=0) <= 1 + 1e-12).all()


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
@pytest.mark.parametrize("k, m", [(0, 0), (0, 3), (4, 0)])
def test_lbp_without_tracks_or_measurements_everything_is_missed_and_free(impl, k, m):
    p, p_free = impl(np.full(k, 0.4), np.ones((k, m)))
    assert p.shape == (k, m + 1) and p_free.shape == (m,)
    assert (p[:, 0] == 1).all() and (p[:, 1:] == 0).all() and (p_free == 1).all()


@pytest.mark.parametrize("impl", IMPLEMENTATIONS)
def test_lbp_an_impossible_track_is_reported_missed_and_a_certain_one_takes_its_measurement(impl):
    # track 0 must be detected (ψ0 = 0) but gates nothing; track 1 must be detected and gates only z0, which
    # track 2 also gates: z0 is track 1's for sure, so track 2 is missed for sure
    psi0 = np.array([0.0, 0.0, 0.5])
    psi = np.array([[0.0, 0.0], [2.0, 0.0], [3.0, 0.0]])
    p, p_free = impl(psi0, psi)
    assert np.isfinite(p).all() and np.isfinite(p_free).all()
    np.testing.assert_array_equal(p, [[1, 0, 0], [0, 1, 0], [1, 0, 0]])
    np.testing.assert_array_equal(p_free, [0, 1])
