"""W20 Ch. 5's attitude limit in the paper's experiments (``analysis/papers/w20_control.py``): the simulated scenarios
fly W20 Sec. 5.4.2's 5° roll/pitch saturation with an MPC model identified on that vehicle, the indoor one does not."""

import numpy as np
import pytest

from swarmtrack.analysis.papers import w20_control
from swarmtrack.control.identification import rounded_model
from swarmtrack.scenarios import load_scenario

SIMULATED = [n for n in w20_control.EXPERIMENTS if n != "w20-mpc-indoor" and n not in w20_control.VARIANTS]


@pytest.fixture(scope="module")
def limited():
    return w20_control.limited_quadrotor_model()


def test_the_limit_is_the_thesis_five_degrees():
    assert w20_control.LIMIT == pytest.approx(5.0 * np.pi / 180.0, rel=1e-15)


@pytest.mark.parametrize("name", SIMULATED)
def test_every_simulated_scenario_flies_five_degrees_with_the_model_identified_on_it(name, limited):
    scenario = load_scenario(name)
    assert scenario.swarm.quadrotor.max_roll_pitch == w20_control.LIMIT
    A, B = rounded_model(limited)  # what swarmtrack identify writes: 6 significant digits
    model = scenario.controller.model
    assert model.T == limited.T == 0.2
    np.testing.assert_array_equal(np.asarray(model.A), A)
    np.testing.assert_array_equal(np.asarray(model.B), B)


def test_the_indoor_pelican_keeps_the_default_tilt_limit():
    # W20 gives the 5° for its V-REP simulation (Sec. 5.4.2), none for the Pelican flown indoors (Sec. 5.4.3)
    scenario = load_scenario("w20-mpc-indoor")
    assert scenario.swarm.quadrotor.max_roll_pitch is None and scenario.swarm.quadrotor.max_tilt == 0.6


def test_the_five_degree_vehicle_is_slower_than_the_default_one(limited):
    # the 1 m steps saturate it (kp·1 m = 1.44 m/s² > g·tan 5° = 0.86 m/s²): a slower model, a lower but good fit
    from swarmtrack.control.identification import identify, step_response_log

    default = identify(step_response_log())
    assert w20_control.FIT_GOAL <= min(limited.fits.values()) < min(default.fits.values())
    assert limited.B[2, 0] < default.B[2, 0]  # the setpoint accelerates it less
    assert limited.A[2, 2] > default.A[2, 2]  # and its velocity decays more slowly


@pytest.mark.parametrize("name", SIMULATED)
def test_every_simulated_scenario_plans_within_what_its_vehicle_flies_and_its_thesis_variant_does_not(name):
    """Issue 42: the scenarios' own bound is the one the 5° vehicle flies (1.041 m); the thesis setting (±2 m, ±10 m,
    the separation cost term only) is flown with a warning naming the key and the limit."""
    own = load_scenario(name).controller
    assert own.bound == 1.041 and own.recording_meta()["mpc"]["warnings"] == []
    assert own.separation == (1.0 if own.Q_s > 0 and "single" not in name else None)
    if name in w20_control.THESIS:
        scenario, overrides = w20_control.VARIANTS[f"{name}-thesis"]
        thesis = load_scenario(scenario, overrides).controller
        assert thesis.bound in (2.0, 10.0) and thesis.separation is None
        [warning] = thesis.recording_meta()["mpc"]["warnings"]
        assert warning.startswith(f"controller.bound = {thesis.bound:g} m is more than the vehicle can fly: "
                                  "swarm.quadrotor.max_roll_pitch = 0.08727 rad (5°)")
