"""The truth side of the live swarm: the world (truth, physics, sensors), the simulated radio and the recorder, in
one process that talks to the UAVs' processes only by messages.

In lockstep (:class:`LockstepWorld`) it runs the simulator's step loop (:func:`swarmtrack.sim.engine.step_loop`) with
every call to the onboard stack replaced by messages: per estimation step it sends each UAV its navigation, its
detections and its radio (which of the other UAVs' messages reach it now: the scenario's channel, with its losses,
outages and delays, drawn from the same streams in the same order), and waits for every UAV's probes; per control
step it sends navigation and the beacon radio, and waits for every UAV's command before it advances. So a live run
records what ``swarmtrack run`` records, bit for bit.
"""

from __future__ import annotations

import dataclasses
import signal
import sys
import time
from collections import Counter
from collections.abc import Callable
from contextlib import contextmanager
from typing import TYPE_CHECKING

import numpy as np

from swarmtrack.autopilot.fleet import Fleet
from swarmtrack.live import wire
from swarmtrack.live.agent import HELLO_EVERY, PATIENCE, scenario_hash, telemetry_of
from swarmtrack.live.node import LOST_AFTER, Node
from swarmtrack.live.report import LiveReport, percentiles
from swarmtrack.network.links import neighbour_lists
from swarmtrack.onboard.build import component, probes_of
from swarmtrack.onboard.context import command_width, context, labels_of, sensor_labels
from swarmtrack.outputs import Terminated
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sensors.detections import Detections
from swarmtrack.sim.build import monitors, truth_side
from swarmtrack.sim.recorder import Recorder, Recording
from swarmtrack.streams.frame import shapes_of

if TYPE_CHECKING:
    import pandas as pd


#: How long a world that refuses UAVs for another swarm key stays on the air before it exits, s (its heartbeats tell
#: them; under load their subscriptions can take a moment to reach the router).
REFUSED_LINGER = 2.0
#: How long a world that stops on an error stays on the air after telling the UAVs' processes, s.
LEAVE_LINGER = 0.5


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
    try:
        build_onboard(scenario, 0, labels_of(scenario))
    except NotImplementedError as exc:
        raise LiveError(f"cannot run live: {exc}") from None


def safe_command(nav: np.ndarray, width: int) -> np.ndarray:
    """What the world flies a UAV whose process stopped answering with, (1, width): a planar command brakes it to a
    hover, ``u = −v`` (1/s); a fixed wing's yaw acceleration is 0 (it flies straight, it cannot hover). With
    ``--mavlink`` its simulated autopilot's failsafe flies it instead (:func:`swarmtrack.autopilot.vehicle.hold`)."""
    if width == 2:
        return -nav[:, 2:4]
    return np.zeros((len(nav), width))


class _Interrupted(Exception):
    """Ctrl-C or SIGTERM arrived while the world waited for its UAVs."""


class LockstepWorld:
    """The truth side of a live run in lockstep: :meth:`run` is the simulator's step loop by messages.

    A UAV whose process is not heard for :data:`~swarmtrack.live.node.LOST_AFTER` s (no heartbeat) is lost, unless
    ``running`` says that process is one this world started and it still runs (a process alive but slow, on a busy
    machine, is waited for, up to ``patience``: lockstep's numbers are those of ``swarmtrack run``): its
    neighbours stop hearing it (the radio leaves it out as sender and receiver, a roster says nobody waits for it),
    the world flies it with :func:`safe_command`, its probes are recorded as NaN, and the report names it. A process
    started again for it (``swarmtrack agent --uav I --rejoin``) says hello, gets the step to start from, and rejoins
    the radio there."""

    realtime = False  # the clock: lockstep (RealtimeWorld, realtime.py: the wall clock)

    def __init__(self, scenario: Scenario, node: Node, record_to=None, patience: float = PATIENCE,
                 progress: Callable[[float], None] | None = None, mavlink: tuple | None = None,
                 running: Callable[[int], bool] | None = None, taps=(), all_to_all: bool = False):
        self.scenario, self.node, self.patience, self.progress = scenario, node, patience, progress
        # per-neighbour delivery: each UAV's radio names the UAVs that hear it, and it addresses its messages to them
        # (all_to_all: it puts them on its own key, which every UAV hears; the radio decides what is kept, as before
        # issue 41: a reference for the benchmark)
        self.all_to_all = all_to_all
        self.running = running  # whether the process of a pid is one this world started and it runs
        self.truth = truth = truth_side(scenario)
        self.n = scenario.swarm.n_uavs
        self.alive = set(range(self.n))
        self.report = LiveReport()
        label_of = sensor_labels(scenario)
        # what every UAV's sample carries (a UAV's stack declares it); the truth side builds of the UAVs' components
        # only those its monitors read, as copies the UAVs' telemetry is mirrored into
        self.probes = probes_of(scenario)
        self.telemetries = telemetry_of(scenario)
        self.components = {role: component(role, scenario, context(scenario, label_of)) for role in self.telemetries}
        self.monitors = monitors(scenario, truth.world, self.components)
        # a run folder keeps the UAVs' inputs (navigation, detections) as swarmtrack run's does: it can be replayed
        self.recorder = Recorder(truth.meta, truth.world.n_objects, self.n, {**self.probes,
                                 **dict.fromkeys(self.monitors, ())}, record_to, presence=True,
                                 inputs=record_to is not None, taps=taps,
                                 shapes=shapes_of(scenario.estimator.kind, self.components.get("estimator")))
        self.last: dict[int, wire.Sample] = {}  # each UAV's latest sample (its aim and telemetry when lost)
        self.u = np.zeros((self.n, command_width(scenario)))
        # each UAV process's latest counts of the messages it dropped, by (UAV, its process): a process lost and
        # started again counts afresh, and the counts of its earlier life stay in the total
        self._rejected: dict[tuple, dict] = {}
        self._autopilot: dict[tuple, list] = {}  # each UAV process's latest account of its autopilot's handovers
        self._stop = False  # Ctrl-C or SIGTERM arrived (:meth:`_interruptible`)
        self.recorded = 0  # estimation steps recorded
        self.processes: dict[int, tuple[int, int]] = {}  # each UAV's process the world knows: (pid, start time)
        self.cpu: list[float] = []  # the CPU time (s) of a UAV's process per estimation step, over UAVs and steps
        self.receive: list[tuple[int, float]] = []  # its messages received and their CPU time (s), likewise
        self.shares_due = 0  # the neighbours' shares the UAVs' radios named for their steps (this step's parts)
        # --mavlink (base port, host, ground-station port): each UAV flies through a simulated autopilot its process
        # talks MAVLink to
        self.fleet = None if mavlink is None else Fleet(self.n, self._now, *mavlink)
        self.node.seal.run = self.node.seal.run or wire.new_run()  # this run's identity: every message carries it
        self._joiners: dict[int, wire.Hello] = {}  # UAVs whose new process (--rejoin) starts at the next step
        # the processes (their proc) it started: a hello of one of them heard again is an old one (said before its
        # start, within LOST_AFTER), never a second process for its UAV, even once another replaced it
        self._started: set[int] = set()
        self._refused: dict[int, float] = {}  # processes refused (their proc), and when they were last told

    def run(self) -> tuple[Recording, LiveReport]:
        node, clock = self.node, self.truth.clock
        node.listen(("uav", "*", "hello"), ("uav", "*", "sample"), ("uav", "*", "command"), ("uav", "*", "alive"),
                    ("world", "*", "stop"))  # a stop it did not send (an --insecure run): said in the report
        node.heartbeat()
        try:
            hello = self._hellos()
            for i, m in sorted(hello.items()):
                self._start(i, m, 0)
            self.last = self._ready()
        except BaseException as exc:
            self._leave(exc, hello=True)
            raise
        self._begin()
        report_every = max(1, clock.steps // 100)
        with self._interruptible():
            for k in range(clock.steps):
                try:
                    self._rejoin(k)
                    self.estimation_step(k)
                except _Interrupted:  # the steps recorded so far are kept: the run stopped at the next one's time
                    self.report.interrupted = round(self.recorded * clock.dt_estimation, 9)
                    break
                except BaseException as exc:
                    self._leave(exc)
                    raise
                if self.progress is not None and (k % report_every == 0 or k == clock.steps - 1):
                    self.progress((k + 1) / clock.steps)
        node.stopping = True
        node.send("all", wire.Stop())
        total = Counter(node.seal.rejected)
        for counts in self._rejected.values():
            total.update(counts)
        self.report.rejected = dict(total)
        for (i, *_), events in sorted(self._autopilot.items(), key=lambda item: item[0][0]):
            self.report.autopilot.setdefault(str(i + 1), []).extend(events)
        self.report.cpu_per_step_ms = percentiles(1e3 * np.asarray(self.cpu))
        if self.receive:
            got = np.asarray(self.receive)
            self.report.received_per_step = {"messages": percentiles(got[:, 0]), "cpu_ms": percentiles(1e3 * got[:, 1])}
        self._finish()
        return self.recorder.close(), self.report

    def _start(self, i: int, hello: wire.Hello, k: int) -> None:
        """Start UAV ``i``'s process of ``hello`` at step ``k`` (the start bound to its hello): it is the one the world
        flies from now (what another process of the UAV sends is dropped)."""
        self.processes[i] = (hello.pid, hello.started)
        self.node.current[i] = hello.proc
        self._started.add(hello.proc)
        self._joiners.pop(i, None)
        self.node.send(i, wire.Start(k=k, to=hello.proc, labels=labels_of(self.scenario), realtime=self.realtime,
                                     mavlink=self.fleet is not None))

    def _leave(self, exc: BaseException, hello: bool = False) -> None:
        """The world stops on ``exc``: every UAV process of the run is told (a stop to all), and with ``hello``
        (before or while it starts them) every process whose hello it heard, each by a stop bound to its hello, so
        that none waits for a world that is gone."""
        interrupted = isinstance(exc, KeyboardInterrupt | Terminated)
        reason = "the world was interrupted" if interrupted else f"the world stopped the run: {exc}"
        node = self.node
        node.stopping = True
        try:
            node.send("all", wire.Stop(reason=reason, refused=not interrupted))
            if hello:
                with node._cond:
                    heard = list(node.hellos)
                for i, proc in heard:
                    node.send(i, wire.Stop(reason=reason, to=proc, refused=not interrupted))
        except Exception:  # noqa: BLE001 - the transport is gone: nobody to tell
            return
        time.sleep(LEAVE_LINGER)  # on their way before the transport closes

    def _begin(self) -> None:
        """Every UAV's stack is built: the first step comes next."""

    def _finish(self) -> None:
        """The run is over: complete the report."""

    def tables(self) -> dict[str, pd.DataFrame]:
        """Tables the run folder keeps beside the recording (``live/<name>.parquet``)."""
        return {}

    @contextmanager
    def _interruptible(self):
        """Ctrl-C and SIGTERM end the run at the next wait for the UAVs (main thread only): the steps completed are
        kept, and the caller writes them whole."""
        def handler(signum, frame) -> None:
            self._stop = True

        try:
            previous = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
        except ValueError:  # not the main thread
            yield
            return
        try:
            yield
        finally:
            for sig, old in previous.items():
                signal.signal(sig, old)

    def _hellos(self) -> dict[int, wire.Hello]:
        """Every UAV's process, by its hello (fresh: it answers this world's run), waited for up to ``patience`` s.
        The run is refused (:class:`LiveError` naming the UAVs) as soon as a hello says its process cannot fly or runs
        another scenario, or flies otherwise (``--autopilot`` against ``--mavlink``), or when a UAV none of whose hellos
        passed the seal has sent hellos that fail it with one process identity, :data:`~swarmtrack.live.node.EVIDENCE`
        in a row over :data:`~swarmtrack.live.node.EVIDENCE_SPAN` s (a process with another key; random bytes from a
        stranger never count). Of two live processes for one UAV, the first heard is started and the other refused
        (the later one with ``--rejoin`` replaces it)."""
        deadline = time.monotonic() + self.patience
        while True:
            heard = self._heard_hellos()
            self._refuse_run(heard)
            if len(heard) == self.n:
                chosen = {}
                for i, entries in heard.items():
                    first = entries[0][0]
                    rejoining = [m for m, _ in entries[1:] if m.rejoin]
                    chosen[i] = rejoining[-1] if rejoining else first
                    for m, _ in entries:
                        if m is not chosen[i]:
                            self._refuse(i, m, f"UAV {i + 1} is flown by process {chosen[i].pid}; this process is "
                                         "a second one for it (--rejoin replaces the process that flies a UAV)")
                return chosen
            if time.monotonic() > deadline:
                raise TimeoutError(f"no hello from UAVs {[i + 1 for i in range(self.n) if i not in heard]}")
            time.sleep(0.05)

    def _heard_hellos(self, refused: bool = False) -> dict[int, list[tuple[wire.Hello, float]]]:
        """Each UAV's processes whose hellos came within :data:`~swarmtrack.live.node.LOST_AFTER` s (those refused
        too with ``refused``), ``[(latest hello, first heard)]`` in the order they were first heard."""
        now = time.monotonic()
        with self.node._cond:
            entries = [(i, msg, first) for (i, proc), (msg, first, last) in self.node.hellos.items()
                       if now - last <= LOST_AFTER and (refused or proc not in self._refused)]
        out: dict = {}
        for i, msg, first in sorted(entries, key=lambda e: e[2]):
            out.setdefault(i, []).append((msg, first))
        return out

    def _refuse_run(self, heard: dict) -> None:
        """Refuse the run (:class:`LiveError`) on what the hellos heard say, or on evidence of another key."""
        problems: dict[str, list[int]] = {}
        for i, entries in sorted(heard.items()):
            for m, _ in entries:
                problem = self._mismatch(m)
                if problem is not None:
                    problems.setdefault(problem, []).append(i + 1)
        if problems:
            raise LiveError("; ".join(f"UAVs {uavs}: {problem}" for problem, uavs in problems.items()))
        wrong = {i + 1: m for i in range(self.n) if i not in heard and (m := self.node.evidence(i)) is not None}
        if wrong:
            # stay on the air a moment: the refused UAVs learn of the mismatch from the world's heartbeats, which
            # fail their key; a world gone before its first heartbeat reached them would leave them waiting
            time.sleep(REFUSED_LINGER)
            pids = ", ".join(str(m.pid) for m in wrong.values() if isinstance(m, wire.Hello))
            raise LiveError(f"the hellos of UAVs {sorted(wrong)} fail the swarm key: their processes ({pids}) run "
                            "with another --key (or without one)")

    def _mismatch(self, hello: wire.Hello) -> str | None:
        """Why the process of ``hello`` cannot fly in this run (None: it can)."""
        if hello.error:
            return f"process {hello.pid} cannot fly: {hello.error}"
        if hello.scenario != scenario_hash(self.scenario):
            return f"process {hello.pid} runs another scenario (or seed, or overrides)"
        if self.fleet is not None and not hello.autopilot:
            return (f"process {hello.pid} runs without --autopilot, and this world flies its UAVs through MAVLink "
                    "autopilots (--mavlink)")
        if self.fleet is None and hello.autopilot:
            return (f"process {hello.pid} flies through an autopilot (--autopilot), and this world does not fly "
                    "through MAVLink (start it with --mavlink)")
        return None

    def _refuse(self, i: int, hello: wire.Hello, reason: str) -> None:
        """Refuse UAV ``i``'s process of ``hello``: a stop bound to its hello says why (said again while it says
        hello); the first time, the world says so on its console and in the report."""
        now = time.monotonic()
        if now - self._refused.get(hello.proc, -np.inf) < HELLO_EVERY:
            return
        first = hello.proc not in self._refused
        self._refused[hello.proc] = now
        self.node.send(i, wire.Stop(reason=reason, to=hello.proc, refused=True))
        if first:
            t = round(self.truth.world.t, 9)
            self.report.refused.append({"uav": i + 1, "pid": hello.pid, "t": t, "reason": reason})
            print(f"UAV {i + 1}: process {hello.pid} refused at t = {t:.2f} s: {reason}", file=sys.stderr, flush=True)

    def _screen(self, k: int) -> None:
        """The hellos of processes the world does not fly, during the run: one that may rejoin (``--rejoin``, the
        UAV's scenario and flight) is kept to start at the next step (:meth:`_rejoin`; a process still flying the UAV
        is told it is replaced, and the UAV lost); any other is refused (a second process for a UAV that is flown,
        one without ``--rejoin`` for a lost UAV, one that cannot fly here)."""
        self._say_unsealed_stops()
        for i, entries in self._heard_hellos(refused=True).items():
            for hello, _ in entries:
                joiner = self._joiners.get(i)
                if hello.proc in self._started or (joiner is not None and joiner.proc == hello.proc):
                    continue  # a process it started (the one flying, or one replaced since: its hello is old)
                flown = i in self.alive and i not in self._joiners
                reason = self._mismatch(hello)
                if reason is None and not hello.rejoin:
                    reason = (f"UAV {i + 1} is flown by process {self.processes[i][0]}; this process is a second one "
                              "for it (--rejoin replaces the process that flies a UAV)" if flown else
                              f"the swarm is at step {k} already: start this UAV with --rejoin")
                if reason is not None:
                    self._refuse(i, hello, reason)
                    continue
                if flown and i in self.node.current:  # --rejoin while its process flies it: that one is replaced
                    self.node.send(i, wire.Stop(reason=f"replaced by process {hello.pid} (--rejoin)",
                                                to=self.node.current[i]))
                self._joiners[i] = hello

    def _say_unsealed_stops(self) -> None:
        """A stop the world did not send came on its keys (it passed the seal: an ``--insecure`` run): said at once on
        the console, and in the report."""
        with self.node._cond:
            came, self.node.foreign_stops = self.node.foreign_stops, []
        for _ in came:
            t = round(self.truth.world.t, 9)
            self.report.unsealed_stops.append(t)
            print(f"warning: at t = {t:.2f} s a stop the world did not send came on its keys, unsealed: this run is "
                  "--insecure, so anyone on the network can stop its UAVs", file=sys.stderr, flush=True)

    def _ready(self) -> dict[int, wire.Sample]:
        """Every UAV's first sample (its stack built and its kernels loaded: compiling them, with numba's cache cold
        and the machine busy, may take minutes), waited for as long as its process is heard; a UAV not heard for
        :data:`~swarmtrack.live.node.LOST_AFTER` s before it is ready stops the run (``TimeoutError`` naming it)."""
        got: dict = {}
        while len(got) < self.n:
            missing = [i for i in range(self.n) if i not in got]
            got.update(self.node.wait("sample", missing, -1, timeout=HELLO_EVERY, missing_ok=True))
            self._screen(0)
            now = time.monotonic()
            silent = [i + 1 for i in missing if i not in got and self._silent(i, now, now)]
            if silent:
                raise TimeoutError(f"UAVs {silent} stopped answering before their first step (not heard for "
                                   f"{LOST_AFTER:g} s)")
        return got

    def estimation_step(self, k: int) -> None:
        """Step ``k`` of :func:`~swarmtrack.sim.engine.step_loop` by messages. Each UAV gets one message (its
        navigation, detections and radio, and the time of the control step that starts now with its beacon radio)
        and answers with one (its probes, and the command of that control step); the radio's draws (links, late
        parts, beacon links) and the guide's view come in the simulator's order."""
        world, channel, clock, oracle = self.truth.world, self.truth.channel, self.truth.clock, self.truth.oracle
        t = k * clock.dt_estimation
        truth = world.truth()
        positions = truth[world.slices["uavs"], :2]
        nav = world.navigation()
        detections, _sources = world.sense(aim=self._aims() if world.aims else None)
        links = channel.links(positions, t)
        parts = self._parts(k, t, links)
        segments = list(clock.control_segments(k))
        beacons = channel.beacon_links(positions, world.t) if segments[0][0] else None
        view = None if oracle is None else oracle.view()
        heard, mine = self._heard(links), detections.of_each_uav()
        parts = [(step, self._heard(part)) for step, part in parts]
        self.shares_due += sum(len(parts[0][1][i]) for i in self._listeners()) if parts and parts[0][0] == k else 0
        beacons = None if beacons is None else self._heard(beacons)
        to, beacon_to = self._receivers(heard), self._receivers(beacons)
        messages = []
        for i in self._listeners():
            radio = wire.Radio(links=heard[i], parts=[(step, senders[i]) for step, senders in parts],
                               beacons=[] if beacons is None else beacons[i], to=None if to is None else to[i],
                               beacon_to=None if beacon_to is None else beacon_to[i])
            messages.append((i, wire.Navigation(
                k=k, taken=t, nav=self._own_nav(nav, i), radio=radio,
                detections={f: wire.pack(getattr(mine[i], f)) for f in FIELDS},
                guide=None if view is None else _row_of_view(view, i),
                control=None if beacons is None else world.t)))
        # in real time the step's sensing and radio are ready before its time (they depend on nothing that comes
        # later): at its time the messages go at once, and the UAVs are not kept waiting for the world's work
        due = self._due(t)
        for i, msg in messages:
            msg.due = due
            self.node.send(i, msg)
        if self.fleet is not None:
            self.fleet.publish(t, nav, self._listeners(), self._heights())
        until = self._until(due, clock.dt_estimation)
        samples = self._gather("sample", k, -1, t, until)
        self.recorder.record_inputs(k, t, nav, detections)  # what the UAVs were sent (the simulator's order)
        self._record(k, t, truth, samples)
        offset = 0
        for c, (control_now, ticks) in enumerate(segments):
            if control_now:
                if offset:  # a control step between estimation steps: fresh navigation
                    nav = world.navigation()
                    positions = world.truth("uavs")[:, :2]
                    self.control_step(k, c, nav, channel.beacon_links(positions, world.t))
                else:  # its commands came with the samples
                    self._fly(world.t, nav, {i: s.u for i, s in samples.items()}, until)
            world.advance({"uavs": self.u}, ticks)
            offset += ticks

    def control_step(self, k: int, c: int, nav: np.ndarray, beacons) -> None:
        t = self.truth.world.t
        due, heard = self._due(t), self._heard(beacons)
        beacon_to = self._receivers(heard)
        for i in self._listeners():
            self.node.send(i, wire.Navigation(k=k, c=c, taken=t, nav=self._own_nav(nav, i), radio=wire.Radio(
                beacons=heard[i], beacon_to=None if beacon_to is None else beacon_to[i]), due=due))
        if self.fleet is not None:
            self.fleet.publish(t, nav, self._listeners(), self._heights())
        until = self._until(due, self.truth.clock.dt_control)
        commands = self._gather("command", k, c, t, until)
        self._fly(t, nav, {i: m.u for i, m in commands.items()}, until)

    def _record(self, k: int, t: float, truth: np.ndarray, samples: dict) -> None:
        """Record step ``k``: the truth, the UAVs' probes (NaN for the UAVs without a sample, marked absent in the
        recording's present mask) and the truth-side monitors on the UAVs' telemetry."""
        world = self.truth.world
        self.last.update(samples)
        probes = {name: np.concatenate([self._probe(i, name, shape, samples) for i in range(self.n)])
                  for name, shape in self.probes.items()}
        for role, telemetry in self.telemetries.items():  # the truth side's copy of the UAVs' components
            telemetry.mirror(self.components[role], _stacked([self.last[i].telemetry[role] for i in range(self.n)]))
        self.recorder.record(t, world.recorded_truth(truth), world.phase_index(),
                             {**probes, **{m: f() for m, f in self.monitors.items()}},
                             present=np.array([i in samples for i in range(self.n)]))
        self.recorded = k + 1
        self._account(samples.values())

    def _account(self, samples) -> None:
        """What the samples say of their processes: the messages they dropped, their CPU per step."""
        for sample in samples:
            self._rejected[self._process_of(sample.sender)] = sample.rejected
            if sample.autopilot:
                self._autopilot[self._process_of(sample.sender)] = sample.autopilot
            if sample.k >= 0:  # the first sample's CPU is the process's start-up
                self.cpu.append(sample.cpu)
                self.receive.append((sample.received, sample.receive_cpu))

    def _process_of(self, i: int) -> tuple:
        """Which process of UAV ``i`` the world knows now: ``(i, pid, start time)`` (a rejoined UAV's is another)."""
        return (i, *self.processes.get(i, ()))

    def _heights(self) -> np.ndarray | None:
        """The UAVs' altitudes (m) in a 3-D world, for their autopilots' navigation (None: a planar world, where each
        simulated autopilot keeps its own)."""
        world = self.truth.world
        return world.altitude("uavs")[:, 0] if world.three_d else None

    def _own_nav(self, nav: np.ndarray, i: int):
        """UAV i's navigation for its message: packed, or None when its autopilot gives it (``--mavlink``)."""
        return None if self.fleet is not None else wire.pack(nav[i:i + 1])

    def _fly(self, t: float, nav: np.ndarray, commands: dict, until: float | None) -> None:
        """Fly the UAVs' ``commands`` of the control step at ``t`` (packed, by UAV), or with ``--mavlink`` what
        their autopilots fly: each the setpoint its UAV sent it for ``t`` (waited for as the commands were), or its
        failsafe."""
        if self.fleet is None:
            self._command(nav, commands)
            return
        deadline = time.monotonic() + self.patience if until is None else until
        self.fleet.setpoints(t, sorted(commands), deadline, lambda: self._stop)
        self.u[:] = self.fleet.commands(nav, self._now())

    def _now(self) -> float:
        """The world's clock (s): simulated time in lockstep."""
        return self.truth.world.t

    def _command(self, nav: np.ndarray, commands: dict) -> None:
        """The UAVs' ``commands`` (packed, by UAV) into the world's; the lost UAVs fly :func:`safe_command`."""
        self.u[:] = safe_command(nav, self.u.shape[1])
        for i, u in commands.items():
            self.u[i] = wire.unpack(u)[0]

    # the clock: in lockstep the world waits for every UAV; RealtimeWorld (realtime.py) keeps the wall clock

    def _due(self, t: float) -> float | None:
        """The wall-clock time simulated time ``t`` is due at (None: lockstep)."""
        return None

    def _until(self, due: float | None, period: float) -> float | None:
        """The monotonic time until which the world waits for the UAVs' answers (None: until they come)."""
        return None

    def _parts(self, k: int, t: float, links) -> list[tuple[int, object]]:
        """``[(send step, links)]`` of the estimation messages that reach their receivers now: this step's, then the
        late ones the simulated channel delivers now (its delays, drawn as the simulator draws them)."""
        delivered = self.truth.channel.deliver(links, {"k": np.full(self.n, k)}, t)
        return [(int(part.payloads["k"][0]), part.links) for part in delivered.parts()]

    def _listeners(self) -> list[int]:
        """The UAVs the world sends their steps to."""
        return sorted(self.alive)

    def _gather(self, channel: str, k: int, c: int, t: float, until: float | None = None) -> dict:
        """Every living UAV's message of ``channel`` for step ``(k, c)``. A UAV whose process has not been heard for
        :data:`~swarmtrack.live.node.LOST_AFTER` s (no heartbeat: it died), or for which a new process said hello, is
        lost; the others are waited for until the monotonic time ``until`` (then what came is returned), or without
        it up to ``patience`` s (a process that is alive but stuck ends the run with an error)."""
        got: dict = {}
        deadline = time.monotonic() + self.patience
        while True:
            if self._stop:
                raise _Interrupted()
            wait = 0.1 if until is None else min(0.1, max(0.0, until - time.monotonic()))
            got.update(self.node.wait(channel, sorted(self.alive - set(got)), k, c, timeout=wait, missing_ok=True))
            self._screen(k)
            missing = self.alive - set(got)
            now = time.monotonic()
            silent = {i for i in missing if self._silent(i, now)}  # not heard: it died
            silent |= {i for i in self.alive if i in self._joiners}  # replaced by a new process (--rejoin)
            if silent:
                self.alive -= silent
                self.report.lost += [{"uav": i + 1, "t": round(t, 9)} for i in sorted(silent)]
                self.node.send("all", wire.Roster(alive=sorted(self.alive)))
            if not missing - silent or (until is not None and now >= until):
                return got
            if until is None and now > deadline:
                raise TimeoutError(f"no {channel} of step {k} from UAVs {[i + 1 for i in sorted(missing)]}, whose "
                                   f"processes are alive")

    def _silent(self, i: int, now: float, unheard: float = 0.0) -> bool:
        """Whether UAV ``i``'s process is taken for dead: not heard for :data:`~swarmtrack.live.node.LOST_AFTER` s
        (``unheard``: when a process never heard was last heard) and, in lockstep, not a process this world started
        that still runs; or not heard for ``patience`` s."""
        quiet = now - self.node.seen.get(i, unheard)
        if quiet <= LOST_AFTER or quiet > self.patience:
            return quiet > LOST_AFTER
        return self.realtime or self.running is None or i not in self.processes or not self.running(
            self.processes[i][0])

    def _rejoin(self, k: int) -> None:
        """A lost UAV whose new process said hello (with ``--rejoin``: :meth:`_screen`) starts at step ``k``."""
        self._screen(k)
        for i in sorted(set(self._joiners) - self.alive):
            hello = self._joiners[i]
            self._start(i, hello, k)
            got = self.node.wait("sample", [i], -1, timeout=self.patience, missing_ok=True)  # its stack is built
            if got:
                self.last.update(got)
                self.alive.add(i)
                self.report.rejoined.append({"uav": i + 1, "t": round(k * self.truth.clock.dt_estimation, 9)})
                self.node.send("all", wire.Roster(alive=sorted(self.alive)))

    def _heard(self, links) -> list[list[int]]:
        """Each UAV's living senders in ``links`` (itself left out)."""
        indptr, senders = neighbour_lists(links)
        return [[s for s in senders[indptr[i]:indptr[i + 1]].tolist() if s in self.alive and s != i]
                for i in range(self.n)]

    def _receivers(self, heard: list[list[int]] | None) -> list[list[int]] | None:
        """Each UAV's receivers in ``heard`` (each UAV's senders, :meth:`_heard`): the UAVs its message reaches, now or
        later (the channel's late parts are subsets of the links of their send step), to which it addresses it.
        Every receiver, lost ones too: a lost UAV's process is gone (nothing subscribes to its key, and Zenoh sends
        nothing), and a new one (``--rejoin``) hears what its radio will name. None: all-to-all delivery (or no
        such message this step)."""
        if heard is None or self.all_to_all:
            return None
        out: list[list[int]] = [[] for _ in range(self.n)]
        for j, senders in enumerate(heard):
            for s in senders:
                out[s].append(j)
        return out

    def _probe(self, i: int, name: str, shape: tuple, samples: dict) -> np.ndarray:
        if i in samples:
            return wire.unpack(samples[i].probes[name])
        return np.full((1, *shape), np.nan)

    def _aims(self) -> np.ndarray:
        return np.concatenate([wire.unpack(self.last[i].aim) for i in range(self.n)])


#: What a UAV's detections travel as (every field of :class:`~swarmtrack.sensors.detections.Detections`).
FIELDS = tuple(f.name for f in dataclasses.fields(Detections))


def _row_of_view(view, i: int) -> dict:
    """UAV i's row of a :class:`~swarmtrack.estimation.base.TargetView` (its state, model and motion), packed."""
    return {name: wire.pack(getattr(view, name)[i:i + 1]) for name in ("state", "model", "motion")
            if getattr(view, name) is not None}


def _stacked(rows: list[dict]) -> dict[str, np.ndarray]:
    """The UAVs' reports (each ``{name: packed (1, ...)}``) as the swarm's ``{name: (N, ...)}``."""
    return {name: np.concatenate([wire.unpack(r[name]) for r in rows]) for name in rows[0]}


