"""One process of the live swarm on the wire: its transport, its seal and the mailbox its subscriptions fill.

Messages are opened as they arrive (on the middleware's threads): what the seal rejects is counted and dropped,
what it accepts is kept in the mailbox by ``(channel, sender, k, c)`` until the process takes it
(:meth:`Node.wait`); a UAV's process drops what is older than the late parts a channel with delays can still
deliver (:meth:`Node.forget`), so its mailbox stays bounded.
"""

from __future__ import annotations

import threading
import time

from swarmtrack.live.transport import Transport, key, parse
from swarmtrack.live.wire import WORLD, Alive, Message, Rejected, Seal, channel_of

#: Seconds between a process's heartbeats, and without a message after which the world takes a UAV for lost.
HEARTBEAT, LOST_AFTER = 0.2, 3.0


class Stopped(Exception):
    """The world said the run is over (reason ``done``), or is gone (not heard for :data:`LOST_AFTER` s)."""


class Mismatch(Exception):
    """The world and this UAV's process are set up otherwise (another swarm key; a flight through MAVLink on one
    side only): the message says how."""


class Node:
    """``me``: this process's UAV index, or :data:`~swarmtrack.live.wire.WORLD`."""

    def __init__(self, transport: Transport, seal: Seal, swarm: str, me: int):
        self.transport, self.seal, self.swarm, self.me = transport, seal, swarm, me
        self._box: dict[tuple[str, int, int, int], Message] = {}
        self._cond = threading.Condition()
        self.stopped: str | None = None
        self.absent: set[int] = set()  # UAVs the world said are lost: nobody waits for their messages
        self.seen: dict[int, float] = {}  # when each sender was last heard (monotonic s)
        self.forged: set[tuple[str, str, str]] = set()  # (origin, to, channel) of the keys forged messages came on
        self.heard: list[tuple] | None = None  # with a list, every step's message is logged with its latency
        self._quiet = threading.Event()  # set by close: the heartbeat stops
        self._beating: threading.Thread | None = None

    def listen(self, *patterns: tuple[str, str, str]) -> None:
        """Subscribe to ``(origin, to, channel)`` key patterns of the swarm's space (``*`` wildcards)."""
        for origin, to, channel in patterns:
            self.transport.subscribe(key(self.swarm, origin, to, channel), self._arrive)

    def _arrive(self, key_expr: str, data: bytes) -> None:
        parts = parse(self.swarm, key_expr)
        if parts is None or (parts[0] == "uav" and parts[1] == str(self.me)):  # not the swarm's, or its own
            return
        try:
            msg = self.seal.open(key_expr, data)
        except Rejected as exc:
            if exc.cause == "forged":
                with self._cond:
                    self.forged.add(parts)
            return
        origin, to, channel = parts
        sender = WORLD if origin == "world" else int(to) if to.isdigit() else None
        if msg.sender != sender or channel_of(msg) != channel:  # a member speaking for another, or a wrong key
            with self._cond:
                self.seal.rejected["impersonated"] += 1
            return
        with self._cond:
            self.seen[msg.sender] = time.monotonic()
            if self.heard is not None and msg.sender != self.me and channel not in ("alive", "roster", "stop"):
                self.heard.append((channel, msg.sender, msg.k, msg.c, msg.sent, time.time() - msg.sent))
            if channel == "stop":
                self.stopped = getattr(msg, "reason", "done")
            elif channel == "roster":
                self.absent = set(range(self.seal.n)) - set(msg.alive)
            elif channel != "alive":
                self._box[(channel, msg.sender, msg.k, msg.c)] = msg
            self._cond.notify_all()

    def send(self, to: int | str, msg: Message) -> None:
        """Seal and put ``msg`` on this process's key for ``to`` (a UAV's own keys take their sender as ``to``)."""
        msg.sender = self.me
        origin, who = ("world", to) if self.me == WORLD else ("uav", self.me)
        k = key(self.swarm, origin, who, channel_of(msg))
        self.transport.put(k, self.seal.seal(k, msg))

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
                if self.me != WORLD:
                    if self.stopped is None and time.monotonic() - self.seen.get(WORLD, time.monotonic()) > LOST_AFTER:
                        self.stopped = f"the world stopped answering (not heard for {LOST_AFTER:g} s)"
                    if self.stopped is not None:
                        raise Stopped(self.stopped)
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
                    self.send(to, Alive())
                except Exception:  # the transport closed under it: the process is ending
                    return
                self._quiet.wait(HEARTBEAT)

        # a daemon, so that a process that never reaches close still ends; close joins it before the transport closes
        self._beating = threading.Thread(target=beat, name="heartbeat", daemon=True)
        self._beating.start()

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
