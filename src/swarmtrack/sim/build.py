"""From a scenario to a runnable simulation: world, onboard stack, channel, recorder metadata.

The sensor, estimator and controller are built by the builders their kinds registered
(:mod:`swarmtrack.registry`; the built-in ones in :mod:`swarmtrack.capabilities`), so a new capability adds modules
and a registration, never a branch here or in the engine.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from swarmtrack import registry
from swarmtrack.network.channel import Channel
from swarmtrack.network.exchange import channel_of
from swarmtrack.network.links import edge_list, proximity_links
from swarmtrack.onboard.build import component, onboard_stack
from swarmtrack.onboard.context import clock_of, context, sensor_labels
from swarmtrack.onboard.stack import OnboardStack
from swarmtrack.scenarios.schema import GroupSpec, Scenario, SensorSpec
from swarmtrack.scenarios.spawn import on_lattice
from swarmtrack.sim.clock import Clock
from swarmtrack.sim.meta import profiles, run_meta
from swarmtrack.sim.oracle import TruthOracle
from swarmtrack.sim.sensors import Occluder, Sensor, hidden_by
from swarmtrack.sim.streams import stream
from swarmtrack.sim.world import Group, ProfileDriver, World, vehicle
from swarmtrack.vehicles.altitude import GroupAltitude
from swarmtrack.vehicles.quadrotor import DEFAULT_PARAMS


def occluders(s: SensorSpec) -> tuple[Occluder, ...]:
    """The world's occluders of a sensor's settings (0-based UAVs)."""
    return tuple(Occluder(o.region, o.window, tuple(u - 1 for u in o.uavs)) for o in s.occluders)


def sensor_of(scenario: Scenario) -> Sensor:
    """The world's sensor (its kind's truth-side builder). It senses the groups its settings declare
    (:attr:`SensorSpec.sensed <swarmtrack.scenarios.schema.SensorSpec.sensed>`), whose labels the UAVs' builders
    get (:func:`~swarmtrack.onboard.context.sensor_labels`): a kind whose two sides disagree is refused by name."""
    sensor = component("sensor", scenario, scenario)
    if tuple(sensor.sensed) != tuple(scenario.sensor.sensed):
        raise TypeError(f"sensor kind {scenario.sensor.kind}: its truth side senses {sensor.sensed}, its settings "
                        f"declare sensed = {scenario.sensor.sensed}")
    return sensor


def spawn_positions(scenario: Scenario, rng: np.random.Generator) -> np.ndarray:
    """Initial UAV positions: the scenario's, or seeded uniform draws in the spawn box, kept apart; a swarm too
    dense to be drawn so (random placement jams) on the hexagonal lattice of the box
    (:func:`swarmtrack.scenarios.spawn.on_lattice`), which validation has checked holds it."""
    sw = scenario.swarm
    if sw.initial_positions is not None:
        return np.asarray(sw.initial_positions, dtype=float)
    center = np.asarray(sw.spawn_center)
    pos = center + rng.uniform(-sw.spawn_half_width, sw.spawn_half_width, size=(sw.n_uavs, 2))
    for _ in range(10_000):  # redraw the UAVs that are too close to an earlier one (near jamming: thousands)
        close = _too_close(pos, sw.min_separation)
        if not close.any():
            break
        pos[close] = center + rng.uniform(-sw.spawn_half_width, sw.spawn_half_width, size=(close.sum(), 2))
    else:
        return on_lattice(sw.n_uavs, center, sw.spawn_half_width, sw.min_separation, rng)
    return pos


def _too_close(pos: np.ndarray, min_sep: float) -> np.ndarray:
    """UAVs closer than ``min_sep`` to an earlier UAV (the links of a proximity graph of range ``min_sep``: dense
    for small swarms, a KD-tree for large ones)."""
    close = np.zeros(len(pos), dtype=bool)
    if min_sep > 0 and len(pos) > 1:
        receivers, senders = edge_list(proximity_links(pos, min_sep))
        close[np.maximum(receivers, senders)] = True
    return close


def _altitude(scenario: Scenario, kind: str, z0, hold=None) -> GroupAltitude | None:
    """A group's altitude channel in a 3-D world (a sensor that reads heights, ``three_d``), else None: quadrotors
    climb through their thrust (:meth:`~swarmtrack.vehicles.altitude.GroupAltitude.quadrotor`, the default Iris's
    mass and thrust), other vehicles as double integrators."""
    if not getattr(scenario.sensor, "three_d", False):
        return None
    if vehicle(kind).physics == "quadrotor":
        p = DEFAULT_PARAMS
        assert p.max_thrust is not None  # its __post_init__ sets it
        return GroupAltitude.quadrotor(z0, p.mass, p.g, p.max_thrust, hold=hold)
    return GroupAltitude(np.asarray(z0, dtype=float), hold=None if hold is None else np.asarray(hold, dtype=float))


def _group(name: str, spec: GroupSpec, flown: tuple, seed: int = 0, scenario: Scenario | None = None) -> Group:
    starts = np.asarray([m.start for m in spec.members], dtype=float).reshape(-1, 2)
    kind = vehicle(spec.vehicle)
    if kind.is_kinematic:  # the listed members, then `count` at uniform places and headings (IB21 Sec. 6)
        rng = stream(seed, f"spawn/{name}")
        x0, y0, x1, y1 = spec.area
        starts = np.concatenate([starts, rng.uniform((x0, y0), (x1, y1), size=(spec.count, 2))])
        heading = np.concatenate([[m.heading for m in spec.members], rng.uniform(-np.pi, np.pi, spec.count)])
        return Group(name, spec.vehicle, starts, params=kind.make_params(spec), heading=heading)
    altitude = None if scenario is None else _altitude(scenario, spec.vehicle, [m.altitude for m in spec.members])
    return Group(name, spec.vehicle, starts, ProfileDriver(flown, spec.velocity_gain, spec.wind_std),
                 altitude=altitude)


def _uavs(scenario: Scenario) -> Group:
    """The swarm at its spawn positions; kinematic vehicles (fixed wings) also with their parameters and seeded
    uniform headings (stream ``spawn/headings``)."""
    sw = scenario.swarm
    starts = spawn_positions(scenario, stream(scenario.seed, "spawn"))
    kind = vehicle(sw.vehicle)
    if not kind.is_kinematic:
        heights = np.full(sw.n_uavs, sw.altitude)
        return Group("uavs", sw.vehicle, starts, params=kind.make_params(sw),
                     altitude=_altitude(scenario, sw.vehicle, heights, hold=heights))
    heading = stream(scenario.seed, "spawn/headings").uniform(-np.pi, np.pi, sw.n_uavs)
    return Group("uavs", sw.vehicle, starts, params=kind.make_params(sw), heading=heading)


def _oracle(world: World, tracked: int, profile, n: int) -> TruthOracle:
    """The truth oracle for the followed target: its state, the model its profile flies now, and which UAVs the
    sensor's occluders blind."""
    def kinematics():
        return profile.velocity(world.t), profile.acceleration(world.t)

    def blind():
        hidden = hidden_by(world.sensor.occluders, world.truth()[tracked, None, :2], n, world.t)
        return np.zeros(n, dtype=bool) if hidden is None else hidden[:, 0]

    return TruthOracle(lambda: world.truth()[tracked], n, kinematics=kinematics, blind=blind, now=lambda: world.t)


@dataclass
class Truth:
    """The truth side of a run: the world, the channel (the radio: who hears whom, from the true positions), the
    clock, the recording's metadata, and the oracle a controller following the truth is given (None: it follows
    the estimator)."""

    world: World
    channel: Channel
    clock: Clock
    meta: dict
    oracle: TruthOracle | None = None


@dataclass
class Simulation:
    """Everything one run needs: the truth, the onboard stack, the channel, the clock and the recording's
    metadata."""

    world: World
    stack: OnboardStack
    channel: Channel
    clock: Clock
    meta: dict
    monitors: dict = dataclasses.field(default_factory=dict)
    """Truth-side checks recorded beside the probes: name → a function giving (N,) values (never onboard)."""


def truth_side(scenario: Scenario) -> Truth:
    """The truth side of a validated scenario (:class:`Truth`; random streams derived by purpose from its seed): what
    the simulator runs beside the onboard stack, and the live world runs alone."""
    clock = clock_of(scenario)
    dt_phys, dt_est = clock.dt, clock.dt_estimation
    compiled = scenario.kernels != "numpy"  # one decision for every compiled fast path (onboard.context too)
    seed = scenario.seed
    flown = {g: profiles(scenario, g) for g in ("targets", "decoys")}
    groups = [_group("targets", scenario.targets, flown["targets"], seed, scenario),
              _group("decoys", scenario.decoys, flown["decoys"], seed, scenario), _uavs(scenario)]
    world = World(groups, sensor_of(scenario),
                  dt=dt_phys, ticks=clock.steps * clock.ticks_estimation,
                  nav_std=(scenario.swarm.nav_position_std, scenario.swarm.nav_velocity_std),
                  streams=lambda purpose: stream(seed, purpose), compiled=compiled)
    oracle = None
    if scenario.controller.follows_truth():
        followed = scenario.estimator.followed_target()  # 1-based member of targets
        assert followed is not None, "the schema checked that the estimator follows a target"
        oracle = _oracle(world, world.slices["targets"].start + followed - 1, flown["targets"][followed - 1],
                         scenario.swarm.n_uavs)
    return Truth(world, channel_of(scenario, dt_est), clock, run_meta(scenario, world.slices, flown, dt_est), oracle)


def build(scenario: Scenario) -> Simulation:
    """Wire a validated scenario into a :class:`Simulation`: its truth side and the whole swarm's onboard stack."""
    truth = truth_side(scenario)
    stack = onboard_stack(context(scenario, sensor_labels(scenario)))
    if truth.oracle is not None:
        stack.guide = truth.oracle
    return Simulation(truth.world, stack, truth.channel, truth.clock, truth.meta,
                      monitors(scenario, truth.world, {"estimator": stack.estimator, "controller": stack.controller}))


def monitors(scenario: Scenario, world: World, components: dict) -> dict[str, Callable[[], np.ndarray]]:
    """The truth-side checks the run's kinds registered (:attr:`swarmtrack.registry.Kind.monitors`), recorded beside
    the probes, (N,) each; never onboard."""
    out = {}
    for role, built in components.items():
        kind = registry.get(role, getattr(scenario, role).kind)
        if kind.monitors is not None:
            out.update(registry.resolve(kind.monitors)(world, built))
    return out
