"""The live agent's :class:`~swarmtrack.onboard.exchange.Exchange`: its stack's messages over Zenoh.

Each round is a message of the UAV's own (sent at once: addressed to the UAVs the world's radio says hear it,
:attr:`~swarmtrack.live.wire.Radio.to`, or on its own key for whoever listens) and the neighbours' of the same step,
taken from the mailbox: those the world's simulated radio names, in lockstep, every one (waited for up to
:data:`PATIENCE`); in real time those that came by the round's deadline (:data:`FUSE_BY` ...
of the step's period after it was due), the others counted late. The beacon of a control step that starts with the
estimation step travels in the share message (one message fewer per step: 2.3x to 3.5x faster in lockstep,
docs/live.md). A late share that comes within the scenario's delay bound is fused at its time stamp at the next step.
"""

from __future__ import annotations

import time
from collections import Counter

import numpy as np

from swarmtrack.live import wire
from swarmtrack.live.node import Node
from swarmtrack.network.messages import Inbox, Outbox

#: How long a process waits for a message its step needs before it gives up (s).
PATIENCE = 60.0
#: In real time, when a UAV stops waiting for its neighbours' messages of a step, as fractions of the step's period
#: after the wall-clock time the step is due: their estimation broadcasts (then it fuses what came; what comes later
#: is fused at its time stamp within the scenario's delay bound), their second broadcasts, their plans (IB21 Sec. 5.3).
FUSE_BY, PUBLISH_BY, PLAN_BY = 0.3, 0.5, 0.6


def late_steps(scenario, dt: float) -> int:
    """The estimation steps (of ``dt`` s) a late share can take: the scenario's delay bound."""
    return int(np.ceil(scenario.network.delay_bound() / dt - 1e-9))


class LiveExchange:
    """UAV ``i``'s rounds of messages on ``node`` (of a swarm of ``n``): :meth:`at` sets the step they belong to
    (its navigation message: the radio's word and, in real time, when it was due); ``late_steps``: the estimation
    steps a late share can take (the channel's delay bound)."""

    def __init__(self, node: Node, i: int, n: int, late_steps: int):
        self.node, self.i, self.n, self._late_steps = node, i, n, late_steps
        self._window = late_steps + 2  # the mailbox keeps two more
        self._own: dict[int, dict] = {}  # own outboxes of recent steps (late parts hold the own row too)
        self._pending: dict[int, list[int]] = {}  # real time: per recent step, linked senders not heard by FUSE_BY
        self.late: Counter = Counter()  # real time: neighbours' messages that missed their deadline, by channel
        self.controller = None  # the stack's controller (one that plans in sequence hears plans, IB21 Sec. 5.3)
        self.k = self.c = 0
        self.radio: wire.Radio | None = None
        self.due: float | None = None
        self.period = 0.0

    def at(self, k: int, c: int, radio: wire.Radio | None, due: float | None, period: float,
           controller) -> LiveExchange:
        """The rounds of step ``(k, c)`` (``radio``: whose messages may come; ``due``: in real time, the wall-clock
        time the step is due at, None in lockstep; ``period``: the step's, s) of the stack whose controller is
        ``controller`` (one that plans in sequence hears its lower neighbours' plans)."""
        self.k, self.c, self.radio, self.due, self.period = k, c, radio, due, period
        self.controller = controller
        return self

    def share(self, t: float, outbox: Outbox, beacon: Outbox | None) -> Inbox:
        k = self.k
        self._own[k] = outbox
        radio = self.radio
        receivers = None if radio is None or radio.to is None else \
            radio.to if beacon is None else sorted({*radio.to, *(radio.beacon_to or ())})
        self.node.send(self.i, wire.Share(k=k, taken=t, payloads=pack(outbox),
                                          beacon=None if beacon is None else pack(beacon)), receivers)
        return self._inbox(k, outbox)

    def publish(self, t: float, posteriors: Outbox) -> Inbox | None:
        self.node.send(self.i, wire.Publish(k=self.k, taken=t, payloads=pack(posteriors)),
                       None if self.radio is None else self.radio.to)
        if not posteriors:
            return None
        assert self.radio is not None, "at() sets the step first"
        heard = self._wait("publish", self.radio.links, self.k, -1, PUBLISH_BY)
        # a neighbour that published nothing this step (its stack not sharing yet: one started later) is not heard
        return self._assemble(self.radio.links, {s: m.payloads for s, m in heard.items() if m.payloads}, posteriors)

    def beacons(self, t: float, beacon: Outbox) -> Inbox:
        assert self.radio is not None, "at() sets the step first"
        k, c, senders = self.k, self.c, self.radio.beacons
        if c == 0:  # the beacons came with the shares
            heard = self._wait("share", senders, k, -1, FUSE_BY, take=False, count=False)
            heard = {s: m.beacon for s, m in heard.items()}
        else:
            self.node.send(self.i, wire.Beacon(k=k, c=c, taken=t, payloads=pack(beacon)), self.radio.beacon_to)
            heard = {s: m.payloads for s, m in self._wait("beacon", senders, k, c, FUSE_BY).items()}
        own_plans = getattr(self.controller, "plans", None)
        if own_plans is None:  # not a SequentialPlanner
            return self._assemble(senders, heard, beacon)
        # the plans its lower-indexed neighbours made in this call; in real time, one whose plan did not come in
        # time is not heard
        lower = [s for s in senders if s < self.i and s in heard]
        plans = self._wait("plan", lower, k, c, PLAN_BY)
        heard = {s: b for s, b in heard.items() if s > self.i or s in plans}
        inbox = self._assemble(senders, heard, beacon)
        inbox.payloads.update(self._rows(lower, {s: m.payloads for s, m in plans.items()}, own_plans()))
        return inbox

    def planned(self, t: float, plans: Outbox) -> None:
        to = None if self.radio is None or self.radio.beacon_to is None else \
            [j for j in self.radio.beacon_to if j > self.i]  # those that plan after it (IB21 Sec. 5.3)
        self.node.send(self.i, wire.Plan(k=self.k, c=self.c, taken=t, payloads=pack(plans)), to)

    def forget(self, k: int) -> None:
        """Step ``k`` is over: what is older than the mailbox's window is dropped."""
        self._own.pop(k - self._window, None)
        self.node.forget(k - self._window)

    def _inbox(self, k: int, outbox: dict) -> Inbox:
        """The estimation inbox: this step's part, then the late ones (Inbox.late, oldest first). In lockstep the
        simulated radio names them; in real time this step's part is what came by FUSE_BY, and a late part is what
        came since of an earlier step's, fused at its time stamp within the scenario's delay bound (later: dropped
        and counted)."""
        assert self.radio is not None, "at() sets the step first"
        parts = []
        for send_step, senders in [*self.radio.parts, *self._late_parts(k)]:  # this step's part is always first
            heard = self._wait("share", senders, send_step, -1, FUSE_BY, take=False, count=False)
            if self.due is not None and send_step == k:
                missed = [s for s in senders if s not in heard and s not in self.node.absent]
                self.late["share"] += len(missed)
                if missed and self._late_steps:
                    self._pending[k] = missed
            parts.append(self._assemble(senders, {s: m.payloads for s, m in heard.items()},
                                        self._own.get(send_step, outbox)))
        return Inbox(parts[0].links, parts[0].payloads, tuple(parts[1:]), parts[0].receivers)

    def _late_parts(self, k: int) -> list[tuple[int, list[int]]]:
        """Real time: ``[(send step, senders)]`` of the shares that missed their step's deadline and came since,
        within the delay bound; what is older is forgotten (it was counted late when it missed its deadline)."""
        if self.due is None:
            return []
        parts = []
        for j in sorted(self._pending):
            if j < k - self._late_steps:
                del self._pending[j]
                continue
            came = [s for s in self._pending[j] if self.node.peek("share", s, j) is not None]
            if came:
                parts.append((j, came))
                self.late["share_fused_late"] += len(came)
                self._pending[j] = [s for s in self._pending[j] if s not in came]
        return parts

    def _assemble(self, senders, heard: dict, own: dict) -> Inbox:
        """An inbox of this UAV: its row of the links (the ``senders`` heard: ``heard`` their packed payloads), every
        payload as the swarm's (N, ...) arrays with its own row and the heard senders' rows filled (the others zero:
        never read)."""
        links = np.zeros((1, self.n), dtype=bool)
        links[0, [s for s in senders if s in heard]] = True
        payloads = self._rows(list(senders), heard, own)
        return Inbox(links, payloads, (), np.array([self.i]))

    def _rows(self, senders: list[int], heard: dict[int, dict], own: dict) -> dict:
        senders = [s for s in senders if s in heard]  # a sender lost meanwhile is not heard
        out = {}
        for name, value in own.items():
            value = np.asarray(value)
            full = np.empty((self.n, *value.shape[1:]), dtype=object) if value.dtype == object else \
                np.zeros((self.n, *value.shape[1:]), dtype=value.dtype)
            full[self.i] = value[0]
            for s in senders:
                full[s] = wire.unpack(heard[s][name])[0]
            out[name] = full
        return out

    def _wait(self, channel: str, senders, k: int, c: int, by: float, take: bool = True, count: bool = True) -> dict:
        """The messages of ``channel`` for step ``(k, c)`` from ``senders``: in lockstep (not due) every one (waiting
        up to PATIENCE); in real time, those come by ``due + by · period`` (wall clock; with ``count``, the others
        are counted in :attr:`late`)."""
        if self.due is None:
            return self.node.wait(channel, senders, k, c, timeout=PATIENCE, take=take)
        got = self.node.wait(channel, senders, k, c, timeout=max(0.0, self.due + by * self.period - time.time()),
                             missing_ok=True, take=take)
        if count:
            self.late[channel] += len([s for s in senders if s not in got and s not in self.node.absent])
        return got


def pack(outbox: dict | None) -> dict:
    return {name: wire.pack(v if type(v) is np.ndarray else np.asarray(v)) for name, v in (outbox or {}).items()}
