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
