"""The field's ground station (``swarmtrack monitor``): it joins the swarm read-only and records what the agents
publish into an ordinary run folder.

Every estimation step it waits until :data:`~swarmtrack.live.realtime.RECORD_BY` of the period after the step's
time (``epoch + k·dt`` on its clock) for each UAV's sample (:class:`~swarmtrack.live.wire.Sample`: the probes its
stack declares, its command, its navigation), then records the step: the UAVs' rows of the truth table are their
own navigation (there is no world), the followed target's is the truth source's when one is given (motion capture,
a simulator's topic: :class:`~swarmtrack.field.inputs.FieldInputs`), NaN otherwise, so errors are computed only
where truth exists; a UAV whose sample did not come is absent. A UAV not heard for
:data:`~swarmtrack.live.node.LOST_AFTER` s is said lost (on the console and in ``metrics.json``), and back when it
is heard again. It sends nothing: the swarm does not know it is there.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from typing import cast

import numpy as np
import pandas as pd

from swarmtrack.field.inputs import FieldInputs
from swarmtrack.live import wire
from swarmtrack.live.node import LOST_AFTER, Node
from swarmtrack.live.realtime import RECORD_BY
from swarmtrack.live.report import LiveReport, percentiles, timing
from swarmtrack.onboard.build import probes_of
from swarmtrack.onboard.context import clock_of, layout
from swarmtrack.sim.meta import profiles, run_meta
from swarmtrack.sim.recorder import Recorder, Recording

#: The monitor's id on the swarm's keys (it sends nothing; its node must be neither a UAV nor the world).
MONITOR = -2
#: What the monitor records of each UAV's step beside its probes (plotted live, :data:`~swarmtrack.streams.frame.
#: PLOTTED`): how late it was done (periods after its time) and the median latency of the messages it heard (ms).
TIMING = ("lateness", "latency_ms")


class Monitor:
    """A read-only member of ``scenario``'s swarm on ``node``, on the clock that starts at ``epoch``; ``truth``:
    the inputs its truth source feeds (None: no truth); ``record_to``: where the recording streams (None: memory);
    ``taps``: live outputs (:mod:`swarmtrack.streams`)."""

    def __init__(self, scenario, node: Node, epoch: float, truth: FieldInputs | None = None, record_to=None,
                 taps=(), progress: Callable[[float], None] | None = None):
        self.scenario, self.node, self.epoch, self.truth, self.progress = scenario, node, epoch, truth, progress
        self.n = scenario.swarm.n_uavs
        self.clock = clock_of(scenario)
        self.rows = layout(scenario)
        self.m = max(sl.stop for sl in self.rows.values())
        self.flown = {g: profiles(scenario, g) for g in ("targets", "decoys")}
        meta = run_meta(scenario, self.rows, self.flown, self.clock.dt_estimation)
        self.probes = probes_of(scenario)
        self.recorder = Recorder(meta, self.m, self.n, {**self.probes, **dict.fromkeys(TIMING, ())}, record_to,
                                 presence=True, taps=taps)
        self.report = LiveReport(mode="field")
        self.lost: set[int] = set()
        self.samples: dict[tuple, wire.Sample] = {}  # each UAV process's latest sample
        self.steps: list[tuple] = []  # (uav, k, done after its time (s), CPU (s))
        self.messages: list[tuple] = []  # (channel, sender, receiver, k, c, sent after the epoch (s), latency (s))
        self.stop = False  # Ctrl-C: the steps recorded so far are kept
        self.tables: dict[str, pd.DataFrame] = {}  # live/latency and live/steps, made when the run is over

    def run(self) -> tuple[Recording, LiveReport, dict[str, pd.DataFrame]]:
        """Record from the current step to the scenario's end (or :attr:`stop`)."""
        self.node.listen(("uav", "*", "sample"), ("uav", "*", "alive"))
        dt = self.clock.dt_estimation
        first = max(0, math.ceil((time.time() - self.epoch) / dt - 1e-9))
        steps = self.clock.steps
        for k in range(first, steps):
            t = k * dt
            until = self.epoch + t + RECORD_BY * dt
            while not self.stop and time.time() < until:
                time.sleep(min(0.05, max(0.0, until - time.time())))
            if self.stop:
                self.report.interrupted = round(t, 9)
                break
            self._record(k, t, cast(dict[int, wire.Sample],
                                    self.node.wait("sample", range(self.n), k, timeout=0.0, missing_ok=True)))
            if self.progress is not None:
                self.progress((k + 1 - first) / (steps - first))
        return self.recorder.close(), self._finish(), self.tables

    def _record(self, k: int, t: float, samples: dict[int, wire.Sample]) -> None:
        self.node.forget(k - 1)
        truth = np.full((self.m, 4), np.nan)
        phase = np.full(self.m, -1, dtype=np.int16)
        for g, flown in self.flown.items():
            for j, profile in enumerate(flown):
                phase[self.rows[g].start + j] = profile.phase_index(t)
        tracked = self.recorder.meta.get("tracked")
        if self.truth is not None and tracked is not None:
            got = self.truth.truth_at(t)
            if got is not None:
                truth[tracked] = got
        uavs = self.rows["uavs"]
        for i, sample in samples.items():
            if sample.nav is not None:
                truth[uavs.start + i] = wire.unpack(sample.nav)[0, :4]
        probes = {name: np.concatenate([wire.unpack(samples[i].probes[name]) if i in samples
                                        else np.full((1, *shape), np.nan) for i in range(self.n)])
                  for name, shape in self.probes.items()}
        timing = {name: np.full(self.n, np.nan) for name in TIMING}  # NaN: no sample, or no message heard
        for i, sample in samples.items():
            timing["lateness"][i], timing["latency_ms"][i] = self._account(i, sample, k)
        present = np.array([i in samples for i in range(self.n)])
        self.recorder.record(t, truth, phase, {**probes, **timing}, present=present)
        self._watch(t)

    def _account(self, i: int, sample: wire.Sample, k: int) -> tuple[float, float]:
        """What a sample says of its process: its counts (the latest of each process), its step's lateness and CPU,
        the latency of the messages it heard; returns its :data:`TIMING` of step ``k``."""
        dt = self.clock.dt_estimation
        self.samples[(i, sample.proc)] = sample
        done = sample.sent - self.epoch - k * dt
        self.steps.append((i, k, done, sample.cpu))
        self.messages += [(ch, s, i, kk, c, sent - self.epoch, lat) for ch, s, kk, c, sent, lat in sample.heard]
        heard = [lat for _, _, kk, _, _, lat in sample.heard if kk == k]
        return done / dt, 1e3 * float(np.median(heard)) if heard else np.nan

    def _watch(self, t: float) -> None:
        """Say a UAV lost (not heard for LOST_AFTER s) or back."""
        now = time.monotonic()
        for i in range(self.n):
            quiet = now - self.node.seen.get(i, -math.inf) > LOST_AFTER
            if quiet and i not in self.lost:
                self.lost.add(i)
                self.report.lost.append({"uav": i + 1, "t": round(t, 9)})
                print(f"monitor: UAV {i + 1} not heard for {LOST_AFTER:g} s (t = {t:.2f} s): lost", file=sys.stderr,
                      flush=True)
            elif not quiet and i in self.lost:
                self.lost.discard(i)
                self.report.rejoined.append({"uav": i + 1, "t": round(t, 9)})
                print(f"monitor: UAV {i + 1} heard again at t = {t:.2f} s", file=sys.stderr, flush=True)

    def _finish(self) -> LiveReport:
        report, dt = self.report, self.clock.dt_estimation
        rejected: dict[str, int] = dict(self.node.seal.rejected)
        skipped: dict[str, int] = {}
        late: dict[str, int] = {}
        for sample in self.samples.values():
            for counts, into in ((sample.rejected, rejected), (sample.skipped, skipped), (sample.late, late)):
                for cause, n in counts.items():
                    into[cause] = into.get(cause, 0) + n
        report.rejected, report.late = rejected, late
        report.skipped = skipped
        report.cpu_per_step_ms = percentiles(1e3 * np.array([s[3] for s in self.steps]))
        self.tables = timing(report, self.steps, self.messages, dt)
        return report
