"""The swarm's ``quadrotor`` section (``capabilities/vehicles.py``'s ``quadrotor_params``, the schema's
``QuadrotorSpec``): W20 Sec. 5.4.2's attitude limit as scenario data, the defaults as the old vehicle."""

import numpy as np
import pytest
from click.testing import CliRunner

from swarmtrack import registry
from swarmtrack.cli import main
from swarmtrack.scenarios import ScenarioError, load_scenario
from swarmtrack.vehicles.quadrotor import DEFAULT_PARAMS, QuadrotorParams


def _params(scenario, overrides=()):
    spec = load_scenario(scenario, list(overrides))
    return registry.get(registry.VEHICLE, "quadrotor").make_params(spec.swarm)


def test_the_default_section_builds_the_default_vehicle():
    assert _params("l24-cv") is None  # the world's default QuadrotorParams(), as before the key existed
    assert _params("l24-cv", ["swarm.quadrotor.max_tilt=0.6"]) is None
    assert QuadrotorParams(max_tilt=0.6, max_roll_pitch=None) == DEFAULT_PARAMS


def test_the_section_sets_the_swarm_quadrotors_limits():
    p = _params("l24-cv", ["swarm.quadrotor.max_roll_pitch=0.0872664626", "swarm.quadrotor.max_tilt=0.5"])
    assert (p.max_roll_pitch, p.max_tilt) == (0.0872664626, 0.5)
    assert p.max_horizontal_accel == pytest.approx(9.81 * np.tan(0.5))
    w20 = _params("w20-mpc-formation")
    assert w20.max_roll_pitch == pytest.approx(np.radians(5.0), rel=1e-15)


@pytest.mark.parametrize(("override", "words"), [
    ("swarm.quadrotor.max_roll_pitch=0", ["swarm.quadrotor.max_roll_pitch", "greater than 0"]),
    ("swarm.quadrotor.max_roll_pitch=-0.1", ["swarm.quadrotor.max_roll_pitch", "greater than 0"]),
    ("swarm.quadrotor.max_roll_pitch=1.6", ["swarm.quadrotor.max_roll_pitch", "less than 1.57"]),
    ("swarm.quadrotor.max_roll_pitch=five", ["swarm.quadrotor.max_roll_pitch"]),
    ("swarm.quadrotor.max_tilt=2", ["swarm.quadrotor.max_tilt", "less than 1.57"]),
    ("swarm.quadrotor.max_yaw=0.1", ["swarm.quadrotor.max_yaw"]),
])
def test_bad_limits_are_refused_naming_the_field_exit_2(override, words):
    with pytest.raises(ScenarioError):
        load_scenario("l24-cv", [override])
    result = CliRunner().invoke(main, ["validate", "l24-cv", "--set", override])
    assert result.exit_code == 2, result.output
    assert all(w in result.output for w in words), result.output
    assert "Traceback" not in result.output


def test_the_section_is_refused_with_another_vehicle():
    with pytest.raises(ScenarioError, match="quadrotor is used only with vehicle: quadrotor"):
        load_scenario("l24-cv", ["swarm.vehicle=double_integrator", "swarm.quadrotor.max_roll_pitch=0.1"])
    load_scenario("l24-cv", ["swarm.vehicle=double_integrator"])  # at its defaults it is let through
