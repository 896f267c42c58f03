"""Bad MPC, outage and identified-model settings are refused with the field and the cause named (exit 2)."""

import numpy as np
import pytest
from click.testing import CliRunner

from swarmtrack.cli import main
from swarmtrack.scenarios import load_scenario


@pytest.mark.parametrize("override, words", [
    ("controller.horizon=0", ["controller.horizon", "greater than or equal to 1"]),
    ("controller.bound=0", ["controller.bound", "greater than 0"]),
    ("controller.bound=-2", ["controller.bound"]),
    ("controller.offsets=[[0,0],[10,10],[0,0]]", ["controller.offsets", "UAVs 1 and 3", "same formation slot"]),
    ("controller.offsets=[[0,0],[10,10]]", ["controller.offsets", "2 entries for 3 UAVs"]),
    ("controller.model=pelican", ["controller.model", "unknown model 'pelican'", "swarmtrack-quadrotor"]),
    ("controller.model={T: 0.2, A: [[1.01,0,0,0],[0,0.5,0,0],[0,0,0.5,0],[0,0,0,0.5]], B: [[0,0],[0,0],[1,0],[0,1]]}",
     ["controller.model", "unstable", "spectral radius 1.01"]),
    ("controller.model={T: 0.2, A: [[0.5,0],[0,0.5]], B: [[0,0],[0,0],[1,0],[0,1]]}",
     ["controller.model", "4x4"]),
    ("controller.period=0.3", ["controller.period", "identified at T = 0.2"]),
    ("controller.R=0", ["controller.R"]),
    ("network.outages=[{uavs: [4], window: [1, 2]}]", ["network.outages[0].uavs", "UAV 4"]),
    ("network.outages=[{uavs: [1], window: [5, 2]}]", ["network.outages", "t0 < t1"]),
])
def test_bad_mpc_settings_exit_2_naming_the_field(override, words, refused):
    refused("w20-mpc-formation", override, words)


def test_a_period_that_is_not_a_whole_number_of_control_steps_is_refused():
    result = CliRunner().invoke(main, ["validate", "w20-mpc-single", "--set", "rates.control=7",
                                       "--set", "rates.physics=70", "--set", "rates.estimation=10"])
    assert result.exit_code == 2 and "whole number of control steps" in result.output, result.output


def test_a_given_model_is_used_and_the_thesis_models_by_name():
    s = load_scenario("w20-mpc-single", ["controller.model=w20-pelican"])
    T, A, B = s.controller.uav_model()
    assert T == 0.2 and A[2, 0] == -0.151 and B[3, 1] == 0.111


@pytest.mark.slow
def test_the_yaml_block_identify_writes_plugs_into_a_scenario():
    import yaml

    from swarmtrack.control.identification import identify, model_yaml, step_response_log
    from swarmtrack.scenarios.loader import load_raw
    from swarmtrack.scenarios.schema import Scenario

    found = identify(step_response_log())
    data = load_raw("w20-mpc-formation")
    data["controller"]["model"] = yaml.safe_load(model_yaml(found))["model"]
    T, A, B = Scenario.model_validate(data).controller.uav_model()
    assert T == found.T
    np.testing.assert_allclose(A, found.A, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(B, found.B, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("override, words", [
    ("controller.bound=vehicles", ["controller.bound", "vehicle"]),
    ("controller.separation=0", ["controller.separation", "greater than 0"]),
    ("controller.model_error=[-0.1, 0.2]", ["controller.model_error", "greater than or equal to 0"]),
    ("controller.model_error=[0.1]", ["controller.model_error"]),
])
def test_bad_bound_and_separation_settings_exit_2_naming_the_field(override, words, refused):
    refused("w20-mpc-collision", override, words)


@pytest.mark.parametrize("overrides, bound, limit", [
    ([], 1.041, "swarm.quadrotor.max_roll_pitch = 0.08727 rad (5°)"),  # W20's 5°: g·tan 5° = 0.858 m/s²
    (["swarm.quadrotor.max_roll_pitch=null"], 2.573, "controller.gains.accel_limit = 3 m/s² (in norm)"),
    (["swarm.quadrotor.max_roll_pitch=null", "swarm.quadrotor.max_tilt=0.2"], 1.705,
     "swarm.quadrotor.max_tilt = 0.2 rad (in norm)"),
])
def test_bound_vehicle_resolves_to_the_bound_the_limiting_setting_allows(overrides, bound, limit):
    """a·T/Δv: 0.858 m/s², 3/√2 m/s², g·tan 0.2/√2 m/s² through the 5° model's first-period change (0.164852 m/s
    per m), rounded down to the mm; the resolved number is what scenario.yaml says."""
    s = load_scenario("w20-mpc-collision", overrides)
    assert s.controller.bound == bound and s.controller.model_dump()["bound"] == bound
    meta = s.controller.recording_meta()["mpc"]
    assert meta["vehicle_bound"] == bound and meta["limit"] == limit and meta["warnings"] == []
    assert meta["separation"] == 1.0 and len(meta["margins"]) == 5


def test_a_bound_the_vehicle_cannot_fly_is_run_with_a_warning_naming_the_key_and_the_limit(tmp_path):
    result = CliRunner().invoke(main, ["validate", "w20-mpc-collision", "--set", "controller.bound=2"])
    assert result.exit_code == 0 and "bound: 2.0" in result.output
    result = CliRunner().invoke(main, ["run", "w20-mpc-collision", "--set", "controller.bound=2", "--set",
                                       "duration=0.6", "--no-plots", "--out", str(tmp_path / "run")])
    assert result.exit_code == 0, result.output
    assert ("warning: controller.bound = 2 m is more than the vehicle can fly: swarm.quadrotor.max_roll_pitch = "
            "0.08727 rad (5°) gives 0.858 m/s² per axis, which the MPC's model reaches at a relative setpoint of "
            "1.041 m") in result.output
    flyable = load_scenario("w20-mpc-collision", ["controller.bound=1.041"]).controller.recording_meta()["mpc"]
    assert flyable["warnings"] == []
