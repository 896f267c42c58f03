"""One UAV's own process: exactly the onboard stack the simulator runs for that UAV (its estimator and controller,
built through the registry for the one UAV, ``Context.uavs = [i]``), fed by messages.

The UAV follows the world's steps, the simulator's step loop (:func:`swarmtrack.sim.engine.step_loop`) seen from one
UAV (:meth:`Agent.step`): take the step's message (its navigation, or its autopilot's; its detections; the simulated
radio's word); share, with the beacon of the control step that starts now; fuse what the radio delivered; (publish;
combine); take its probes; command (hearing the beacons the radio delivered, and the plans of its lower-indexed
neighbours, IB21 Sec. 5.3); answer with its probes and its command. A control step between estimation steps is one
more exchange (:meth:`Agent.control`). Its stack's steps are :class:`~swarmtrack.onboard.stack.OnboardStack`'s, its
messages those of :class:`~swarmtrack.live.exchange.LiveExchange`: in lockstep it waits for every message its radio
names; in real time until deadlines (:data:`~swarmtrack.live.exchange.FUSE_BY` ...). Its inputs are its own
navigation, its own detections and its inbox: nothing else reaches this process.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import time

import numpy as np

from swarmtrack import registry
from swarmtrack.autopilot.authority import Authority
from swarmtrack.autopilot.link import AutopilotError, AutopilotLink, AutopilotRefused
from swarmtrack.estimation.base import TargetView
from swarmtrack.live import wire
from swarmtrack.live.exchange import PATIENCE, LiveExchange, late_steps, pack
from swarmtrack.live.node import EVIDENCE, EVIDENCE_SPAN, LOST_AFTER, Mismatch, Node, Refused, Stopped
from swarmtrack.onboard.build import onboard_stack
from swarmtrack.onboard.context import clock_of, context
from swarmtrack.onboard.stack import OnboardStack
from swarmtrack.onboard.warm import warm_up
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sensors.detections import Detections

#: Seconds the interpreter lets the main thread hold the GIL while another thread waits for it (Python's default:
#: 0.005): a neighbour's message that comes while the stack computes waits at most this long for the callback that
#: files it (a fifth of a real-time share deadline at Python's default, a twentieth here).
SWITCH_INTERVAL = 0.001
#: Seconds between a starting UAV's hellos.
HELLO_EVERY = 0.5
#: Seconds a UAV that cannot fly (its autopilot link) says so to the world before it exits, at most.
FAREWELL = 10.0
#: How the console names the believed cause of a handover (:func:`swarmtrack.autopilot.authority.cause`).
CAUSES = {"operator": "its operator: a pilot's switch or a ground station's command",
          "failsafe": "its autopilot's failsafe", "disarm": "disarmed", "land": "landing",
          "released": "handed back on a ground station's request"}


def scenario_hash(scenario: Scenario) -> str:
    """What two processes compare to know they run the same resolved scenario."""
    return hashlib.sha256(json.dumps(scenario.model_dump(mode="json"), sort_keys=True).encode()).hexdigest()[:16]


def build_onboard(scenario: Scenario, uav: int, labels: dict[str, list[int | None]]) -> OnboardStack:
    """UAV ``uav``'s stack, built for it alone; ``labels`` the sensor's label of each member of each sensed group
    (the world's ``start`` message)."""
    return onboard_stack(context(scenario, lambda group, member: labels[group][member], uavs=[uav]))


def telemetry_of(scenario: Scenario) -> dict[str, registry.Telemetry]:
    """The telemetry of the scenario's estimator and controller kinds that register one (what their truth-side
    monitors read of them), by role."""
    out = {}
    for role in ("estimator", "controller"):
        kind = registry.get(role, getattr(scenario, role).kind)
        if kind.telemetry is not None:
            out[role] = registry.resolve(kind.telemetry)
    return out


class Agent:
    """UAV ``uav`` of ``scenario`` on ``node`` (its transport and seal); ``autopilot``: the URL of its autopilot's
    MAVLink link (:mod:`swarmtrack.autopilot.link`), which then gives its navigation and takes its commands while the
    operator lets it (:mod:`swarmtrack.autopilot.authority`; ``reengage``: its opt-in re-engagement after a link
    loss)."""

    def __init__(self, scenario: Scenario, uav: int, node: Node, autopilot: str | None = None,
                 reengage: bool = False):
        self.scenario, self.i, self.node, self.autopilot, self.reengage = scenario, uav, node, autopilot, reengage
        self.link: AutopilotLink | None = None
        self.authority: Authority | None = None
        self.flying = False  # whether it has sent its autopilot a command of its controller
        self.n = scenario.swarm.n_uavs
        self.clock = clock_of(scenario)
        self.stack: OnboardStack | None = None
        self._telemetry = telemetry_of(scenario)
        # its messages; a late share can take the estimation steps of the channel's delay bound
        self.exchange = LiveExchange(node, uav, self.n, late_steps(scenario, self.clock.dt_estimation))
        self._cpu = time.process_time()
        self._received: tuple[int, float] = (0, 0.0)  # its subscriptions' messages and their CPU time so far

    def run(self, rejoin: bool = False) -> None:
        """Say hello, build the stack when the world says start, and follow its steps to the end. ``rejoin``: the
        UAV's earlier process was lost (or is to be replaced); this one starts afresh at the step the world gives
        it."""
        node = self.node
        sys.setswitchinterval(SWITCH_INTERVAL)
        node.greeting = True  # until its start, it takes only what binds to its hello (the run is not known yet)
        # its neighbours' messages addressed to it (its world's radio names their receivers), and those on their
        # own keys (a world asked for all-to-all delivery: every UAV hears every UAV, the radio decides)
        node.listen(("world", str(self.i), "*"), ("world", "all", "*"), ("uav", "*", "*", str(self.i)),
                    ("uav", "*", "share"), ("uav", "*", "publish"), ("uav", "*", "beacon"), ("uav", "*", "plan"))
        node.heartbeat()
        hello = wire.Hello(pid=os.getpid(), started=node.seal.started, scenario=scenario_hash(self.scenario),
                           autopilot=self.autopilot is not None, rejoin=rejoin)
        if self.autopilot is not None:  # its autopilot first, as a companion computer does: armed, in offboard mode
            try:
                self.link = AutopilotLink(self.autopilot, self.i)
                self.authority = Authority(self.link, self.reengage)
                self.authority.engage()
            except (AutopilotError, AutopilotRefused) as exc:
                hello.error = str(exc)
                self._farewell(hello)  # the world learns why this UAV will not fly, at once
                raise
        start = self._greet(hello)
        world = node.worlds.get(node.seal.run)
        if not start.realtime and world is not None and world[1] == os.getppid():  # started by its world (live)
            parent = world[1]
            node.world_runs = lambda: os.getppid() == parent  # a lockstep world slowed by a busy machine is waited for
        if not rejoin and start.k:
            raise Mismatch(f"the swarm is at step {start.k} already: start this UAV with --rejoin")
        if start.mavlink != (self.autopilot is not None):
            raise Mismatch("the world flies its UAVs through MAVLink autopilots (--mavlink): give --autopilot URL"
                           if start.mavlink else "--autopilot: the world does not fly its UAVs through MAVLink "
                           "(start it with --mavlink)")
        # the kernels loaded (compiled, when numba's cache is cold) before it says it is ready, in lockstep too: the
        # world waits for that as long as the process is heard, but for a step only its patience
        warm_up(self.scenario, self.i, lambda group, member: start.labels[group][member])
        if start.realtime:
            node.heard = []  # every message's latency is logged and reported
        self.build(start.labels)
        node.send(wire.WORLD, self._sample(-1)[0])  # ready: its stack is built
        try:
            for k in range(start.k, self.clock.steps):
                self.step(k)
        except Stopped as exc:
            if str(exc) == "done" and node.seal.key is None:
                print(f"UAV {self.i + 1}: warning: a stop came before the run's end, unsealed: this run is --insecure, "
                      "so anyone on the network can send one (the world flies this UAV safely from now)",
                      file=sys.stderr, flush=True)
            raise

    def build(self, labels: dict[str, list[int | None]]) -> None:
        """Its stack, built for this UAV alone (``labels``: the world's, from its ``start``)."""
        self.stack = build_onboard(self.scenario, self.i, labels)

    def _greet(self, hello: wire.Hello) -> wire.Start:
        """Say ``hello`` until the world starts this process (a ``start`` bound to its hello); said again at once when
        a new world is heard, every :data:`HELLO_EVERY` s otherwise. Ends on the world's refusal (bound to its
        hello: :class:`~swarmtrack.live.node.Refused`), on evidence that the world runs with another key
        (:class:`Mismatch`), when the world that heard it is no longer heard (:class:`Stopped`), or after
        :data:`PATIENCE` s (``TimeoutError``)."""
        node, deadline = self.node, time.monotonic() + PATIENCE
        said, first_said, worlds, told = -np.inf, np.inf, set(), 0
        while True:
            if node.stopped is not None:
                raise Refused(node.stopped) if node.refused else Stopped(node.stopped)
            if set(node.heard_worlds()) != worlds or time.monotonic() - said >= HELLO_EVERY:
                node.send(wire.WORLD, hello)
                said, worlds, told = time.monotonic(), set(hello.worlds), told + 1
                first_said = min(first_said, said)
            try:
                return node.first("start", wire.WORLD, timeout=0.1)
            except TimeoutError:
                pass
            wrong = node.evidence(wire.WORLD)
            if wrong is not None and not node.heard_worlds():
                # its hellos go on until the world too has its evidence (they fail its key): both sides name the key
                while told < EVIDENCE + 1 or time.monotonic() - first_said < EVIDENCE_SPAN + HELLO_EVERY:
                    time.sleep(max(0.0, said + HELLO_EVERY - time.monotonic()))
                    node.send(wire.WORLD, hello)
                    said, told = time.monotonic(), told + 1
                raise Mismatch(f"the world's messages (process {getattr(wrong, 'pid', '?')}) fail this UAV's swarm "
                               "key: the world runs with another --key (or without one)")
            knowing, there = node.known_by()
            if knowing and not there:
                raise Stopped(f"the world (process {knowing[0]}) that heard this UAV stopped answering before it "
                              f"started it (not heard for {LOST_AFTER:g} s)")
            if time.monotonic() >= deadline:
                raise TimeoutError(f"no start from the world within {PATIENCE:g} s")

    def _farewell(self, hello: wire.Hello) -> None:
        """Say ``hello`` (with its error) until the world has heard it (it answers with a stop, or lists this process
        among those it heard), for up to :data:`FAREWELL` s."""
        node, deadline = self.node, time.monotonic() + FAREWELL
        while time.monotonic() < deadline and node.stopped is None:
            node.send(wire.WORLD, hello)
            if node.known_by()[0]:
                time.sleep(HELLO_EVERY)  # its answer, the stop, on its way
                return
            time.sleep(0.1 if node.heard_worlds() else HELLO_EVERY)

    def step(self, k: int) -> None:
        """Estimation step ``k`` (:meth:`~swarmtrack.onboard.stack.OnboardStack.estimation_step`), then the control
        step that starts with it and those until the next (:meth:`control`)."""
        node, dt = self.node, self.clock.dt_estimation
        got = node.wait("navigation", [wire.WORLD], k, timeout=PATIENCE)[wire.WORLD]
        nav = self._navigation(got)
        detections = Detections(**{name: wire.unpack(v) for name, v in got.detections.items()})
        exchange = self.exchange.at(k, 0, got.radio, got.due, dt, self.stack.controller)
        beacon = self.stack.estimation_step(k * dt, nav, detections, exchange, got.control)
        exchange.forget(k)
        sample, view = self._sample(k)
        if got.guide is not None:  # an external tracker's view of the target (controller.follow: truth)
            view = TargetView(**{name: wire.unpack(v) for name, v in got.guide.items()})
        if got.control is not None:  # its beacon went with the share
            sample.u = wire.pack(self._command(got.control, nav, view, exchange, beacon))
        node.send(wire.WORLD, sample)
        for c, (control_now, _) in enumerate(self.clock.control_segments(k)):
            if control_now and c:
                self.control(k, c, view)

    def control(self, k: int, c: int, view) -> None:
        """A control step between estimation steps: its navigation and beacon radio from the world, its command
        back."""
        got = self.node.wait("navigation", [wire.WORLD], k, c, timeout=PATIENCE)[wire.WORLD]
        exchange = self.exchange.at(k, c, got.radio, got.due, self.clock.dt_control,
                                          self.stack.controller)
        u = self._command(got.taken, self._navigation(got), view, exchange)
        self.node.send(wire.WORLD, wire.Command(k=k, c=c, taken=got.taken, u=wire.pack(u)))

    def _command(self, t: float, nav: np.ndarray, view, exchange: LiveExchange, beacon: dict | None = None):
        """The control step at ``t`` (:meth:`~swarmtrack.onboard.stack.OnboardStack.control_step`); its command is
        flown through its autopilot while the operator lets it."""
        u = np.asarray(self.stack.control_step(t, nav, view, exchange, self.clock.dt_control, beacon))
        if self.authority is not None:
            self._fly(u[0], t)
        return u

    def _navigation(self, got: wire.Navigation) -> np.ndarray:
        """Its navigation solution (1, d): the world's word, or its autopilot's (``LOCAL_POSITION_NED``): in lockstep
        the one of the step's time, in real time the latest."""
        if self.link is None:
            return wire.unpack(got.nav)
        after = -1 if got.due is not None else int(round(got.taken * 1000)) - 1
        return self.link.navigation(after, timeout=PATIENCE)[None]

    def _fly(self, u: np.ndarray, t: float) -> None:
        """Send the command ``u`` of time ``t`` to its autopilot as a setpoint, while its operator lets it; say each
        handover and engagement once."""
        self.flying |= self.authority.fly(u, t)
        for event in self.authority.take(t):
            if event["event"] == "handover":
                again = ("it engages again once its link is back (--reengage-after-link-loss)"
                         if event["cause"] == "failsafe" and self.reengage else "it engages again only when asked")
                print(f"UAV {self.i + 1}: its autopilot left offboard mode at t = {t:.2f} s: {event['mode']}"
                      f"{'' if event['armed'] else ', disarmed'} ({CAUSES[event['cause']]}); this UAV no longer "
                      f"commands it and goes on estimating and sharing; {again} "
                      f"(swarmtrack engage --uav {self.i + 1}: docs/autopilot.md)", file=sys.stderr, flush=True)
            elif event["event"] == "engaged":
                print(f"UAV {self.i + 1}: engaged again at t = {t:.2f} s ({event['by']})", file=sys.stderr,
                      flush=True)
            else:
                print(f"UAV {self.i + 1}: not engaged again at t = {t:.2f} s: {event['why']}; it engages again "
                      f"only when asked (swarmtrack engage --uav {self.i + 1})", file=sys.stderr, flush=True)

    def _sample(self, k: int) -> tuple[wire.Sample, TargetView]:
        """The step's probes, and where a gimballed sensor should aim at the next frame (its latest estimate); and
        the estimator's view, which the controller follows until the next step."""
        stack = self.stack
        probes = {} if k < 0 else stack.sample()
        view = stack.estimator.view()
        reports = {role: telemetry.report(getattr(stack, role)) for role, telemetry in self._telemetry.items()}
        now = time.process_time()
        cpu, self._cpu = now - self._cpu, now
        tally = getattr(self.node.transport, "received", None)
        got = (0, 0.0) if tally is None else tally()
        received, self._received = (got[0] - self._received[0], got[1] - self._received[1]), got
        return wire.Sample(k=k, probes=pack(probes), aim=wire.pack(view.state[:, :2]),
                           telemetry={role: pack(r) for role, r in reports.items()},
                           rejected=dict(self.node.seal.rejected), cpu=cpu, received=received[0],
                           receive_cpu=received[1], heard=self.node.log(),
                           late=dict(self.exchange.late), autopilot=[] if self.authority is None else
                           [e for e in self.authority.events if "t" in e]), view  # those its steps saw
