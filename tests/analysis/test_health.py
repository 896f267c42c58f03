"""Warnings: a lost target, a filter far from consistent and a UAV without detections are not successes."""

import numpy as np

from swarmtrack.analysis.health import check
from swarmtrack.capabilities.tracking_swarm.metrics import LOST_M
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate
from swarmtrack.sim.recorder import Recording


def _rec(err_scale, K=400, N=3, lost_from=None):
    rng = np.random.default_rng(0)
    t = np.arange(K) * 0.05
    target = np.zeros((K, 4))
    cov = np.broadcast_to(np.diag([0.01, 0.01, 0.04, 0.04]), (K, N, 4, 4)).copy()
    est = target[:, None, :] + rng.standard_normal((K, N, 4)) * np.sqrt([0.01, 0.01, 0.04, 0.04]) * err_scale
    if lost_from is not None:
        est[lost_from:, :, 0] += 2 * LOST_M
    uav = np.zeros((K, N, 4))
    return Recording.from_arrays(t, np.zeros(K, int), ["all"], target, uav, est, cov, d=4.0, r_comm=4.8)


def test_a_consistent_filter_gets_no_warning_and_an_overconfident_one_does():
    assert check(_rec(1.0)) == []
    kinds = [w["kind"] for w in check(_rec(5.0))]  # errors 5x the reported std: NEES about 25
    assert kinds == ["inconsistent"]


def test_losing_the_target_is_reported_with_its_time():
    lost = [w for w in check(_rec(1.0, lost_from=200)) if w["kind"] == "lost_target"]
    assert len(lost) == 1 and lost[0]["t_start"] == 10.0


def test_a_uav_out_of_range_is_named_with_how_long_it_saw_nothing():
    rec = simulate(load_scenario("l24-cv", ["duration=6", "sensor.latency=0", "sensor.max_range=2",
                                            "target.profile=hover", "controller.chase_after_steps=100000",
                                            "swarm.initial_positions=[[1, 0], [5, 0], [9, 0]]"]))
    gaps = {w["uav"]: w for w in check(rec) if w["kind"] == "no_detection"}
    assert set(gaps) == {2, 3} and "never detected" in gaps[3]["message"]


def test_the_chi2_band_matches_scipy():
    from scipy.stats import chi2

    from swarmtrack.analysis.health import chi2_mean_band

    for dim, n in ((4, 10), (2, 100), (1, 40), (4, 6000)):
        exact = chi2.ppf([0.025, 0.975], dim * n) / n
        assert np.allclose(chi2_mean_band(dim, n), exact, rtol=1e-3)
