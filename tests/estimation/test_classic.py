"""The classic baselines (issue 40): GNN and JPDA with M-of-N track management. A track is confirmed at its
confirm-th hit, a tentative one deleted at its first miss and a confirmed one after delete misses in a row; a track
its sensor cannot see is never missed; GNN's single assigned track is a Kalman filter's; JPDA's update is the LMB
update of a track certain to exist."""

import numpy as np
import pytest

from swarmtrack.estimation import lmb
from swarmtrack.estimation.classic import CONFIRMED, TENTATIVE, GNNFilter, JPDAFilter
from swarmtrack.estimation.kalman import ekf_update

F, Q = lmb.cv_model(1.0, 0.5)
R = np.eye(2)[None]
GATE = 13.8


def _step(f, z, pd=0.9, kappa=1e-4):
    f.predict(F, Q, 1.0)
    free = f.correct(np.atleast_2d(z).reshape(-1, 2), np.repeat(R, len(np.atleast_2d(z).reshape(-1, 2)), 0), pd,
                     kappa, GATE, 0.1, 0.5, 5.0)
    f.finish()
    return free


@pytest.mark.parametrize("cls", [GNNFilter, JPDAFilter])
def test_a_track_is_confirmed_at_its_third_hit_and_deleted_after_three_misses(cls):
    f = cls(confirm=3, delete=3, compiled=False)
    path = [np.array([1.0 * k, 0.5 * k]) for k in range(4)]
    _step(f, path[0])
    assert f.tracks.r.tolist() == [TENTATIVE]
    _step(f, path[1])
    assert f.tracks.r.tolist() == [TENTATIVE]
    _step(f, path[2])
    assert f.tracks.r.tolist() == [CONFIRMED]
    for _ in range(2):
        _step(f, np.zeros((0, 2)))
        assert f.tracks.r.tolist() == [CONFIRMED]
    _step(f, np.zeros((0, 2)), pd=0.0)  # out of its sensor's view: not a miss
    assert len(f.tracks) == 1
    _step(f, np.zeros((0, 2)))
    assert len(f.tracks) == 0


@pytest.mark.parametrize("cls", [GNNFilter, JPDAFilter])
def test_a_tentative_track_is_deleted_at_its_first_miss_and_a_free_detection_starts_one(cls):
    f = cls(confirm=3, delete=3, compiled=False)
    assert _step(f, [[0.0, 0.0], [50.0, 50.0]]).tolist() == [1.0, 1.0]
    assert len(f.tracks) == 2
    _step(f, [[0.5, 0.0]])  # the second one missed
    assert len(f.tracks) == 1 and np.abs(f.tracks.m[0, :2] - [0.5, 0.0]).max() < 1.0


def test_gnns_assigned_track_is_a_kalman_filter():
    f = GNNFilter(confirm=2, delete=3, compiled=False)
    z = [np.array([1.0 * k + 0.1 * (-1) ** k, 2.0 * k]) for k in range(6)]
    _step(f, z[0])
    m, P = f.tracks.m[0].copy(), f.tracks.P[0].copy()
    H = np.eye(2, 4)
    for k in range(1, 6):
        _step(f, z[k])
        m, P = F @ m, F @ P @ F.T + Q
        m, P = ekf_update(m, P, H, R[0], z[k] - H @ m)
        np.testing.assert_allclose(f.tracks.m[0], m, atol=1e-9)
        np.testing.assert_allclose(f.tracks.P[0], P, atol=1e-9)


def test_jpdas_update_is_the_lmb_update_of_tracks_certain_to_exist():
    f = JPDAFilter(confirm=1, delete=3, compiled=False)
    _step(f, [[0.0, 0.0], [6.0, 0.0]])
    f.predict(F, Q, 1.0)
    before = f.tracks
    z = np.array([[0.4, 0.1], [5.0, 0.3], [3.0, 0.0]])
    f.correct(z, np.repeat(R, 3, 0), 0.9, 1e-3, GATE, 0.1, 0.5, 5.0)
    want, _ = lmb.update(lmb.Tracks(before.label, np.ones(2), before.m, before.P), z, np.repeat(R, 3, 0), 0.9, 1e-3,
                         GATE, compiled=False)
    np.testing.assert_allclose(f.tracks.m[:2], want.m, rtol=1e-12)
    np.testing.assert_allclose(f.tracks.P[:2], want.P, rtol=1e-12)
