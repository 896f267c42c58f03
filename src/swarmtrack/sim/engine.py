"""The engine: one clock, and the same step loop for every capability.

Per estimation step: sense → the stack's estimation step
(:meth:`~swarmtrack.onboard.stack.OnboardStack.estimation_step`: share → broadcast → deliver → fuse → publish →
deliver → combine) → record; then, per control step until the next
estimation step: the stack's control step (deliver the beacons → command) → advance. The messages travel over the
simulated channel (:class:`~swarmtrack.network.exchange.ChannelExchange`). What is sensed, shared, fused and
commanded is the business of the components the builder (:mod:`swarmtrack.sim.build`) wired from the scenario; this
loop has no branch per capability. It is the only place where truth (for the recorder) and onboard state meet.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from swarmtrack.network.exchange import ChannelExchange
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.build import Simulation, build
from swarmtrack.sim.recorder import Recorder, Recording
from swarmtrack.streams.frame import shapes_of


def simulate(scenario: Scenario, progress: Callable[[float], None] | None = None,
             record_to: Path | None = None, on_step: Callable[[Simulation], None] | None = None,
             inputs: bool | None = None, taps=()) -> Recording:
    """Run one closed-loop simulation and return its recording (kept in memory, or streamed to ``record_to``).
    Same scenario and seed, same numbers. ``on_step``: see :func:`step_loop`. ``inputs``: keep the onboard
    stack's inputs (navigation and detections, :mod:`swarmtrack.sim.inputs`) so the run can be replayed; by
    default a recording streamed to ``record_to`` keeps them and one in memory does not. ``taps``: live outputs
    sent each recorded step (:class:`~swarmtrack.streams.frame.Tap`)."""
    sim = build(scenario)
    return step_loop(sim, recorder_of(sim, scenario, record_to, inputs, taps), progress, on_step)


def recorder_of(sim: Simulation, scenario: Scenario, record_to: Path | None = None, inputs: bool | None = None,
                taps=()) -> Recorder:
    """The recorder of a built simulation's run (:func:`simulate`'s arguments)."""
    probes = {**sim.stack.probes, **dict.fromkeys(sim.monitors, ())}
    return Recorder(sim.meta, sim.world.n_objects, scenario.swarm.n_uavs, probes, record_to,
                    inputs=record_to is not None if inputs is None else inputs, taps=taps,
                    shapes=shapes_of(scenario.estimator.kind, sim.stack.estimator))


def step_loop(sim: Simulation, recorder: Recorder, progress: Callable[[float], None] | None = None,
              on_step: Callable[[Simulation], None] | None = None) -> Recording:
    """Run a built simulation to its end, recording every estimation step. ``on_step(sim)`` (truth side, e.g. the
    animation's frame capture) is called after each estimation step's record, before the control; it may read the
    simulation, never change it."""
    world, stack, clock = sim.world, sim.stack, sim.clock
    exchange = ChannelExchange(sim.channel)
    uavs = world.slices["uavs"]
    u = np.zeros((uavs.stop - uavs.start, 2))
    report_every = max(1, clock.steps // 100)
    aims = world.aims  # only a gimballed sensor reads the estimates (computing them is not free)
    for k in range(clock.steps):
        t = k * clock.dt_estimation
        truth = world.truth()
        positions = truth[uavs, :2]
        nav = world.navigation()
        # sources: the world's, never onboard; a gimballed sensor aims at its UAV's latest estimate
        detections, _sources = world.sense(aim=stack.estimator.view().state[:, :2] if aims else None)
        segments = list(clock.control_segments(k))
        control = world.t if segments[0][0] else None  # a control step starts with this one: its beacon now
        beacon = stack.estimation_step(t, nav, detections, exchange.at(positions), control)
        recorder.record_inputs(k, t, nav, detections)
        recorder.record(t, world.recorded_truth(truth), world.phase_index(),
                        {**stack.sample(), **{k: f() for k, f in sim.monitors.items()}})
        if on_step is not None:
            on_step(sim)
        view = stack.guide.view()
        offset = 0  # physics ticks since the estimation step
        for control_now, ticks in segments:
            if control_now:
                if offset:  # a control step between estimation steps: fresh navigation
                    nav = world.navigation()
                    positions = world.truth("uavs")[:, :2]
                u = stack.control_step(world.t, nav, view, exchange.at(positions), clock.dt_control,
                                       None if offset else beacon)
            world.advance({"uavs": u}, ticks)
            offset += ticks
        if progress is not None and (k % report_every == 0 or k == clock.steps - 1):
            progress((k + 1) / clock.steps)
    return recorder.close()
