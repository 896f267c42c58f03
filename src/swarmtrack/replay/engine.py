"""The replay loop: the simulator's estimation step, with the world's sensing replaced by a log.

Per step: the stack's estimation step (:meth:`~swarmtrack.onboard.stack.OnboardStack.estimation_step`) → record,
exactly as :func:`swarmtrack.sim.engine.step_loop` does it, on the navigation and detections a log reader gives
(:class:`~swarmtrack.replay.steps.StepInputs`). The messages between UAVs are the scenario's: its channel (topology,
losses, delays, outages, from the scenario's seeded streams) carries what the estimators share, over the links the
UAVs' logged positions give. The controller is not run (its commands would fly nothing), so a channel that draws
losses draws them for the estimation links only: a replay of a lossy run draws other losses than the run did, whose
flocking beacons drew from the same stream.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from swarmtrack.network.exchange import ChannelExchange, channel_of
from swarmtrack.onboard.build import onboard_stack
from swarmtrack.onboard.context import clock_of, context, layout, sensor_labels
from swarmtrack.replay.steps import LogError, StepInputs
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.meta import profiles, run_meta
from swarmtrack.sim.recorder import Recorder, Recording
from swarmtrack.streams.frame import shapes_of

#: The one phase of a log that does not know the scenario's profile phases.
LOGGED = "logged"
#: The most steps a replay's recording holds in memory before it writes them (the simulator's recorder sizes its
#: chunks by rows, which for a small swarm is tens of thousands of steps).
REPLAY_CHUNK_STEPS = 4096


def replay(scenario: Scenario, steps: Iterable[StepInputs], record_to: Path | None = None,
           progress: Callable[[float], None] | None = None, source: dict | None = None,
           phases: bool = True, planned: Callable[[int], None] | None = None, taps=()) -> Recording:
    """Run ``scenario``'s estimator on ``steps`` (in time order, on its estimation grid) and return the recording:
    the estimator's probes, and the log's ground truth where it has one. ``source`` (what was replayed) goes into the
    recording's ``meta`` under ``replay``, with ``truth``: the steps where the followed target's truth is known
    (:func:`truth_coverage`). ``phases=False``: the log does not know the scenario's profile phases; the tracked
    target's steps are one phase, ``logged`` (phase 0 of the steps). ``progress`` gets the fraction done; ``planned``
    the number of steps before the first, when the reader knows it (:class:`~swarmtrack.replay.steps.Planned`);
    ``taps`` live outputs sent each recorded step (:mod:`swarmtrack.streams`)."""
    clock, rows = clock_of(scenario), layout(scenario)
    stack = onboard_stack(context(scenario, sensor_labels(scenario)), controller=False)
    exchange, dt = ChannelExchange(channel_of(scenario, clock.dt_estimation)), clock.dt_estimation
    n, n_objects = scenario.swarm.n_uavs, rows["uavs"].stop
    meta = run_meta(scenario, rows, {g: profiles(scenario, g) for g in ("targets", "decoys")}, dt)
    # the controller was not run: its kind's metrics and figures have nothing to read
    meta.update(controller=None, replay=source or {})
    if not phases:
        meta["phase_names"] = [LOGGED] if meta["tracked"] is not None else []
        meta["object_phases"] = [[LOGGED] if j == meta["tracked"] else [] for j in range(n_objects)]
    # a replay keeps its inputs too (a replayed run folder can be replayed again, with another estimator)
    # chunks of at most REPLAY_CHUNK_STEPS steps: a long log of a small swarm streams in bounded memory
    recorder = Recorder(meta, n_objects, n, stack.probes, record_to, inputs=record_to is not None,
                        max_chunk_steps=REPLAY_CHUNK_STEPS, taps=taps,
                        shapes=shapes_of(scenario.estimator.kind, stack.estimator))
    n_steps = getattr(steps, "n_steps", None)
    if n_steps is not None and planned is not None:
        planned(n_steps)
    total = max(n_steps if n_steps is not None else clock.steps, 1)
    tracked = meta["tracked"]
    k_last, n_done, n_truth = -1, 0, 0
    for s in steps:
        if s.k <= k_last:
            raise LogError(f"replay: step {s.k} (t = {s.t:g} s) came after step {k_last}; steps must go forward")
        k_last = s.k
        stack.estimation_step(s.t, s.navigation, s.detections, exchange.at(s.positions))
        recorder.record_inputs(s.k, s.t, s.navigation, s.detections)
        recorder.record(s.t, s.truth, s.phase, stack.sample())
        n_done += 1
        n_truth += tracked is not None and bool(np.isfinite(s.truth[tracked]).all())
        if progress is not None:
            progress(min(1.0, n_done / total))
    if source is not None and tracked is not None:
        source["truth"] = truth_coverage(n_truth, n_done, dt)
    return recorder.close()


def truth_coverage(with_truth: int, steps: int, dt: float) -> dict:
    """Where a replay's errors are computed: the steps with the followed target's truth, their time and fraction of
    the steps (``meta["replay"]["truth"]``; issue 35)."""
    return {"steps": with_truth, "of_steps": steps, "seconds": with_truth * dt,
            "fraction": with_truth / steps if steps else 0.0}


def replay_logs(logs, scenario: Scenario, mapping=None, fmt: str | None = None, record_to: Path | None = None,
                progress: Callable[[float], None] | None = None,
                planned: Callable[[int], None] | None = None, taps=()) -> Recording:
    """Replay ``logs`` (paths: a run folder, ROS bags, ULog or CSV files) through ``scenario``'s estimator:
    ``mapping`` is a map file's path, its contents as a dict, or None (a run folder needs none); ``fmt`` a registered
    reader's name (default: recognised from the first log). The recording's ``meta["replay"]`` says what was
    replayed, under ``skipped`` how many messages were skipped and why, under ``truth`` where the truth was known.
    Bad logs raise :class:`~swarmtrack.replay.steps.LogError` naming the file, topic, field or row."""
    from swarmtrack.replay.formats import reader_for
    from swarmtrack.replay.mapping import ReplayMap, load_map

    logs = [Path(p) for p in ([logs] if isinstance(logs, (str, Path)) else logs)]
    reader = reader_for(fmt, logs)
    if isinstance(mapping, (str, Path)):
        source_map, mapping = str(mapping), load_map(Path(mapping), scenario)
    else:
        source_map = None
        mapping = None if mapping is None else ReplayMap.checked(mapping, scenario)
    if mapping is None and reader.needs_map:
        raise LogError(f"a map (--map MAP.yaml) is needed to read {reader.name} logs (docs/replay.md)")
    skipped: dict[str, int] = {}
    source = {"format": reader.name, "logs": [str(p) for p in logs], "map": source_map, "skipped": skipped}
    return replay(scenario, reader.open(logs, scenario, mapping, skipped), record_to, progress, source,
                  phases=reader.phases, planned=planned, taps=taps)
