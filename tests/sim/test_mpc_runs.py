"""W20 Ch. 5 closed loop: the MPC holds the formation, the separation term keeps UAVs apart, a blind and cut-off UAV
keeps its last estimate and model while the others carry on."""

import numpy as np
import pytest

from swarmtrack.analysis.metrics import summary
from swarmtrack.network.channel import Channel
from swarmtrack.network.links import to_dense
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.build import build
from swarmtrack.sim.engine import simulate
from swarmtrack.sim.oracle import TruthOracle, kinematic_model, predict

#: W20's controller (its ±2 m bound, the separation cost term only) on the agile vehicle (0.6 rad tilt limit, its own
#: model): with W20's 5° roll/pitch saturation, which the scenarios fly, it keeps neither property (docs/mpc.md,
#: "Attitude limit"; the paper's claims report it); the scenarios' own setting does (below)
AGILE = ["swarm.quadrotor.max_roll_pitch=null", "controller.model=swarmtrack-quadrotor", "controller.bound=2.0",
         "controller.separation=null"]


@pytest.fixture(scope="module")
def collision():
    return {q_s: summary(simulate(load_scenario("w20-mpc-collision", [*AGILE, f"controller.Q_s={q_s}"])))
            for q_s in (6, 0)}


@pytest.mark.slow
def test_the_separation_term_keeps_two_crossing_uavs_apart(collision):
    assert collision[6]["inter_agent_distance"]["min"] > 1.0  # measured 1.17 m
    assert not [w for w in collision[6]["warnings"] if w["kind"] in ("collision", "solver_fallback")]


@pytest.mark.slow
def test_without_the_separation_term_they_collide_and_the_run_says_so(collision):
    assert collision[0]["inter_agent_distance"]["min"] < 0.5
    assert "collision" in [w["kind"] for w in collision[0]["warnings"]]


@pytest.fixture(scope="module")
def five_degrees():
    """Table 5.9 on the 5° vehicle, seed 1: the scenario's own setting (bound: vehicle, separation 1 m) and the
    thesis' (±2 m, the cost term only)."""
    settings = {"consistent": [], "thesis": ["controller.bound=2", "controller.separation=null"]}
    return {name: summary(simulate(load_scenario("w20-mpc-collision", overrides, seed=1)))
            for name, overrides in settings.items()}


@pytest.mark.slow
def test_at_five_degrees_the_consistent_bound_and_the_separation_constraint_keep_them_a_metre_apart(five_degrees):
    run = five_degrees["consistent"]
    # the plans keep d + 2 margin_l apart; flown 2.38 m (10 seeds: 2.33-2.40 m); the thesis' ±2 m with the constraint
    # 0.83-0.88 m, without the margins the constraint's 1 m at most
    assert run["inter_agent_distance"]["min"] >= 2.0
    assert not [w for w in run["warnings"] if w["kind"] in ("collision", "solver_fallback", "unflyable_bound",
                                                            "separation_relaxed", "model_error_exceeded")]


@pytest.mark.slow
def test_at_five_degrees_the_thesis_bound_plans_what_the_vehicle_cannot_fly_and_they_touch(five_degrees):
    run = five_degrees["thesis"]
    assert run["inter_agent_distance"]["min"] < 0.5  # measured 0.43 m
    assert {"unflyable_bound", "collision"} <= {w["kind"] for w in run["warnings"]}
    flown, consistent = run["formation"]["model_error"], five_degrees["consistent"]["formation"]["model_error"]
    assert flown["position"] > 2 * consistent["position"]  # measured 0.049 against 0.018 m in one period


def test_both_reach_their_slots(collision):
    rec_err = collision[6]["formation"]["tracking_error"]
    assert max(rec_err) < 2.0  # includes the 6-9 m approach; settled error is cm


def test_a_single_uav_settles_on_a_resting_target_slot():
    s = load_scenario("w20-mpc-single", ["duration=30", "controller.offsets=[[-2.0, 1.0]]",
                                         "targets.members=[{profile: hover, hover_duration: 30, start: [5, 3]}]"])
    rec = simulate(s)
    np.testing.assert_allclose(rec.uav[-1, 0, :2], [3.0, 4.0], atol=0.05)


@pytest.mark.slow
def test_only_the_blind_and_cut_off_uav_degrades():
    clear = summary(simulate(load_scenario("w20-mpc-formation", AGILE)))["formation"]["tracking_error"]
    occluded = summary(simulate(load_scenario("w20-mpc-occlusion", AGILE)))["formation"]["tracking_error"]
    assert occluded[2] > 1.5 * clear[2]
    for i in (0, 1):
        assert abs(occluded[i] / clear[i] - 1) < 0.10


def test_kinematic_model_names_cv_ct_and_ca_from_velocity_and_acceleration():
    v = np.array([0.5, 0.0])
    assert kinematic_model(v, np.zeros(2))[0] == "cv"
    name, motion = kinematic_model(v, np.array([0.0, 0.075]))  # a = ω × v with ω = 0.15
    assert name == "ct" and motion[2] == pytest.approx(0.15)
    name, motion = kinematic_model(v, np.array([0.05, 0.05]))
    assert name == "ca" and motion[:2].tolist() == [0.05, 0.05]


def test_a_blind_uav_predicts_its_last_sight_with_its_last_model():
    t, truth = [0.0], [np.array([0.0, 0.0, 1.0, 0.0])]
    blind = [np.array([False, False])]
    oracle = TruthOracle(lambda: truth[0], 2, kinematics=lambda: (truth[0][2:], np.array([0.0, 0.3])),
                         blind=lambda: blind[0], now=lambda: t[0])
    first = oracle.view()
    assert first.model.tolist() == ["ct", "ct"]
    t[0], truth[0], blind[0] = 2.0, np.array([9.0, 9.0, 0.0, 0.0]), np.array([False, True])
    view = oracle.view()
    np.testing.assert_array_equal(view.state[0], truth[0])
    np.testing.assert_allclose(view.state[1], predict(np.array([0.0, 0.0, 1.0, 0.0]), "ct", np.array([0, 0, 0.3]), 2.0))
    assert view.state[1, 1] > 0  # turned left


def test_an_outage_cuts_every_link_of_the_uav_during_its_window_only():
    ch = Channel("full", 3, 100.0, outages=(((2,), (40.0, 55.0)),))
    pos = np.zeros((3, 2))
    during, after = to_dense(ch.links(pos, 41.0)), to_dense(ch.links(pos, 55.0))
    assert not during[2].any() and not during[:, 2].any() and during[0, 1]
    assert after[2, 0] and after[0, 2]
    assert not to_dense(ch.beacon_links(pos, 50.0))[:, 2].any()


@pytest.mark.slow
def test_the_multimodel_view_carries_the_winners_model_and_extra_states(monkeypatch):
    from swarmtrack.sim import engine

    built = []
    monkeypatch.setattr(engine, "build", lambda scenario: built.append(build(scenario)) or built[-1])
    simulate(load_scenario("w20-switching", ["duration=20"]))
    est = built[0].stack.estimator
    view, names = est.view(), est.model_names
    assert view.model.tolist() == [names[w] for w in est._winner]
    for i, w in enumerate(est._winner):
        bank = next(b for b in est._banks if w in b.idx)
        row = bank.x[list(bank.idx).index(w)]
        expected = [row[4], row[5], 0] if names[w] == "ca" else [0, 0, row[4]] if names[w] == "ct" else [0, 0, 0]
        np.testing.assert_allclose(view.motion[i], expected)
