"""W20 Ch. 4's error budget as scenarios (issue 27): the ideal variants stay the ideal camera, the budget is what
the paper module's one-source variants add up to, and the imperfect camera's draws are per world and UAV."""

import numpy as np
import pytest

from swarmtrack.analysis.papers import w20
from swarmtrack.capabilities.multi_model.sensor import CompiledCamera, ImperfectCamera
from swarmtrack.scenarios import load_scenario
from swarmtrack.scenarios.loader import ScenarioError
from swarmtrack.sim.batch import simulate_batch
from swarmtrack.sim.build import build
from swarmtrack.sim.engine import simulate
from swarmtrack.sim.sensors import CameraSensor

BUDGET_KEYS = {"noise_distance_power", "noise_angle_power", "servo_deadband", "servo_speed", "servo_zero_std",
               "mount_offset_std", "latency"}


@pytest.mark.parametrize("name", list(w20.IDEAL))
def test_each_ideal_variant_is_its_scenario_without_the_budget(name):
    budget, ideal = load_scenario(name).model_dump(), load_scenario(w20.IDEAL[name]).model_dump()
    assert ideal["name"] == f"{name}-ideal"
    for key in ("name", "description"):
        budget.pop(key), ideal.pop(key)
    assert {k for k in budget["sensor"] if budget["sensor"][k] != ideal["sensor"][k]} == BUDGET_KEYS
    for k in BUDGET_KEYS:
        budget["sensor"].pop(k), ideal["sensor"].pop(k)
    assert budget == ideal
    assert type(build(load_scenario(w20.IDEAL[name], ["kernels=numpy"])).world.sensor) is CameraSensor
    assert type(build(load_scenario(w20.IDEAL[name])).world.sensor) is CompiledCamera  # its frames compiled
    assert type(build(load_scenario(name)).world.sensor) is ImperfectCamera


def test_the_budget_variants_add_up_to_the_budget_scenario():
    """The paper's one-source variants switch on exactly the budget of ``w20-switching`` (optitrack: its 1 mm is
    in both; its variant switches it off)."""
    on = [o for key, (_, overrides, _) in w20.BUDGET.items() if key != "optitrack" for o in overrides]
    assert load_scenario(w20.BUDGET_BASE, [*on, "name=w20-switching"]).model_dump(exclude={"description"}) == \
        load_scenario("w20-switching").model_dump(exclude={"description"})
    off = load_scenario(w20.BUDGET_BASE, list(w20.BUDGET["optitrack"][1])).swarm
    assert off.nav_position_std == off.nav_velocity_std == 0 < load_scenario("w20-switching").swarm.nav_position_std


@pytest.mark.parametrize(("key", "value"), [("servo_deadband", "-1"), ("servo_speed", "0"),
                                            ("mount_offset_std", "-0.1"), ("noise_angle_power", "9")])
def test_a_bad_budget_value_is_refused_naming_its_field(key, value):
    with pytest.raises(ScenarioError, match=key):
        load_scenario("w20-switching", [f"sensor.{key}={value}"])


def _constants(scenario) -> tuple[np.ndarray, np.ndarray]:
    sim = build(scenario)
    sim.world.sense(aim=None)
    return sim.world.sensor.state["offset"], sim.world.sensor.state["zero"]


def test_calibration_constants_differ_by_uav_and_seed_at_their_stated_size():
    offsets, zeros = zip(*(_constants(load_scenario("w20-switching", seed=s)) for s in range(1, 21)), strict=True)
    offsets, zeros = np.concatenate(offsets), np.concatenate(zeros)  # 20 seeds x 3 UAVs
    assert len(np.unique(offsets[:, 0])) == len(offsets)
    # 60 draws of N(0, 5 mm) and N(0, 1°) per axis: their std within 30 % (3 standard errors)
    np.testing.assert_allclose(offsets.std(axis=0), 0.005, rtol=0.3)
    np.testing.assert_allclose(np.degrees(zeros.std(axis=0)), 1.0, rtol=0.3)
    # without calibration errors the noise streams are not drawn for them
    exact = _constants(load_scenario("w20-switching", ["sensor.servo_zero_std=0", "sensor.mount_offset_std=0"]))
    assert not np.any(exact[0]) and not np.any(exact[1])


@pytest.mark.slow
@pytest.mark.parametrize("name", ["w20-switching", "w20-switching-ideal"])
def test_each_world_of_a_batch_senses_as_it_does_alone(name):
    """The imperfect camera's servo state and calibration draws are per world and UAV (and the ideal one's)."""
    scenarios = [load_scenario(name, ["duration=5", "estimator.solo_steps=30"], seed=s) for s in (1, 2, 3)]
    for batched, s in zip(simulate_batch(scenarios), scenarios, strict=True):
        alone = simulate(s)
        np.testing.assert_array_equal(batched.estimate, alone.estimate)
        np.testing.assert_array_equal(batched.uav, alone.uav)
