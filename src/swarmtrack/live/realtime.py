"""The live swarm at wall-clock rate (``swarmtrack live --realtime``): the world keeps the time, and messages arrive
when they arrive.

The world begins estimation step ``k`` when the wall clock reaches its time (``epoch + k·dt``, :attr:`Navigation.due
<swarmtrack.live.wire.Navigation>` tells each UAV), senses and sends as in lockstep, and waits for the UAVs' samples
only until :data:`RECORD_BY` of the period after that time: then it records the step (a UAV whose sample did not come
is recorded as NaN), applies the commands that came (a UAV whose command did not come keeps its last one; a lost UAV
flies the safe command) and advances the physics. A UAV waits for its neighbours until its own deadlines
(:data:`~swarmtrack.live.agent.FUSE_BY` and after, in the agent), and fuses what comes later at its time stamp within
the scenario's delay bound (``network.delay_max``; ``estimator.delayed_data`` says how), or drops and counts it.

The simulated channel keeps its topology, range, losses and outages; its delays are the network's own (none are
drawn). Every message received is logged with its latency (the receiver's wall clock minus the sender's: on one
machine one clock; across machines, clocks synchronised by NTP or PTP to well under a period) and the run folder keeps
them (``live/latency.parquet``), with each UAV's steps: how late each was done and the CPU time it took
(``live/steps.parquet``); ``metrics.json`` has their percentiles under ``live``.

A UAV that rejoins (``swarmtrack agent --uav I --rejoin``) is sent the steps from the one the world is at when it
says hello; it catches up through the steps it is sent and is back when its first sample comes.
"""

from __future__ import annotations

import time
from collections import Counter

import numpy as np
import pandas as pd

from swarmtrack.analysis.sweep import warm
from swarmtrack.live import wire
from swarmtrack.live.report import percentiles, timing
from swarmtrack.live.world import LockstepWorld, safe_command

#: Seconds between the UAVs' stacks being built and the first step.
LEAD = 0.5
#: When the world stops waiting for the UAVs' answers of a step, as a fraction of the period after its time.
RECORD_BY = 0.8


class RealtimeWorld(LockstepWorld):
    """The truth side of a live run at wall-clock rate (module docstring)."""

    realtime = True
    epoch = 0.0  # the wall-clock time (s since the Unix epoch) of t = 0, set when every UAV is ready

    def __init__(self, *args, **kwargs):
        self._boot = time.monotonic()  # the vehicles' clock starts with the world (its Fleet reads it at once)
        super().__init__(*args, **kwargs)
        # the world's first steps call its kernels too: loaded by a throwaway run of its first second (another seed)
        warm(self.scenario.model_copy(update={"seed": self.scenario.seed + 1}))
        self.report.mode = "realtime"
        self.joining: set[int] = set()  # UAVs whose new process was sent its start, not back yet
        self.steps: list[tuple[int, int, float, float]] = []  # (UAV, k, done after its time (s), CPU (s))
        self.messages: list[tuple] = []  # (channel, sender, receiver, k, c, sent after the epoch (s), latency (s))
        self.world_late: list[float] = []  # how late the world began each step (s)
        # each UAV process's latest counts of the messages that missed its deadlines, by (UAV, its process)
        self._late: dict[tuple, dict] = {}
        self._tables: dict[str, pd.DataFrame] = {}

    def _begin(self) -> None:
        self.node.heard = []
        self.epoch = time.time() + LEAD

    def _due(self, t: float) -> float:
        due = self.epoch + t
        left = due - time.time()
        if left > 0:
            time.sleep(left)
        self.world_late.append(max(0.0, time.time() - due))
        return due

    def _now(self) -> float:
        """The clock of the world's simulated autopilots (s): monotonic from the world's start, before the run's
        epoch too (a setpoint that came while the UAVs joined is as old as it is)."""
        return time.monotonic() - self._boot

    def _until(self, due: float, period: float) -> float:
        return time.monotonic() + (due + RECORD_BY * period - time.time())

    def _parts(self, k: int, t: float, links) -> list[tuple[int, object]]:
        return [(k, links)]  # the network delays what it delays

    def _listeners(self) -> list[int]:
        return sorted(self.alive | self.joining)

    def _record(self, k: int, t: float, truth: np.ndarray, samples: dict) -> None:
        for sample in self.node.older("sample", k):  # came after its step was recorded
            i = sample.sender
            if i in self.joining:  # a rejoining UAV's stack is built: it is back
                self.joining.discard(i)
                self.alive.add(i)
                self.report.rejoined.append({"uav": i + 1, "t": round(t, 9)})
                self.node.send("all", wire.Roster(alive=sorted(self.alive)))
            if sample.k > self.last[i].k:
                self.last[i] = sample
            if sample.u is not None and i in self.alive:
                self.u[i] = wire.unpack(sample.u)[0]
            self._account([sample])
        super()._record(k, t, truth, samples)

    def _account(self, samples) -> None:
        super()._account(samples)
        dt = self.truth.clock.dt_estimation
        for sample in samples:
            i = sample.sender
            self._late[self._process_of(i)] = sample.late
            if sample.k >= 0:
                self.steps.append((i, sample.k, sample.sent - self.epoch - sample.k * dt, sample.cpu))
            self.messages += [(ch, s, i, k, c, sent - self.epoch, lat) for ch, s, k, c, sent, lat in sample.heard]

    def _command(self, nav: np.ndarray, commands: dict) -> None:
        """The commands that came; a UAV whose command did not come keeps its last one, a lost one flies the safe
        command."""
        away = [i for i in range(self.n) if i not in self.alive]
        if away:
            self.u[away] = safe_command(nav[away], self.u.shape[1])
        for i, u in commands.items():
            if u is not None:
                self.u[i] = wire.unpack(u)[0]

    def control_step(self, k: int, c: int, nav: np.ndarray, beacons) -> None:
        for msg in self.node.older("command", k, c):  # came after their control step
            if msg.sender in self.alive:
                self.u[msg.sender] = wire.unpack(msg.u)[0]
        super().control_step(k, c, nav, beacons)

    def _rejoin(self, k: int) -> None:
        """A lost UAV whose new process said hello (with ``--rejoin``) is sent its start and the steps from ``k`` on;
        it is back when its first sample comes (:meth:`_record`)."""
        self._screen(k)
        for i in sorted(set(self._joiners) - self.alive - self.joining):
            self._start(i, self._joiners[i], k)
            self.joining.add(i)

    def _finish(self) -> None:
        dt = self.truth.clock.dt_estimation
        self.messages += [(ch, s, wire.WORLD, k, c, sent - self.epoch, lat) for ch, s, k, c, sent, lat in
                          self.node.log()]
        self._tables = timing(self.report, self.steps, self.messages, dt)
        self.report.world_lateness = percentiles(np.array(self.world_late) / dt)
        late = Counter()
        for counts in self._late.values():
            late.update(counts)
        self.report.late = dict(late)
        self.report.shares_due = self.shares_due

    def tables(self) -> dict[str, pd.DataFrame]:
        """``latency``: every message received, ``channel, sender, receiver, k, c, sent, latency`` (UAVs 0-based,
        the world −1; ``sent`` s after t = 0's wall-clock time, ``latency`` s); ``steps``: each UAV's estimation steps,
        ``uav, k, done, cpu`` (``done``: s after the step's time; ``cpu``: the CPU time its process spent on it); made
        once, when the run is over."""
        return self._tables
