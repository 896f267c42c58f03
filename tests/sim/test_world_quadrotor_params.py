"""The world flies each quadrotor group with its own parameters (the swarm's ``quadrotor`` section, W20 Sec. 5.4.2's
5° roll/pitch saturation): the UAVs hold the limit, quadrotor targets keep the defaults, defaults change nothing."""

import numpy as np
import pytest

from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.build import build
from swarmtrack.vehicles import quadrotor

LIMIT = np.radians(5.0)
TOL = 1e-9  # compiled against numpy: only sin/cos/atan/hypot come from another libm


def _world(name, overrides, kernels):
    return build(load_scenario(name, [*overrides, f"kernels={kernels}"])).world


def test_a_default_swarm_is_the_default_vehicle():
    world = _world("l24-cv", [], "numpy")
    assert world.params == quadrotor.DEFAULT_PARAMS and not isinstance(world.params, quadrotor.RowParams)


@pytest.mark.parametrize("kernels", ["numpy", "compiled"])
def test_the_swarm_holds_its_roll_pitch_limit(kernels):
    world = _world("w20-mpc-formation", [], kernels)
    assert world.params.max_roll_pitch == pytest.approx(LIMIT, rel=1e-15)
    rows = world._row[world.slices["uavs"]]
    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(40):
        world.advance({"uavs": rng.normal(0.0, 3.0, (3, 2))}, 25)
        worst = max(worst, np.abs(world._quads[rows, 4:6]).max())
    assert LIMIT * 0.99 < worst <= LIMIT * 1.02  # the setpoint limit plus the attitude loop's < 2 % overshoot


def test_quadrotor_targets_keep_the_defaults_beside_a_limited_swarm():
    limited = ["swarm.quadrotor.max_roll_pitch=0.08726646259971647"]
    ref, lim, fast = (_world("l24-cv", o, k) for o, k in (([], "numpy"), (limited, "numpy"), (limited, "compiled")))
    assert isinstance(lim.params, quadrotor.RowParams) and len(lim.params.sets) == 2
    target = ref.slices["targets"]
    cmd = np.full((3, 2), 3.0)
    for _ in range(100):
        for w in (ref, lim):
            for _ in range(10):
                w.advance({"uavs": cmd}, 1)
        fast.advance({"uavs": cmd}, 10)
        np.testing.assert_array_equal(lim.truth()[target], ref.truth()[target])  # the target as without the limit
        np.testing.assert_allclose(fast.truth(), lim.truth(), rtol=TOL, atol=TOL)
    uavs = lim._row[lim.slices["uavs"]]
    assert np.abs(lim._quads[uavs, 4:6]).max() <= LIMIT * 1.02 < np.abs(ref._quads[uavs, 4:6]).max()
