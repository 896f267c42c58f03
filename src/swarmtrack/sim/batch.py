"""Many worlds per process: several seeds of one scenario run as one vectorised batch.

The B worlds of a batch share one layout (the same scenario, seeds apart), so they fold into the arrays the
components already vectorise over: every group holds B blocks of members (world b's block b), the UAVs are
``B·N`` rows, each world's UAVs follow their own world's target (a label per UAV), its links are a block of a
block-diagonal array (:class:`~swarmtrack.network.channel.WorldsChannel`), and its UAVs sense only its own objects.
Each world draws from its own seed's streams exactly what it would draw alone, so a world of a batch gives the
numbers of its scenario run alone (to round-off in the order of summation; a test holds them equal). The step
loop is :func:`swarmtrack.sim.engine.step_loop`, unchanged; the recording is cut into one per world at the end.

The per-step Python cost is paid once for the batch instead of once per world, which is what small swarms spend
their time on. Components with state that is not per UAV, or whose settings name UAVs, are not batched
(:func:`unbatchable` says why): kinds not registered as ``batched`` (the centralized filter, the set-membership
estimator and its MPC), kinematic vehicles, occluders, outages, delays and liars. A truth oracle
(``controller.follow: truth``) is one per world, each following its own world's target.
"""

from __future__ import annotations

import numpy as np

from swarmtrack import registry
from swarmtrack.estimation.base import TargetView
from swarmtrack.network.channel import Channel, WorldsChannel
from swarmtrack.onboard.build import onboard_stack
from swarmtrack.onboard.context import clock_of, context
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.build import (
    Simulation,
    _group,
    _oracle,
    sensor_of,
    spawn_positions,
)
from swarmtrack.sim.engine import step_loop
from swarmtrack.sim.meta import profiles, run_meta
from swarmtrack.sim.oracle import TruthOracle
from swarmtrack.sim.recorder import Chunk, Recorder, Recording
from swarmtrack.sim.streams import stream
from swarmtrack.sim.world import Group, World, vehicle


def batched_kinds(role: str) -> list[str]:
    """What a batch can hold: the kinds of ``role`` registered as ``batched`` (components that keep per-UAV state
    only and name no UAV)."""
    return [name for name, kind in registry.kinds(role).items() if kind.batched]


def unbatchable(scenarios: list[Scenario]) -> str | None:
    """Why these scenarios cannot run as one batch, or None when they can (the same scenario but for the seed)."""
    first = scenarios[0]
    same = first.model_dump(exclude={"seed"})
    if any(s.model_dump(exclude={"seed"}) != same for s in scenarios[1:]):
        return "the scenarios differ in more than the seed"
    for role in registry.ROLES:
        kind = getattr(first, role).kind
        if not registry.get(role, kind).batched:
            return f"{role}.kind {kind!r} is not batched (batched: {', '.join(batched_kinds(role))})"
    kinematic = [f"{section}.vehicle {v!r}" for section, v in
                 (("swarm", first.swarm.vehicle), ("targets", first.targets.vehicle),
                  ("decoys", first.decoys.vehicle)) if vehicle(v).is_kinematic]
    if kinematic:
        return f"{', '.join(kinematic)}: kinematic vehicles are not batched"
    if first.sensor.occluders or first.network.outages:
        return "occluders and outages name UAVs of one world"
    if getattr(first.sensor, "detection_probability", 1.0) < 1 or getattr(first.sensor, "clutter_rate", 0.0) > 0 \
            or getattr(first.sensor, "detection_falloff", 0.0) > 0:
        return "misses and clutter are drawn per world"
    if not getattr(first.sensor, "labelled", True):
        return "a batch tells its worlds' objects apart by their labels"
    if first.network.delay_bound() or first.network.liar is not None:
        return "network delays and liars (kept per world)"
    return None


def _concat_group(name: str, specs: list[Scenario], flown: list[dict]) -> Group:
    """One group holding every world's members, world-major."""
    groups = [_group(name, getattr(s, name), f[name]) for s, f in zip(specs, flown, strict=True)]
    g0 = groups[0]
    starts = np.concatenate([g.start.reshape(-1, 2) for g in groups])
    if g0.driver is None:
        return Group(name, g0.vehicle, starts)
    driver = type(g0.driver)(sum((g.driver.profiles for g in groups), ()), g0.driver.gain, g0.driver.wind_std)
    return Group(name, g0.vehicle, starts, driver)


class WorldsOracle:
    """The truth oracles of a batch's worlds (one per world, of its N UAVs, each following its own world's target),
    as one: their views stacked world-major."""

    probes = ()

    def __init__(self, oracles: list[TruthOracle]):
        self.oracles = oracles

    def share(self, t, nav, own) -> dict:
        return {}

    def fuse(self, t, own, inbox) -> None:
        pass

    def view(self) -> TargetView:
        views = [o.view() for o in self.oracles]

        def stacked(field: str):
            parts = [getattr(v, field) for v in views]
            return None if parts[0] is None else np.concatenate(parts)

        return TargetView(stacked("state"), stacked("model"), stacked("motion"))

    def sample(self) -> dict:
        return {}


def build_batch(scenarios: list[Scenario]) -> tuple[Simulation, list[dict]]:
    """The batch of ``scenarios`` (checked by :func:`unbatchable`) as one :class:`Simulation`, and each world's
    recording metadata (what :func:`~swarmtrack.sim.build.build` gives it alone)."""
    why = unbatchable(scenarios)
    if why is not None:
        raise ValueError(f"cannot batch these runs: {why}")
    first = scenarios[0]
    clock = clock_of(first)
    n, worlds = first.swarm.n_uavs, len(scenarios)
    flown = [{g: profiles(s, g) for g in ("targets", "decoys")} for s in scenarios]
    uavs = Group("uavs", first.swarm.vehicle,
                 np.concatenate([spawn_positions(s, stream(s.seed, "spawn")) for s in scenarios]),
                 params=vehicle(first.swarm.vehicle).make_params(first.swarm))
    groups = [_concat_group("targets", scenarios, flown), _concat_group("decoys", scenarios, flown), uavs]
    world = World(groups, sensor_of(first), dt=clock.dt,
                  ticks=clock.steps * clock.ticks_estimation,
                  nav_std=(first.swarm.nav_position_std, first.swarm.nav_velocity_std),
                  streams=[lambda purpose, seed=s.seed: stream(seed, purpose) for s in scenarios],
                  compiled=first.kernels != "numpy")
    per = {name: (sl.stop - sl.start) // worlds for name, sl in world.slices.items()}

    def label_of(group: str, member: int) -> np.ndarray:
        """Per UAV: the label of its own world's ``member`` of ``group``."""
        objects = world.slices[group].start + np.arange(worlds) * per[group] + member
        return np.repeat([world.label_of(o) for o in objects], n)

    ctx = context(first, label_of, worlds=worlds)
    stack = onboard_stack(ctx)
    followed = first.estimator.followed_target()
    if first.controller.follows_truth():  # each world's UAVs told their own world's target (the schema checked it)
        start = world.slices["targets"].start
        stack.guide = WorldsOracle([_oracle(world, start + b * per["targets"] + followed - 1,
                                      f["targets"][followed - 1], n) for b, f in enumerate(flown)])
    net = first.network
    channel = WorldsChannel(tuple(Channel(net.topology, n, net.r_comm, tuple((a - 1, b - 1) for a, b in net.edges),
                                          net.loss_probability, stream(s.seed, "channel")) for s in scenarios), n)
    ends = np.cumsum(list(per.values()))
    local = {name: slice(int(end - per[name]), int(end)) for name, end in zip(per, ends, strict=True)}  # one world's
    metas = [run_meta(s, local, f, clock.dt_estimation) for s, f in zip(scenarios, flown, strict=True)]
    batch_meta = {**metas[0], "seed": None, "groups": {k: [v.start, v.stop] for k, v in world.slices.items()},
                  "tracked": None, "tracked_label": None, "worlds": worlds}
    sim = Simulation(world, stack, channel, clock, batch_meta)
    return sim, metas


def simulate_batch(scenarios: list[Scenario], progress=None) -> list[Recording]:
    """Run several seeds of one scenario as one batch; one in-memory recording per world, in the given order."""
    sim, metas = build_batch(scenarios)
    n = scenarios[0].swarm.n_uavs
    recording = step_loop(sim, Recorder(sim.meta, sim.world.n_objects, n * len(scenarios), sim.stack.probes),
                          progress)
    out = []
    for b, meta in enumerate(metas):
        objects = np.flatnonzero(sim.world.world_of == b)
        rows = slice(b * n, (b + 1) * n)
        chunks = [Chunk(c.k0, c.t, c.truth[:, objects], c.phase[:, objects],
                        {k: v[:, rows] for k, v in c.probes.items()}) for c in recording.chunks()]
        out.append(Recording({**recording.meta, **meta, "n_objects": len(objects), "n_uavs": n}, chunks))
    return out
