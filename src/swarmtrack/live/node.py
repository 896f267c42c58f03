"""One process of the live swarm on the wire: its transport, its seal and the mailbox its subscriptions fill.

Messages are opened as they arrive (on the middleware's threads): what the seal rejects is counted and dropped,
what it accepts is kept in the mailbox by ``(channel, sender, k, c)`` until the process takes it
(:meth:`Node.wait`); a UAV's process drops what is older than the late parts a channel with delays can still
deliver (:meth:`Node.forget`), so its mailbox stays bounded.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable

from swarmtrack.live.transport import Transport, key, parse
from swarmtrack.live.wire import WORLD, Alive, Hello, Message, Rejected, Seal, channel_of, peek

#: Seconds between a process's heartbeats, and without a message after which the world takes a UAV for lost.
HEARTBEAT, LOST_AFTER = 0.2, 3.0
#: Seconds a UAV's process waits, in lockstep, for a silent world that is its parent process and still runs (a world
#: slowed by a busy machine), before it stops.
PARENT_PATIENCE = 60.0
#: Evidence that a process runs with another key: this many consecutive messages of one process identity that fail
#: the seal (and decode, as what they claim to be), spanning at least this many seconds, from a sender none of whose
#: messages passed the seal meanwhile. Random bytes never count; a stranger who wants a refusal must forge such a
#: stream (and is named by the process identity it made up).
EVIDENCE, EVIDENCE_SPAN = 3, 0.8
#: How many process identities whose messages fail the seal are followed per sender (the latest).
SUSPECTS = 16
#: How many messages a UAV's process keeps before it knows its run (checked against the run at its start).
EARLY = 4096


class Stopped(Exception):
    """The world said the run is over (reason ``done``), or is gone (not heard for :data:`LOST_AFTER` s)."""


class Mismatch(Exception):
    """The world and this UAV's process are set up otherwise (another swarm key; a flight through MAVLink on one
    side only): the message says how."""


class Refused(Mismatch):
    """The world refused this UAV's process, or stopped the run on an error: the message says why (exit 2)."""


class Node:
    """``me``: this process's UAV index, or :data:`~swarmtrack.live.wire.WORLD`; ``world``: whether a world process
    runs the swarm (a UAV's process stops when it is no longer heard); in the field none does
    (:mod:`swarmtrack.field`), and a process is told of nobody's absence: it judges its peers by their heartbeats."""

    def __init__(self, transport: Transport, seal: Seal, swarm: str, me: int, world: bool = True):
        self.transport, self.seal, self.swarm, self.me, self.world = transport, seal, swarm, me, world
        self._me = str(me)  # as its keys spell it
        self._box: dict[tuple[str, int, int, int], Message] = {}
        self._cond = threading.Condition()
        self.stopped: str | None = None
        self.absent: set[int] = set()  # UAVs the world said are lost: nobody waits for their messages
        self.seen: dict[int, float] = {}  # when each sender was last heard (monotonic s)
        self.heard: list[tuple] | None = None  # with a list, every step's message is logged with its latency
        self._quiet = threading.Event()  # set by close: the heartbeat stops
        self._beating: threading.Thread | None = None
        self.refused = False  # the stop that came is the world's refusal (or a stop of the run on error)
        # the messages that fail the seal, by the sender and process identity they claim: [first, last, count, msg]
        self.failing: dict[int, dict[int, list]] = {}  # by sender, then proc (at most SUSPECTS per sender)
        self.hellos: dict[tuple[int, int], list] = {}  # the world: bound hellos by (UAV, proc): [msg, first, last]
        self.current: dict[int, int] = {}  # the world: each UAV's process it flies (its proc)
        self.foreign_stops: list[tuple[str, float]] = []  # the world: stops on its keys it did not send
        self.stopping = False  # the world: it sends its stop (what comes on its stop keys afterwards is its own)
        self._own_stops: set[int] = set()  # the world: the sequence numbers of the stops it sent
        # a UAV's process before its start: the worlds it heard ({run: [last heard, pid, whether it heard me]}) and
        # the messages that came (their run checked at the start)
        self.worlds: dict[bytes, list] = {}
        self._early: deque = deque(maxlen=EARLY)
        self.greeting = False  # a UAV's process has said hello: until its start it takes only what binds to it
        # a UAV's process: whether its world still runs though silent (lockstep, a world that is its parent)
        self.world_runs: Callable[[], bool] = lambda: False

    def listen(self, *patterns: tuple[str, ...]) -> None:
        """Subscribe to ``(origin, to, channel)`` key patterns of the swarm's space (``*`` wildcards), or
        ``(origin, to, channel, receiver)`` for the messages addressed to one UAV (:func:`~.transport.key`)."""
        for pattern in patterns:
            self.transport.subscribe(key(self.swarm, *pattern), self._arrive)

    def _arrive(self, key_expr: str, data: bytes) -> None:
        parts = parse(self.swarm, key_expr)
        if parts is None or (parts[0] == "uav" and parts[1] == self._me) or parts[3] not in (None, self._me):
            return  # not the swarm's, its own, or addressed to another UAV
        unbound = self.me != WORLD and self.seal.run is None and self.greeting  # its run known at its start
        try:
            msg = self.seal.open(key_expr, data, fresh=not unbound)
        except Rejected as exc:
            if exc.cause == "forged":
                self._failed(parts, data)
            return
        origin, to, channel, _ = parts
        sender = WORLD if origin == "world" else int(to) if to.isdigit() else None
        if msg.sender != sender or channel_of(msg) != channel:  # a member speaking for another, or a wrong key
            self.seal.count("impersonated")
            return
        with self._cond:
            self.failing.pop(msg.sender, None)  # its messages pass now: what failed was not its
            if self.me == WORLD:
                self._at_world(msg, channel)
            elif unbound and self.seal.run is None:
                self._before_start(msg, channel)
            elif unbound and msg.run != self.seal.run:  # it came as the start bound the process to another run
                self.seal.count("other_run")
            elif unbound and not self.seal.fresh(msg):
                pass
            else:
                self._take(msg, channel)
            self._cond.notify_all()

    def _failed(self, parts: tuple[str, str, str, str | None], data: bytes) -> None:
        """A message that failed the seal: evidence of who sent it when it decodes as what its key says, with a
        process identity (:data:`EVIDENCE`)."""
        origin, to, channel, _ = parts
        msg = peek(data)
        sender = WORLD if origin == "world" else int(to) if to.isdigit() else None
        if msg is None or msg.sender != sender or channel_of(msg) != channel or not msg.proc:
            return
        now = time.monotonic()
        with self._cond:
            suspects = self.failing.setdefault(msg.sender, {})
            if msg.proc not in suspects and len(suspects) >= SUSPECTS:  # a flood of made-up identities: bounded
                del suspects[min(suspects, key=lambda proc: (suspects[proc][2], suspects[proc][1]))]  # the least seen
            entry = suspects.setdefault(msg.proc, [now, now, 0, msg])
            entry[1], entry[2], entry[3] = now, entry[2] + 1, msg

    def evidence(self, sender: int) -> Message | None:
        """A message of a process claiming ``sender`` whose messages have failed the seal :data:`EVIDENCE` times in a
        row over :data:`EVIDENCE_SPAN` s or more (a process with another key), or None."""
        with self._cond:
            for first, last, count, msg in self.failing.get(sender, {}).values():
                if count >= EVIDENCE and last - first >= EVIDENCE_SPAN:
                    return msg
        return None

    def _at_world(self, msg: Message, channel: str) -> None:
        now = time.monotonic()
        if channel == "hello":
            if self.seal.run in msg.worlds:  # fresh: it answers this run's world (else a hello before it heard it)
                entry = self.hellos.setdefault((msg.sender, msg.proc), [msg, now, now])
                entry[0], entry[2] = msg, now
            return
        if channel == "stop":  # on the world's own keys: its own, or another's (passing the seal: --insecure)
            if not self.stopping and not (msg.proc == self.seal.proc and msg.seq in self._own_stops):
                self.foreign_stops.append((msg.reason, time.time()))
            return
        if not msg.run:  # a UAV's process not started yet: its heartbeat says nothing of the run
            return
        if self.current.get(msg.sender, msg.proc) != msg.proc:  # a process of the UAV the world does not fly
            self.seal.count("other_process")
            return
        self._take(msg, channel)

    def _before_start(self, msg: Message, channel: str) -> None:
        """A UAV's process before its start: a world's heartbeat (which runs are there, which heard it), its own start
        (bound to its hello: then the run is its own), a stop bound to its hello; the rest is kept until the run is
        known."""
        if channel == "alive" and msg.sender == WORLD:
            if not self.seal.fresh(msg):
                return
            entry = self.worlds.setdefault(msg.run, [0.0, msg.pid, False])
            entry[0], entry[1] = time.monotonic(), msg.pid
            entry[2] = entry[2] or self.seal.proc in msg.heard
        elif channel in ("start", "stop"):
            if msg.to != self.seal.proc:  # another process's, or another run's
                self.seal.count("other_run")
            elif not self.seal.fresh(msg):
                return
            elif channel == "start":
                self._bind(msg.run)
                self._take(msg, channel)
            else:
                self.stopped, self.refused = msg.reason, msg.refused
        elif channel != "alive":
            self._early.append((msg, channel))

    def _bind(self, run: bytes) -> None:
        """This UAV's process belongs to ``run`` from now: what came before of another run is dropped and counted."""
        self.seal.run = run
        self.seen[WORLD] = time.monotonic()
        early, self._early = list(self._early), deque()
        other = 0
        for msg, channel in early:
            if msg.run == run:
                if self.seal.fresh(msg):
                    self._take(msg, channel)
            else:
                other += 1
        if other:
            self.seal.count("other_run", other)

    def _take(self, msg: Message, channel: str) -> None:
        """A message of this process's run (under the lock)."""
        if channel in ("start", "stop") and msg.to not in (0, self.seal.proc):  # bound to another process
            return
        self.seen[msg.sender] = time.monotonic()
        if self.heard is not None and msg.sender != self.me and channel not in ("alive", "roster", "stop"):
            self.heard.append((channel, msg.sender, msg.k, msg.c, msg.sent, time.time() - msg.sent))
        if channel == "stop":
            self.stopped, self.refused = msg.reason, msg.refused
        elif channel == "roster":
            self.absent = set(range(self.seal.n)) - set(msg.alive)
        elif channel != "alive":
            self._box[(channel, msg.sender, msg.k, msg.c)] = msg

    def heard_worlds(self, within: float = LOST_AFTER) -> list[bytes]:
        """The runs of the worlds this process heard within ``within`` s, latest first (at most 4)."""
        now = time.monotonic()
        with self._cond:
            recent = sorted(((last, run) for run, (last, _, _) in self.worlds.items() if now - last <= within),
                            reverse=True)
        return [run for _, run in recent[:4]]

    def send(self, to: int | str, msg: Message, receivers: list[int] | None = None) -> None:
        """Seal and put ``msg`` on this process's key for ``to`` (a UAV's own keys take their sender as ``to``); a
        hello answers the worlds heard (:meth:`heard_worlds`). ``receivers`` (a UAV's message): put on the key of
        each of these UAVs alone (encoded once, sealed per key; none: not sent), not on its own key."""
        msg.sender = self.me
        if receivers is not None:
            if receivers:
                keys = [key(self.swarm, "uav", self._me, channel_of(msg), j) for j in receivers]
                for k, data in zip(keys, self.seal.seal_each(keys, msg), strict=True):
                    self.transport.put(k, data)
            return
        if isinstance(msg, Hello):
            msg.worlds = self.heard_worlds()
            self.greeting = True
        origin, who = ("world", to) if self.me == WORLD else ("uav", self.me)
        k = key(self.swarm, origin, who, channel_of(msg))
        data = self.seal.seal(k, msg)
        if self.me == WORLD and channel_of(msg) == "stop":
            with self._cond:
                self._own_stops.add(msg.seq)
        self.transport.put(k, data)

    def wait(self, channel: str, senders, k: int, c: int = -1, timeout: float | None = None,
             missing_ok: bool = False, take: bool = True) -> dict[int, Message]:
        """The messages of ``channel`` for step ``(k, c)`` from every sender in ``senders``, taken out of the
        mailbox (``take=False``: left there, until :meth:`forget`); waits for them up to ``timeout`` s (None:
        forever). ``missing_ok``: return what came by the timeout; otherwise a timeout raises ``TimeoutError`` naming
        the missing senders."""
        senders = list(senders)
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            while True:
                missing = [s for s in senders if (channel, s, k, c) not in self._box and s not in self.absent]
                if not missing:
                    break
                if self.me != WORLD and self.world:
                    quiet = time.monotonic() - self.seen.get(WORLD, time.monotonic())
                    if self.stopped is None and quiet > LOST_AFTER and (
                            quiet > PARENT_PATIENCE or not self.world_runs()):
                        self.stopped = f"the world stopped answering (not heard for {quiet:.1f} s)"
                    if self.stopped is not None:
                        raise Refused(self.stopped) if self.refused else Stopped(self.stopped)
                left = None if deadline is None else deadline - time.monotonic()
                if left is not None and left <= 0:
                    if missing_ok:
                        break
                    raise TimeoutError(f"no {channel} of step {k} from {missing}")
                self._cond.wait(1.0 if left is None else min(left, 1.0))  # at least every second: is the world there
            get = self._box.pop if take else self._box.get
            return {s: get((channel, s, k, c)) for s in senders if (channel, s, k, c) in self._box}

    def first(self, channel: str, sender: int, timeout: float) -> Message:
        """The earliest message of ``channel`` from ``sender`` whatever its step, taken out of the mailbox (waits up
        to ``timeout`` s, then ``TimeoutError``)."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                keys = sorted(key_ for key_ in self._box if key_[0] == channel and key_[1] == sender)
                if keys:
                    return self._box.pop(keys[0])
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"no {channel} from {sender}")
                self._cond.wait(left)

    def heartbeat(self) -> None:
        """Send :class:`~swarmtrack.live.wire.Alive` (a UAV to the world, the world to every UAV) every
        :data:`HEARTBEAT` s from a thread of its own, until :meth:`close` (or, on a UAV, until the world says stop)."""
        to = "all" if self.me == WORLD else WORLD

        def beat() -> None:
            while self.stopped is None and not self._quiet.is_set():
                try:
                    self.send(to, Alive(pid=self.seal.pid, started=self.seal.started, heard=self.greeted()))
                except Exception:  # the transport closed under it: the process is ending
                    return
                self._quiet.wait(HEARTBEAT)

        # a daemon, so that a process that never reaches close still ends; close joins it before the transport closes
        self._beating = threading.Thread(target=beat, name="heartbeat", daemon=True)
        self._beating.start()

    def known_by(self) -> tuple[list[int], bool]:
        """A UAV's process before its start: the pids of the worlds that heard its hello, and whether one of them is
        still heard (within :data:`LOST_AFTER` s)."""
        now = time.monotonic()
        with self._cond:
            knowing = [(last, pid) for last, pid, knows in self.worlds.values() if knows]
        return [pid for _, pid in knowing], any(now - last <= LOST_AFTER for last, _ in knowing)

    def greeted(self) -> list[int]:
        """The world: the processes whose hellos it heard within :data:`LOST_AFTER` s (its heartbeat tells them)."""
        if self.me != WORLD:
            return []
        now = time.monotonic()
        with self._cond:
            return sorted(proc for (_, proc), (_, _, last) in self.hellos.items() if now - last <= LOST_AFTER)

    def close(self, timeout: float = 5.0) -> None:
        """Stop the heartbeat and wait for its thread, then close the transport (idempotent). Call it before the
        process ends: a thread still inside the transport's native code when the interpreter shuts down aborts the
        process (:class:`~swarmtrack.live.transport.ZenohTransport`)."""
        self._quiet.set()
        if self._beating is not None and self._beating is not threading.current_thread():
            self._beating.join(timeout)  # a send blocked longer than this ends when the transport closes below
        self.transport.close()
        if self._beating is not None and self._beating is not threading.current_thread():
            self._beating.join(timeout)

    def log(self) -> list[tuple]:
        """The messages received since the last call, ``(channel, sender, k, c, sent, latency)`` (wall-clock s;
        logged once :attr:`heard` is a list), and a fresh log."""
        with self._cond:
            out, self.heard = self.heard or [], []
        return out

    def older(self, channel: str, k: int, c: int = -1) -> list[Message]:
        """Every message of ``channel`` from any sender for a step before ``(k, c)``, taken out of the mailbox in
        step order (in real time, what came after its deadline)."""
        with self._cond:
            keys = [key_ for key_ in self._box if key_[0] == channel and (key_[2], key_[3]) < (k, c)]
            return [self._box.pop(key_) for key_ in sorted(keys, key=lambda key_: (key_[2], key_[3], key_[1]))]

    def peek(self, channel: str, sender: int, k: int, c: int = -1) -> Message | None:
        with self._cond:
            return self._box.get((channel, sender, k, c))

    def forget(self, before: int) -> None:
        """Drop what is kept of estimation steps before ``before`` (a bounded mailbox)."""
        with self._cond:
            for key_ in [key_ for key_ in self._box if key_[2] < before]:
                del self._box[key_]
