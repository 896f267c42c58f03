"""The truth side of the live swarm: the world (truth, physics, sensors), the simulated radio and the recorder, in
one process that talks to the UAVs' processes only by messages.

In lockstep (:func:`run_lockstep`) it runs the simulator's step loop (:func:`swarmtrack.sim.engine.step_loop`) with
every call to the onboard stack replaced by messages: per estimation step it sends each UAV its navigation, its
detections and its radio (which of the other UAVs' messages reach it now: the scenario's channel, with its losses,
outages and delays, drawn from the same streams in the same order), and waits for every UAV's probes; per control
step it sends navigation and the beacon radio, and waits for every UAV's command before it advances. So a live run
records what ``swarmtrack run`` records, bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from swarmtrack.live import wire
from swarmtrack.live.agent import PATIENCE, scenario_hash, telemetry_of
from swarmtrack.live.node import Node
from swarmtrack.network.links import edge_list, rows_of
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.build import build
from swarmtrack.sim.recorder import Recorder, Recording


class LiveError(Exception):
    """The live run cannot go on (a UAV process that never came, a scenario mismatch): the message says which."""


def check_live(scenario: Scenario) -> None:
    """Refuse a scenario whose components cannot run live (:class:`LiveError` naming what)."""
    from swarmtrack import registry
    from swarmtrack.live.agent import build_onboard

    if scenario.network.liar is not None:
        raise LiveError("network.liar corrupts messages inside the simulated channel; in a live run a liar is a "
                        "UAV process of its own (not available yet)")
    for role in ("estimator", "controller"):
        kind = registry.get(role, getattr(scenario, role).kind)
        if kind.monitors is not None and kind.telemetry is None:
            raise LiveError(f"{role} {kind.name}: its truth-side checks read the onboard component, which runs in "
                            "the UAVs' processes, and it registers no telemetry for them")
    labels = {g: list(range(getattr(scenario, g).size())) for g in ("targets", "decoys")}
    try:
        build_onboard(scenario, 0, labels)
    except NotImplementedError as exc:
        raise LiveError(f"cannot run live: {exc}") from None


def labels_of(world) -> dict[str, list[int]]:
    """The sensor's label of every member of every sensed group (what each UAV's sensor reports, told to it at
    start)."""
    return {g: [world.label_of(sl.start + m) for m in range(sl.stop - sl.start)] for g, sl in world.slices.items()
            if g != "uavs"}


def run_lockstep(scenario: Scenario, node: Node, record_to=None, progress: Callable[[float], None] | None = None,
                 patience: float = PATIENCE) -> Recording:
    """Run ``scenario`` with its UAVs' stacks in their own processes (already started, reachable through
    ``node``); returns the recording (streamed to ``record_to`` when given)."""
    sim = build(scenario)
    world, channel, clock = sim.world, sim.channel, sim.clock
    n = scenario.swarm.n_uavs
    uavs = range(n)
    node.listen(("uav", "*", "hello"), ("uav", "*", "sample"), ("uav", "*", "command"))
    hello = node.wait("hello", uavs, 0, timeout=patience)
    wrong = [i for i, m in hello.items() if m.scenario != scenario_hash(scenario)]
    if wrong:
        raise LiveError(f"UAV processes {[i + 1 for i in wrong]} run another scenario (or seed, or overrides)")
    node.send("all", wire.Start(labels=labels_of(world)))
    aims = _aims(node.wait("sample", uavs, -1, timeout=patience))
    probes = {**sim.stack.probes, **dict.fromkeys(sim.monitors, ())}
    recorder = Recorder(sim.meta, world.n_objects, n, probes, record_to)
    telemetries = telemetry_of(scenario)
    components = {"estimator": sim.stack.estimator, "controller": sim.stack.controller}
    guided = sim.stack.guide is not sim.stack.estimator
    u = np.zeros((n, 2))
    report_every = max(1, clock.steps // 100)
    for k in range(clock.steps):
        t = k * clock.dt_estimation
        truth = world.truth()
        positions = truth[world.slices["uavs"], :2]
        nav = world.navigation()
        detections, _sources = world.sense(aim=aims if world.aims else None)
        links = channel.links(positions, t)
        delivered = channel.deliver(links, {"k": np.full(n, k)}, t)
        for i in uavs:
            node.send(i, wire.Navigation(k=k, taken=t, nav=wire.pack(nav[i:i + 1])))
            mine = detections.of_uavs([i])
            node.send(i, wire.DetectionsMsg(k=k, taken=t, fields={f: wire.pack(getattr(mine, f)) for f in FIELDS}))
            node.send(i, wire.Radio(k=k, taken=t, links=_heard(links, i), parts=[
                (int(part.payloads["k"][0]), _heard(part.links, i)) for part in delivered.parts()]))
        samples = node.wait("sample", uavs, k, timeout=patience)
        aims = _aims(samples)
        probes = {name: np.concatenate([wire.unpack(samples[i].probes[name]) for i in uavs])
                  for name in sim.stack.probes}
        for role, telemetry in telemetries.items():  # the truth side's copy of the UAVs' components, for the monitors
            telemetry.mirror(components[role], _stacked([samples[i].telemetry[role] for i in uavs]))
        recorder.record(t, truth, world.phase_index(), {**probes, **{k: f() for k, f in sim.monitors.items()}})
        if guided:  # an external tracker's view of the target (W20's motion capture), the UAV's row
            view = sim.stack.guide.view()
            for i in uavs:
                node.send(i, wire.Guide(k=k, taken=t, view=_row_of_view(view, i)))
        offset = 0
        for c, (control_now, ticks) in enumerate(clock.control_segments(k)):
            if control_now:
                if offset:  # a control step between estimation steps: fresh navigation
                    nav = world.navigation()
                    positions = world.truth("uavs")[:, :2]
                beacons = channel.beacon_links(positions, world.t)
                for i in uavs:
                    node.send(i, wire.Navigation(k=k, c=c, taken=world.t, nav=wire.pack(nav[i:i + 1])))
                    node.send(i, wire.Radio(k=k, c=c, taken=world.t, beacons=_heard(beacons, i)))
                commands = node.wait("command", uavs, k, c, timeout=patience)
                u = np.concatenate([wire.unpack(commands[i].u) for i in uavs])
            world.advance({"uavs": u}, ticks)
            offset += ticks
        if progress is not None and (k % report_every == 0 or k == clock.steps - 1):
            progress((k + 1) / clock.steps)
    node.send("all", wire.Stop())
    return recorder.close()


FIELDS = ("owner", "z", "sensor_pos", "label", "n_uavs", "grid", "frame", "footprint", "taken")


def _heard(links, i: int) -> list[int]:
    """The senders UAV i's row of ``links`` holds."""
    return edge_list(rows_of(links, np.array([i])))[1].tolist()


def _row_of_view(view, i: int) -> dict:
    """UAV i's row of a :class:`~swarmtrack.estimation.base.TargetView` (its state, model and motion), packed."""
    return {name: wire.pack(getattr(view, name)[i:i + 1]) for name in ("state", "model", "motion")
            if getattr(view, name) is not None}


def _stacked(rows: list[dict]) -> dict[str, np.ndarray]:
    """The UAVs' reports (each ``{name: packed (1, ...)}``) as the swarm's ``{name: (N, ...)}``."""
    return {name: np.concatenate([wire.unpack(r[name]) for r in rows]) for name in rows[0]}


def _aims(samples: dict[int, wire.Sample]) -> np.ndarray:
    return np.concatenate([wire.unpack(samples[i].aim) for i in sorted(samples)])
