"""Many targets, many UAVs (issue 40): the assignment covers every track first, at most per_track UAVs each, keeps
the searchers, and minimises the distances; the lawnmower covers the region."""

import numpy as np
from scipy.optimize import linear_sum_assignment

from swarmtrack.control.assignment import assign, lawnmower


def test_every_track_gets_a_uav_before_any_gets_two_and_the_rest_search():
    rng = np.random.default_rng(0)
    uavs, tracks = rng.uniform(0, 100, (7, 2)), rng.uniform(0, 100, (3, 2))
    got = assign(uavs, tracks, searchers=2, per_track=2)
    counts = np.bincount(got[got >= 0], minlength=3)
    assert counts.min() >= 1 and counts.max() <= 2 and counts.sum() == 5 and (got < 0).sum() == 2
    got = assign(uavs[:2], tracks, searchers=1, per_track=2)  # fewer UAVs than tracks: all follow, none searches
    assert (got >= 0).all() and len(set(got.tolist())) == 2
    assert (assign(uavs, np.zeros((0, 2)), 1, 2) == -1).all()  # no track: all search


def test_the_assignment_minimises_the_total_distance_with_one_uav_per_track():
    rng = np.random.default_rng(1)
    for _ in range(20):
        uavs, tracks = rng.uniform(0, 100, (4, 2)), rng.uniform(0, 100, (4, 2))
        got = assign(uavs, tracks, searchers=0, per_track=1)
        cost = np.linalg.norm(uavs[:, None] - tracks[None], axis=-1)
        rows, cols = linear_sum_assignment(cost)
        assert cost[np.arange(4), got].sum() == cost[rows, cols].sum()


def test_the_lawnmower_sweeps_the_region_lane_by_lane():
    w = lawnmower((-100.0, -100.0, 100.0, 100.0), 40.0)
    assert len(w) == 10 and (np.abs(w) <= 100).all()
    ys = np.unique(w[:, 1])
    np.testing.assert_allclose(np.diff(ys), 40.0)
    assert ys[0] == -80.0 and ys[-1] == 80.0
