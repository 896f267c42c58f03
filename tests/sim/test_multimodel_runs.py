"""W20 Ch. 4 in the closed loop: static UAVs, gimballed cameras aimed at their own estimates, a ground robot."""

import numpy as np
import pytest

from swarmtrack.analysis.metrics import summary
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate

SHORT = ["duration=12", "estimator.solo_steps=30"]


def test_the_switching_team_tracks_the_robot_to_centimetres_and_records_its_model_choice():
    rec = simulate(load_scenario("w20-switching-ideal", SHORT, seed=1))
    s = summary(rec)
    assert s["mean_error"]["all"] < 0.03
    assert s["mean_error"]["occluded_steps"] == 0
    assert abs(sum(s["model_use"]["share"]) - 1.0) < 1e-9
    winner = rec.frame("uavs")["winner"].to_numpy()
    assert set(np.unique(winner[winner > 0])) <= {1.0, 2.0, 3.0}
    assert not [w for w in s["warnings"] if w["kind"] in ("lost_target", "never_detected")]


@pytest.mark.slow
def test_a_camera_whose_footprint_is_too_small_for_its_estimate_loses_the_robot():
    """The gimbal aims at the UAV's own estimate: with a 5 mm footprint at 1.5 m (the estimate errs by about as
    much) the robot leaves the view."""
    narrow = simulate(load_scenario("w20-switching-ideal", [*SHORT, "sensor.footprint=[0.005, 0.005]"], seed=1))
    wide = simulate(load_scenario("w20-switching-ideal", SHORT, seed=1))
    seen = {k: r.frame("uavs")["detected"].mean() for k, r in (("narrow", narrow), ("wide", wide))}
    assert seen["wide"] > 0.99
    assert seen["narrow"] < 0.9


@pytest.mark.slow
def test_an_occlusion_interval_is_measured_and_predicted_through():
    rec = simulate(load_scenario("w20-occlusion-ideal", ["duration=26", "estimator.solo_steps=30"], seed=1))
    s = summary(rec)
    assert s["mean_error"]["occluded_steps"] >= 50  # the 2 s blackout from t = 22 s, at 30 Hz
    assert s["mean_error"]["occluded"] > s["mean_error"]["all"]
    assert s["mean_error"]["all"] < 0.05  # found again after the blackout


@pytest.mark.slow
def test_every_fusion_runs_in_the_loop():
    for fusion in ("imm-thesis", "imm", "ml", "none"):
        s = summary(simulate(load_scenario("w20-evasive-ideal", ["duration=6", "estimator.solo_steps=30",
                                                           f"estimator.fusion={fusion}"], seed=2)))
        assert s["mean_error"]["all"] < 0.05, fusion


@pytest.mark.slow
def test_lost_messages_leave_each_uav_with_what_arrived():
    """W20 Sec. 3.2.2.2: lossless communication is not assumed. With half the messages lost (both rounds) every
    fusion still tracks, from the candidates whose messages arrived."""
    for fusion in ("ttest", "imm", "ml"):
        rec = simulate(load_scenario("w20-evasive-ideal", ["duration=6", "estimator.solo_steps=30",
                                                     "network.loss_probability=0.5", f"estimator.fusion={fusion}"],
                                     seed=3))
        s = summary(rec)
        assert s["mean_error"]["all"] < 0.05, fusion
        assert np.isfinite(np.asarray(rec.estimate)[-30:]).all()
