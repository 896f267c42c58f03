"""The compiled world steps its walkers and fixed wings together (``_KinematicPack``): the numbers of the readable
per-group references, to the last bit, also when walkers reflect at the walls of a small area."""

import numpy as np

from swarmtrack.sensors import footprint
from swarmtrack.sim.sensors import FootprintSensor
from swarmtrack.sim.streams import stream
from swarmtrack.sim.world import Group, World
from swarmtrack.vehicles.fixed_wing import FixedWingParams
from swarmtrack.vehicles.ground_walker import WalkerParams

TICKS = 400


def _world(compiled: bool) -> World:
    """Three targets and two decoys walking fast in a 6 m box (they hit its walls every few ticks) and four fixed
    wings with a low yaw-rate bound (the commands saturate it)."""
    rng = np.random.default_rng(3)
    box = WalkerParams(speed=1.8, area=(0.0, 0.0, 6.0, 6.0))
    groups = [Group("targets", "walker", rng.uniform(0.5, 5.5, (3, 2)), params=box, heading=rng.uniform(-3, 3, 3)),
              Group("decoys", "walker", rng.uniform(0.5, 5.5, (2, 2)), params=box, heading=rng.uniform(-3, 3, 2)),
              Group("uavs", "fixed_wing", rng.uniform(0, 400, (4, 2)), params=FixedWingParams(yaw_rate_max=0.2),
                    heading=rng.uniform(-3, 3, 4))]
    sensor = FootprintSensor(footprint.FootprintParams(), *footprint.draw_cones(rng, 5),
                             np.r_[np.zeros(3, bool), np.ones(2, bool)], footprint.confusion_map(2, 3))
    return World(groups, sensor, dt=0.05, ticks=TICKS, nav_std=(0.0, 0.0), streams=lambda p: stream(7, p),
                 compiled=compiled)


def test_the_packed_kinematic_groups_step_as_their_references_bit_for_bit():
    ref, fast = _world(False), _world(True)
    assert fast._pack is not None and ref._pack is None
    commands = np.random.default_rng(4).uniform(-2.0, 2.0, (TICKS, 4, 1))
    crossed = saturated = 0
    for k in range(TICKS):
        walkers = np.concatenate([ref.kinematic("targets").state, ref.kinematic("decoys").state])
        ahead = walkers[:, :2] + 0.05 * 1.8 * np.stack([np.cos(walkers[:, 2]), np.sin(walkers[:, 2])], axis=1)
        crossed += bool(np.any((ahead < 0.0) | (ahead > 6.0)))  # a tick the reference folds a path
        for world in (ref, fast):
            world.advance({"uavs": commands[k]}, 1)
        saturated += bool(np.any(np.abs(ref.kinematic("uavs").state[:, 5]) == 0.2))
        np.testing.assert_array_equal(fast.truth(), ref.truth())
        for name in ("targets", "decoys", "uavs"):
            np.testing.assert_array_equal(fast.kinematic(name).state, ref.kinematic(name).state, err_msg=name)
            np.testing.assert_array_equal(fast.kinematic(name).trig(), ref.kinematic(name).trig(), err_msg=name)
    np.testing.assert_array_equal(fast.navigation(), ref.navigation())
    assert crossed > 10 and saturated > 10  # the walls and the yaw-rate bound were exercised
