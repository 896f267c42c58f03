"""The Gaussian LMB filter (estimation/lmb.py): a certain track is a Kalman filter, an undetected one fades by the
LMB formula, two targets in clutter are found and kept under their labels, the compiled update is the reference's.
"""

from __future__ import annotations

import numpy as np
import pytest

from swarmtrack.estimation import lmb
from swarmtrack.estimation.lmb import LMBFilter, Tracks

DT = 1.0
GATE = 13.8  # χ²(2) 99.9 %


def _rel(a, b):
    """Normwise relative error per track (max over tracks): ``max|a − b| / max|b|`` over each track's entries."""
    a = np.asarray(a).reshape(len(a), -1)
    b = np.asarray(b).reshape(len(b), -1)
    if a.size == 0:
        return 0.0
    return float((np.abs(a - b).max(axis=1) / np.maximum(np.abs(b).max(axis=1), 1e-300)).max())


def _random_spd(rng, n, scale=1.0):
    A = rng.standard_normal((n, n))
    return scale * (A @ A.T / n + 0.5 * np.eye(n))


def _kalman(x, P, F, Q, z, R):
    """A plain Kalman filter step: predict, update with the position ``z`` (H = [I 0])."""
    x, P = F @ x, F @ P @ F.T + Q
    S = P[:2, :2] + R
    K = np.linalg.solve(S, P[:2, :]).T
    return x + K @ (z - x[:2]), P - K @ S @ K.T


def test_cv_model_is_the_discretised_white_noise_acceleration_model():
    F, Q = lmb.cv_model(0.5, 2.0)
    np.testing.assert_array_equal(F @ [1.0, 2.0, 3.0, 4.0], [2.5, 4.0, 3.0, 4.0])
    per_axis = 4.0 * np.array([[0.5**4 / 4, 0.5**3 / 2], [0.5**3 / 2, 0.5**2]])
    np.testing.assert_allclose(Q[np.ix_([0, 2], [0, 2])], per_axis, rtol=1e-15)
    np.testing.assert_allclose(Q[np.ix_([1, 3], [1, 3])], per_axis, rtol=1e-15)
    assert Q[0, 1] == Q[0, 3] == Q[2, 3] == 0.0


@pytest.mark.parametrize("compiled", [True, False])
def test_a_certain_single_target_is_born_confirmed_and_then_is_exactly_a_kalman_filter(compiled):
    rng = np.random.default_rng(1)
    F, Q = lmb.cv_model(DT, 0.3)
    truth = np.array([10.0, -5.0, 1.0, 2.0])
    f = LMBFilter(compiled=compiled)
    x = P = None
    for k in range(12):
        if k:
            truth = F @ truth + rng.multivariate_normal(np.zeros(4), Q)
            f.predict(F, Q, 1.0)  # P_S = 1: r reaches 1 (then ψ0 = 1 − r p_D = 0, the certain track's case of LBP)
        R = _random_spd(rng, 2, 0.5)  # each detection its own covariance
        z = truth[:2] + rng.multivariate_normal(np.zeros(2), R)
        f.correct(z[None], R[None], 1.0, 1e-12, GATE, birth_rate=1.0, r_max=0.4, velocity_std=3.0)
        f.finish()
        if k == 0:  # born from the first detection: N([z, 0, 0], blockdiag(R, 9 I))
            x, P = np.concatenate([z, [0.0, 0.0]]), np.diag([0.0, 0.0, 9.0, 9.0])
            P[:2, :2] = R
            continue
        x, P = _kalman(x, P, F, Q, z, R)
        confirmed = f.estimates()
        assert confirmed.label.tolist() == [0]  # the first track, and no other (this step's birth has r = 0.4)
        assert confirmed.r[0] > 1 - 1e-9
        np.testing.assert_allclose(confirmed.m[0], x, rtol=1e-9, atol=1e-9 * np.abs(x).max())
        np.testing.assert_allclose(confirmed.P[0], P, rtol=1e-9, atol=1e-9 * np.abs(P).max())


@pytest.mark.parametrize("compiled", [True, False])
def test_the_existence_of_an_undetected_target_decays_as_r_1_minus_pd_over_1_minus_r_pd(compiled):
    pd = 0.8
    F, Q = lmb.cv_model(DT, 0.5)
    tracks = Tracks([3, 8], [0.95, 0.6], [[0.0, 0.0, 1.0, 0.0], [50.0, 50.0, 0.0, 0.0]],
                    np.repeat(np.diag([1.0, 1.0, 0.5, 0.5])[None], 2, axis=0))
    far = np.array([[500.0, -500.0]])  # a detection both tracks gate out
    r = tracks.r.copy()
    for k in range(8):
        predicted = lmb.predict(tracks, F, Q, 1.0)
        z, R = (far, np.eye(2)[None]) if k % 2 else (np.zeros((0, 2)), np.zeros((0, 2, 2)))
        tracks, p_free = lmb.update(predicted, z, R, pd, 1e-4, GATE, compiled=compiled)
        r = r * (1 - pd) / (1 - r * pd)
        np.testing.assert_allclose(tracks.r, r, rtol=1e-14)
        np.testing.assert_array_equal(tracks.m, predicted.m)  # a sure miss leaves the density as predicted
        np.testing.assert_array_equal(tracks.P, predicted.P)
        np.testing.assert_array_equal(p_free, np.ones(len(z)))
        assert tracks.label.tolist() == [3, 8]


def _two_targets_in_clutter(seed, steps=30, compiled=True):
    """Two targets about 130 m apart in a 1 km square, 10 clutter detections a scan, p_D = 0.95, σ = 1 m; births
    weak (λ_B = 0.005, existence ~4e-4 each): a clutter track needs coincidences on consecutive scans. Yields the
    filter and the truth after every step."""
    rng = np.random.default_rng(seed)
    F, Q = lmb.cv_model(DT, 0.2)
    half, clutter, pd = 500.0, 10, 0.95
    truth = np.array([[-60.0, -20.0, 1.5, 0.5], [60.0, 40.0, -1.0, -0.8]])
    f = LMBFilter(compiled=compiled)
    for k in range(steps):
        if k:
            truth = truth @ F.T + rng.multivariate_normal(np.zeros(4), Q, 2)
            f.predict(F, Q, 0.99)
        seen = truth[rng.random(2) < pd, :2]
        false = rng.uniform(-half, half, (rng.poisson(clutter), 2))
        z = np.concatenate([seen + rng.standard_normal(seen.shape), false])
        f.correct(z, np.repeat(np.eye(2)[None], len(z), 0), pd, clutter / (2 * half) ** 2, GATE, birth_rate=0.005,
                  r_max=0.5, velocity_std=3.0)
        f.finish(threshold=1e-5, max_tracks=100)
        yield f, truth


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_two_targets_in_clutter_are_confirmed_within_three_steps_under_labels_that_follow_them_and_no_false_track(seed):
    labels = [None, None]
    for k, (f, truth) in enumerate(_two_targets_in_clutter(seed)):
        confirmed = f.estimates()
        distance = np.linalg.norm(confirmed.m[:, None, :2] - truth[None, :, :2], axis=-1)  # (confirmed, target)
        assert (distance.min(axis=1) < 10.0).all(), f"step {k}: a confirmed track on no target"
        for t in range(2):
            on_target = confirmed.label[distance[:, t] < 10.0]
            assert len(on_target) <= 1, f"step {k}: two confirmed tracks on target {t}"
            if k >= 3:  # born from the first scan, confirmed after at most three more
                assert len(on_target) == 1, f"step {k}: target {t} not confirmed"
            if len(on_target):
                assert labels[t] in (None, on_target[0]), f"step {k}: target {t} changed its label"
                labels[t] = on_target[0]
    assert len(set(labels)) == 2


def test_the_filter_is_deterministic_and_its_compiled_run_is_the_reference_run():
    runs = [list(_two_targets_in_clutter(4, steps=12, compiled=c)) for c in (True, True, False)]
    (a, _), (b, _), (c, _) = runs[0][-1], runs[1][-1], runs[2][-1]
    np.testing.assert_array_equal(a.tracks.label, b.tracks.label)
    np.testing.assert_array_equal(a.tracks.m, b.tracks.m)
    np.testing.assert_array_equal(a.tracks.P, b.tracks.P)
    assert a.next_label == b.next_label == c.next_label
    np.testing.assert_array_equal(a.tracks.label, c.tracks.label)
    assert _rel(a.tracks.r[:, None], c.tracks.r[:, None]) < 1e-10
    assert _rel(a.tracks.m, c.tracks.m) < 1e-10
    assert _rel(a.tracks.P, c.tracks.P) < 1e-10


def test_the_compiled_update_equals_the_reference_on_a_random_problem():
    rng = np.random.default_rng(11)
    K, M = 9, 12
    m = np.column_stack([rng.uniform(0, 30, (K, 2)), rng.normal(0, 2, (K, 2))])
    P = np.stack([_random_spd(rng, 4, 2.0) for _ in range(K)])
    P[0, 0, 1] += 1e-9  # a slightly asymmetric input: both use its symmetric part
    r = rng.uniform(0.05, 1.0, K)
    r[1] = 1.0
    tracks = Tracks(np.arange(K) * 2, r, m, P)
    z = np.concatenate([m[:8, :2] + rng.normal(0, 1.5, (8, 2)), rng.uniform(0, 30, (M - 8, 2))])
    R = np.stack([_random_spd(rng, 2, 0.8) for _ in range(M)])
    pd = rng.uniform(0.5, 1.0, K)
    kappa = rng.uniform(1e-3, 1e-2, M)
    a, free_a = lmb.update(tracks, z, R, pd, kappa, 9.0, compiled=True)
    b, free_b = lmb.update(tracks, z, R, pd, kappa, 9.0, compiled=False)
    # the problem has what it should: pairs gated out, tracks with several detections, ambiguous detections
    S = P[:, None, :2, :2] + R[None]
    nu = z[None] - m[:, None, :2]
    gated = np.einsum("kma,kma->km", nu, np.linalg.solve(S, nu[..., None])[..., 0]) <= 9.0
    assert (~gated).any() and (gated.sum(axis=1) >= 2).any() and (gated.sum(axis=0) >= 2).any()
    assert _rel(a.r[:, None], b.r[:, None]) < 1e-12
    assert _rel(a.m, b.m) < 1e-12
    assert _rel(a.P, b.P) < 1e-12
    assert _rel(free_a[:, None], free_b[:, None]) < 1e-12
    assert not np.allclose(a.m, m)  # the update did something


def test_covariances_stay_symmetric_positive_definite_over_a_long_clutter_run():
    rng = np.random.default_rng(5)
    F, Q = lmb.cv_model(0.5, 1.0)
    truth = np.array([0.0, 0.0, 3.0, -1.0])
    f = LMBFilter()
    for k in range(150):
        truth = F @ truth
        f.predict(F, Q, 0.95)
        z = np.concatenate([truth[None, :2] + rng.normal(0, 0.5, (1, 2)), truth[:2] + rng.uniform(-15, 15, (15, 2))])
        R = np.stack([_random_spd(rng, 2, 0.3) for _ in range(len(z))])
        f.correct(z, R, 0.9, 15 / 900, GATE, birth_rate=0.5, r_max=0.3, velocity_std=5.0)
        f.finish(threshold=1e-4, max_tracks=60)
        P = f.tracks.P
        np.testing.assert_array_equal(P, np.swapaxes(P, 1, 2))
        assert (np.linalg.eigvalsh(P)[:, 0] > 0).all(), f"step {k}"
        assert ((f.tracks.r >= 0) & (f.tracks.r <= 1)).all()
    assert len(f.tracks) > 10  # clutter kept the filter busy


@pytest.mark.parametrize("compiled", [True, False])
def test_empty_inputs_no_tracks_and_no_detections(compiled):
    F, Q = lmb.cv_model(DT, 1.0)
    none, no_R = np.zeros((0, 2)), np.zeros((0, 2, 2))
    f = LMBFilter(compiled=compiled)
    f.predict(F, Q, 0.99)
    assert len(f.correct(none, no_R, 0.9, 1e-3, GATE, 0.1, 0.5, 2.0)) == 0
    f.finish()
    assert len(f.tracks) == 0 and len(f.estimates()) == 0 and f.next_label == 0
    # detections but no tracks: every detection is free, one birth each
    tracks, p_free = lmb.update(Tracks.empty(), np.ones((3, 2)), np.repeat(np.eye(2)[None], 3, 0), 0.9, 1e-3, GATE,
                                compiled=compiled)
    assert len(tracks) == 0 and p_free.tolist() == [1.0, 1.0, 1.0]
    assert len(lmb.births(none, no_R, np.zeros(0), 0.1, 0.5, 2.0, labels=7)) == 0
    assert len(lmb.prune(Tracks.empty())) == 0 and len(lmb.estimates(Tracks.empty())) == 0


def test_births_follow_the_adaptive_birth_rule_with_consecutive_labels():
    z = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    R = np.stack([np.eye(2), 2 * np.eye(2), [[1.0, 0.3], [0.3, 2.0]]])
    born = lmb.births(z, R, [0.5, 0.02, 0.48], birth_rate=0.6, r_max=0.2, velocity_std=2.0, labels=40)
    assert born.label.tolist() == [40, 41, 42]
    np.testing.assert_allclose(born.r, [0.2, 0.012, 0.2], rtol=1e-15)  # min(r_max, λ_B w / Σ w)
    np.testing.assert_array_equal(born.m, np.column_stack([z, np.zeros((3, 2))]))
    np.testing.assert_array_equal(born.P[:, :2, :2], R)
    np.testing.assert_array_equal(born.P[:, 2:, 2:], np.repeat(4 * np.eye(2)[None], 3, 0))
    np.testing.assert_array_equal(born.P[:, :2, 2:], 0)
    assert lmb.births(z, R, np.zeros(3), 0.6, 0.2, 2.0, 0).r.tolist() == [0, 0, 0]


def test_prune_drops_small_existence_keeps_the_largest_and_returns_label_order():
    r = np.array([0.5, 1e-4, 0.9, 0.5, 0.7, 0.002])
    tracks = Tracks([9, 4, 7, 2, 5, 1], r, np.arange(24.0).reshape(6, 4), np.repeat(np.eye(4)[None], 6, 0))
    assert lmb.prune(tracks).label.tolist() == [1, 2, 5, 7, 9]
    kept = lmb.prune(tracks, max_tracks=3)  # 0.9, 0.7, then the tie at 0.5 to the smaller label
    assert kept.label.tolist() == [2, 5, 7]
    np.testing.assert_array_equal(kept.m[0], tracks.m[3])
    assert lmb.estimates(tracks).label.tolist() == [7, 5]  # r > 0.5, in the tracks' order


def test_a_birth_from_one_sensor_is_confirmed_by_the_next_sensor_in_the_same_step():
    f = LMBFilter()
    F, Q = lmb.cv_model(DT, 0.5)
    f.predict(F, Q, 0.99)
    f.correct([[10.0, 10.0]], [np.eye(2)], 0.9, 1e-4, GATE, birth_rate=0.1, r_max=0.1, velocity_std=2.0)
    assert len(f.estimates()) == 0
    f.correct([[10.5, 9.8]], [0.5 * np.eye(2)], 0.9, 1e-4, GATE, birth_rate=0.1, r_max=0.1, velocity_std=2.0)
    f.finish()
    confirmed = f.estimates()
    assert confirmed.label.tolist() == [0]  # sensor A's birth, updated by sensor B
    assert 10.0 < confirmed.m[0, 0] < 10.5 and 9.8 < confirmed.m[0, 1] < 10.0
