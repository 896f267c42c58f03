"""A new vehicle adds a module and a registration, not a branch in the world: a unicycle at constant speed defined
only in this test (outside the package), registered as a vehicle kind, flies as a driven target group and as the
swarm through :func:`swarmtrack.simulate`, its truth moving as its own model says, with no edit of the world."""

from types import SimpleNamespace

import numpy as np
import pytest

import swarmtrack
from swarmtrack import registry
from swarmtrack.onboard.context import command_width
from swarmtrack.scenarios.loader import ScenarioError
from swarmtrack.vehicles.base import Vehicle

NAME = "test-unicycle"
SPEED, TURN = 0.8, 0.3  # m/s; rad/s, the turn rate a driven unicycle draws every tick


def _initial_state(xy, heading, params):
    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    return np.column_stack([xy, heading])


def _step(state, u, params, dt, trig=None):
    """A unicycle (x, y, heading) at constant speed, turning at the rate ``u`` (explicit Euler)."""
    cos_h, sin_h = (np.cos(state[:, 2]), np.sin(state[:, 2])) if trig is None else trig
    out = state.copy()
    out[:, 0] += dt * params.speed * cos_h
    out[:, 1] += dt * params.speed * sin_h
    out[:, 2] += dt * np.asarray(u, dtype=float).reshape(len(state))
    return out


def _truth4(state, params, trig=None):
    cos_h, sin_h = (np.cos(state[:, 2]), np.sin(state[:, 2])) if trig is None else trig
    return np.column_stack([state[:, :2], params.speed * cos_h, params.speed * sin_h])


UNICYCLE = SimpleNamespace(
    STATE_DIM=3, HEADING=2, initial_state=_initial_state, step=_step, step_compiled=_step, truth4=_truth4,
    draw_inputs=lambda rng, n_ticks, n, params: np.full((n_ticks, n), params.turn))


@pytest.fixture
def unicycle():
    kind = registry.register_vehicle(Vehicle(NAME, "a toy unicycle", kinematic=UNICYCLE, command_width=1,
                                             params=lambda section: SimpleNamespace(speed=SPEED, turn=TURN)))
    yield kind
    registry.unregister(registry.VEHICLE, NAME)


def _euler(xy, heading, rate, dt, ticks):
    """The unicycle's positions after 1..ticks ticks (its own model, step by step)."""
    x, y, h, out = xy[0], xy[1], heading, []
    for _ in range(ticks):
        x, y, h = x + dt * SPEED * np.cos(h), y + dt * SPEED * np.sin(h), h + dt * rate
        out.append((x, y))
    return np.array(out)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_a_registered_unicycle_target_turns_as_its_model_says(unicycle, kernels):
    scenario = swarmtrack.load_scenario("l24-cv", [f"target.vehicle={NAME}", "target.start=[1, 2]",
                                                   "duration=2", f"kernels={kernels}"], seed=1)
    rec = swarmtrack.simulate(scenario)
    objects = rec.frame("objects")
    target = objects[objects["group"] == "targets"].sort_values("t")
    dt = 1 / scenario.rates.physics
    ticks = np.rint(target["t"].to_numpy() / dt).astype(int)
    expected = _euler((1.0, 2.0), 0.0, TURN, dt, ticks.max())
    got = target[["x", "y"]].to_numpy()
    moved = ticks > 0
    np.testing.assert_allclose(got[moved], expected[ticks[moved] - 1], atol=1e-9)
    assert np.linalg.norm(got[-1] - [1.0, 2.0]) > 1.0  # it moved, and turned left
    assert got[-1, 1] > 2.0


def test_a_registered_unicycle_swarm_takes_its_kinds_command_width(unicycle):
    scenario = swarmtrack.load_scenario("l24-cv", [f"swarm.vehicle={NAME}", "controller={kind: static}",
                                                   "duration=2"], seed=2)
    assert command_width(scenario) == 1
    rec = swarmtrack.simulate(scenario)
    objects = rec.frame("objects")
    uavs = objects[objects["group"] == "uavs"]
    first, last = uavs[uavs["t"] == uavs["t"].min()], uavs[uavs["t"] == uavs["t"].max()]
    # commanded to turn at rate 0 (the static controller's zeros): straight lines at the unicycle's speed
    speed = np.hypot(last["vx"].to_numpy(), last["vy"].to_numpy())
    np.testing.assert_allclose(speed, SPEED, rtol=1e-12)
    travelled = np.hypot(*(last[["x", "y"]].to_numpy() - first[["x", "y"]].to_numpy()).T)
    elapsed = last["t"].iloc[0] - first["t"].iloc[0]
    np.testing.assert_allclose(travelled, SPEED * elapsed, rtol=1e-9)


def test_an_unregistered_or_misplaced_vehicle_is_refused_in_one_line(unicycle):
    with pytest.raises(ScenarioError, match=r"swarm.vehicle: unknown vehicle 'boat'; the swarm can use: .*"
                                            + NAME):
        swarmtrack.load_scenario("l24-cv", ["swarm.vehicle=boat"])
    with pytest.raises(ScenarioError, match="vehicle 'fixed_wing' is not for a group; a group can use: "):
        swarmtrack.load_scenario("l24-cv", ["target.vehicle=fixed_wing"])
    with pytest.raises(ScenarioError, match="count is used only with vehicle: nearly_cv or walker"):
        swarmtrack.load_scenario("l24-cv", [f"target.vehicle={NAME}", "decoys.count=3"])


def test_a_vehicle_kind_is_stepped_one_way_and_registered_once(unicycle):
    with pytest.raises(ValueError, match="exactly one of physics and kinematic"):
        Vehicle("both", physics="quadrotor", kinematic=UNICYCLE)
    with pytest.raises(ValueError, match="already registered"):
        registry.register_vehicle(Vehicle(NAME, kinematic=UNICYCLE))
    assert registry.get(registry.VEHICLE, "fixed_wing").command_width == 1
    assert {n for n, k in registry.kinds(registry.VEHICLE).items() if k.pack} == {"walker", "fixed_wing"}
