"""One UAV's stack in the field (``swarmtrack agent --field``): no world, no radio but the real one.

The same stack as every driver's (:class:`~swarmtrack.onboard.stack.OnboardStack`, built for this UAV alone) runs
on the UAV's own clock: estimation step k at ``epoch + k·dt`` (``--start``: the swarm's agreed t = 0, the clocks
synchronised by NTP or PTP). Its navigation comes from its autopilot over MAVLink or from a topic, its detections
from its sensor's topic (:mod:`swarmtrack.field.sources`, placed on its steps by
:class:`~swarmtrack.field.inputs.FieldInputs`), its neighbours' messages straight over Zenoh
(:class:`~swarmtrack.field.exchange.FieldExchange`); its commands go to its autopilot while the operator lets it.
Every step it publishes its sample (probes, command, navigation, counts) on its own key, for the monitor
(:mod:`swarmtrack.field.monitor`) and the stand-in's camera gimbal.

An agent started after the epoch joins at the current step, its filter fresh: a UAV whose process died is started
again the same way. A source that falls silent, a neighbour no longer heard, a message skipped: each is said on the
console once, when it happens (and when it is over), and counted in the samples.
"""

from __future__ import annotations

import functools
import math
import sys
import time
from datetime import datetime

import numpy as np

from swarmtrack.autopilot.authority import Authority
from swarmtrack.autopilot.link import AutopilotLink
from swarmtrack.field.exchange import FieldExchange, neighbours
from swarmtrack.field.inputs import FieldInputs
from swarmtrack.field.sources import SourceError, SourceUrl, open_source, parse
from swarmtrack.live import wire
from swarmtrack.live.agent import Agent
from swarmtrack.live.exchange import PATIENCE, late_steps
from swarmtrack.live.node import Node
from swarmtrack.onboard.context import labels_of, sensor_labels
from swarmtrack.onboard.warm import warm_up
from swarmtrack.replay.grid import remedy
from swarmtrack.replay.rosbag import Topics
from swarmtrack.replay.steps import LogError

#: Seconds without a message after which a source, or the UAV's neighbours, are said to be silent.
QUIET_AFTER = 2.0
#: When a UAV takes its inputs of a step, as a fraction of the period after the step's time: its sensor's frame of
#: that time, published then, has come (on loopback within a millisecond; one that comes later is the next step's).
INPUTS_BY = 0.1


def start_time(text: str, now: float | None = None) -> float:
    """The epoch a ``--start`` names (wall-clock s): Unix seconds, an ISO 8601 time with its zone, or ``next:S``
    (the next multiple of S seconds of the Unix clock: agents started within S s of each other agree)."""
    now = time.time() if now is None else now
    if text.startswith("next:"):
        try:
            every = float(text[5:])
        except ValueError:
            every = math.nan
        if not every > 0 or not math.isfinite(every):
            raise ValueError(f"{text!r}: next:S takes a positive number of seconds")
        return math.ceil(now / every) * every
    try:
        return float(text)
    except ValueError:
        pass
    try:
        when = datetime.fromisoformat(text)
    except ValueError:
        raise ValueError(f"{text!r} is not a start time: Unix seconds, an ISO 8601 time with its zone "
                         "(2026-12-06T17:00:00+00:00) or next:S") from None
    if when.tzinfo is None:
        raise ValueError(f"{text!r}: give the time's zone (+00:00): the UAVs' clocks must agree on it")
    return when.timestamp()


class FieldAgent(Agent):
    """UAV ``uav`` of ``scenario`` on ``node`` (a node without a world), on the clock that starts at ``epoch``;
    ``navigation`` and ``detections``: its sources (a map's :class:`~swarmtrack.replay.mapping.Source` and
    ``DetectionSource``, topics written as URLs; ``navigation`` None: its autopilot's), ``window`` (s) the map's;
    ``autopilot``: its MAVLink link's URL; ``wait``: how long it waits for a first message of each source before it
    gives up (:class:`SourceError`); ``taps``: live outputs of its own row (:mod:`swarmtrack.streams`)."""

    exchange: FieldExchange

    def __init__(self, scenario, uav: int, node: Node, epoch: float, navigation, detections, window: float,
                 autopilot: str | None = None, reengage: bool = False, wait: float = 10.0, taps=()):
        super().__init__(scenario, uav, node, autopilot, reengage)
        self.epoch, self.wait, self.taps = epoch, wait, list(taps)
        self.exchange = FieldExchange(node, uav, self.n, late_steps(scenario, self.clock.dt_estimation),
                                      neighbours(scenario, uav), epoch)
        self.topics = Topics()
        self.topics.add("navigation", uav, navigation)
        self.topics.add("detections", uav, detections)
        self.inputs = FieldInputs(scenario, uav, epoch, window)
        self.urls: dict[str, SourceUrl] = {s.topic: parse(s.topic) for s in (navigation, detections) if s is not None}
        self.nav_source = None if navigation is None else navigation.topic
        self._silent: set[str] = set()
        self._told: set[str] = set()  # the skip counts' keys said on the console
        self.opened: list = []
        self.problem: str | None = None  # a source whose messages the field cannot read (from its thread)

    def _open_sources(self) -> None:
        """Subscribe to every source and wait for each one's first message (:attr:`wait` s)."""
        for text, url in self.urls.items():
            def on_message(msgtype, msg, received, text=text):
                try:
                    items = list(self.topics.read(text, msgtype, msg, int(received * 1e9), self.inputs.counts))
                except LogError as exc:  # a type the field cannot read (no position, no point): the agent stops
                    self.problem = self.problem or str(exc)
                    return
                for item in items:
                    self.inputs.put(item)

            self.opened.append(open_source(url, self.node.transport, on_message,
                                           functools.partial(self.inputs.skip, topic=text), self.wait))
        deadline = time.monotonic() + self.wait
        for source in self.opened:
            if not source.first.wait(max(0.0, deadline - time.monotonic())):
                raise SourceError(f"{source.url.text}: no message within {self.wait:g} s (is its publisher running, "
                                  "on this network, and is the topic or key spelt as it publishes?)")
            if source.problem is not None:
                raise SourceError(source.problem)
        if self.problem is not None:
            raise SourceError(self.problem)

    def run(self, rejoin: bool = False) -> None:
        """Open its autopilot and sources, build its stack, and step from the current step (the epoch's, or the one
        the clock is at) to the scenario's end."""
        node = self.node
        node.listen(("uav", "*", "share"), ("uav", "*", "publish"), ("uav", "*", "beacon"), ("uav", "*", "plan"),
                    ("uav", "*", "alive"))
        node.heartbeat()
        if self.autopilot is not None:
            self.link = AutopilotLink(self.autopilot, self.i)
            self.authority = Authority(self.link, self.reengage)
            self.authority.engage()
        warm_up(self.scenario, self.i, sensor_labels(self.scenario))
        self.build(labels_of(self.scenario))
        assert self.stack is not None
        probes = {name: list(shape) for name, shape in self.stack.probes.items()}
        for tap in self.taps:  # what the outputs read of the run (the estimator's settings, its probes)
            tap.open({"scenario": self.scenario.name, "estimator": self.scenario.estimator.model_dump(mode="json"),
                      "probes": probes})
        self._open_sources()
        node.heard = []  # every message's latency is logged and reported
        dt = self.clock.dt_estimation
        first = max(0, math.ceil((time.time() - self.epoch) / dt - 1e-9))
        self.inputs.begin(first * dt)
        for k in range(first, self.clock.steps):
            self.step(k)

    def _sleep_until(self, t: float) -> None:
        left = self.epoch + t - time.time()
        if left > 0:
            time.sleep(left)

    def _own_navigation(self, t: float) -> np.ndarray | None:
        """Its navigation at run time ``t``: its autopilot's latest (put among its samples), or its topic's."""
        if self.link is not None and self.nav_source is None:
            nav = self.link.navigation(-1, timeout=PATIENCE)
            self.inputs.put_navigation(t, nav)
            return nav[None]
        return self.inputs.navigation(t)

    def step(self, k: int) -> None:
        """Estimation step ``k`` at its time on this UAV's clock, then the control steps until the next."""
        dt = self.clock.dt_estimation
        t = k * dt
        self._sleep_until(t + INPUTS_BY * dt)
        if self.problem is not None:
            raise SourceError(self.problem)
        segments = list(self.clock.control_segments(k))
        nav = self._own_navigation(t)
        self._say(t)
        if nav is None:  # no navigation for the map's window: nothing to estimate or command from (said by _say)
            return
        detections = self.inputs.detections(t)
        control = t if segments[0][0] else None
        stack = self.stack
        assert stack is not None, "run() builds it first"
        exchange = self.exchange.step(k, 0, t, dt, stack.controller)
        beacon = stack.estimation_step(t, nav, detections, exchange, control)
        exchange.forget(k)
        sample, view = self._sample(k)
        sample.nav, sample.skipped = wire.pack(nav), dict(self.inputs.counts)
        u = None
        if control is not None:
            u = self._command(t, nav, view, exchange, beacon)
            sample.u = wire.pack(u)
        self.node.send(wire.WORLD, sample)
        self._tap(t, nav, u, sample.probes)
        offset = 0
        for c, (control_now, ticks) in enumerate(segments):
            if control_now and c:
                tc = t + offset * self.clock.dt
                self._sleep_until(tc)
                nav_c = self._own_navigation(tc)
                if nav_c is not None:
                    exchange = self.exchange.step(k, c, tc, self.clock.dt_control, stack.controller)
                    self._command(tc, nav_c, view, exchange)
            offset += ticks

    def _tap(self, t: float, nav: np.ndarray, u, probes: dict) -> None:
        """Its own row to the live outputs (ROS 2, Foxglove); ``probes`` its sample's (packed)."""
        if not self.taps:
            return
        from swarmtrack.streams.frame import StepFrame

        estimate, covariance = (wire.unpack(probes[name]) if name in probes else None
                                for name in ("estimate", "covariance"))
        frame = StepFrame(t=t, uavs=np.array([self.i + 1]), uav=np.asarray(nav, dtype=float)[:, :4],
                          present=np.ones(1, dtype=bool), estimate=estimate, covariance=covariance,
                          command=None if u is None else np.asarray(u))
        for tap in self.taps:
            tap.send(frame)

    def _say(self, t: float) -> None:
        """Say on the console a source that fell silent or came back, a UAV that hears none of its neighbours, and
        the first message skipped for each cause on each topic (with what to do; the counts go on in its samples)."""
        now = time.monotonic()
        for key in sorted(set(self.inputs.counts) - self._told):
            self._told.add(key)
            print(f"UAV {self.i + 1}: a message skipped at t = {t:.2f} s: {key} ({remedy(key)}); such messages are "
                  "counted in its samples", file=sys.stderr, flush=True)
        watched = [*self.urls, "neighbours"]
        quiet = set(self.inputs.quiet(list(self.urls), now, QUIET_AFTER))
        peers = self.exchange.peers
        if peers and now - max(self.node.seen.get(s, -math.inf) for s in peers) > QUIET_AFTER:
            quiet.add("neighbours")
        for text in watched:
            what = "none of its neighbours heard" if text == "neighbours" else f"no message on {text}"
            if text in quiet and text not in self._silent:
                print(f"UAV {self.i + 1}: {what} for {QUIET_AFTER:g} s (t = {t:.2f} s); it goes on with what it "
                      "has", file=sys.stderr, flush=True)
            elif text not in quiet and text in self._silent:
                print(f"UAV {self.i + 1}: {'its neighbours heard' if text == 'neighbours' else text} again at "
                      f"t = {t:.2f} s", file=sys.stderr, flush=True)
        self._silent = quiet
