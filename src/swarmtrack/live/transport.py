"""The middleware under the live swarm: a small :class:`Transport` interface (put bytes on a key, subscribe to a key
expression), implemented over Eclipse Zenoh (:class:`ZenohTransport`: peer mode, no daemon, multicast scouting off;
loopback unless endpoints are given). Another middleware is one more class with these three methods.

Key space (:func:`key`): ``swarmtrack/<swarm>/uav/<i>/<channel>`` for what UAV i sends, and
``swarmtrack/<swarm>/world/<i>/<channel>`` for what the world sends UAV i (``.../world/all/<channel>`` to every UAV).
"""

from __future__ import annotations

import contextlib
import json
import socket
import threading
from collections.abc import Callable
from typing import Protocol

PREFIX = "swarmtrack"


class TransportError(Exception):
    """The middleware could not start (an endpoint in use, a peer unreachable): the message names the cause."""


class Transport(Protocol):
    def put(self, key: str, data: bytes) -> None:
        """Send ``data`` on ``key`` (best effort, reliable where the middleware is)."""

    def subscribe(self, key_expr: str, callback: Callable[[str, bytes], None]) -> object:
        """Call ``callback(key, data)`` for every message on ``key_expr`` (``*`` one chunk), from the middleware's
        threads; keep the returned handle alive."""

    def close(self) -> None:
        """Stop (idempotent): no callback runs once it has returned."""


def key(swarm: str, origin: str, to: int | str, channel: str) -> str:
    """``swarmtrack/<swarm>/<origin>/<to>/<channel>``: ``origin`` ``uav`` (then ``to`` is the sender) or ``world``
    (then ``to`` is the receiver, or ``all``)."""
    return f"{PREFIX}/{swarm}/{origin}/{to}/{channel}"


def parse(swarm: str, key_expr: str) -> tuple[str, str, str] | None:
    """``(origin, to, channel)`` of a key of ``swarm``'s space, None for any other key."""
    parts = str(key_expr).split("/")
    if len(parts) != 5 or parts[0] != PREFIX or parts[1] != swarm:
        return None
    return parts[2], parts[3], parts[4]


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port nothing listens on now (the world's default endpoint on loopback)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


#: Seconds :meth:`ZenohTransport.close` waits for each subscription's callback thread to finish what it has queued.
DRAIN = 5.0


class ZenohTransport:
    """Eclipse Zenoh in peer mode: ``listen`` and ``connect`` endpoint lists (``tcp/127.0.0.1:7447``), multicast
    scouting off (peers meet through the endpoints given, and gossip); a ``connect`` endpoint that cannot be reached
    within ``timeout`` s is an error.

    Callbacks run on the Python thread zenoh-python starts for each subscription (its default, indirect callbacks:
    never on Zenoh's own threads). :meth:`close` undeclares the subscriptions, joins those threads and closes the
    session, so that nothing of Zenoh calls into Python once it has returned: a call
    that re-enters the interpreter while it shuts down ends its thread by ``pthread_exit``, which aborts the process
    when the thread is inside Zenoh's Rust code (``FATAL: exception not rethrown``, exit −6; docs/live.md).
    Close it before the interpreter exits, from the thread that made it, after every thread that sends through it
    has stopped."""

    def __init__(self, listen: list[str] = (), connect: list[str] = (), timeout: float = 5.0):
        import zenoh

        conf = zenoh.Config()
        conf.insert_json5("mode", '"peer"')
        conf.insert_json5("scouting/multicast/enabled", "false")
        if listen:
            conf.insert_json5("listen/endpoints", json.dumps(list(listen)))
        if connect:
            conf.insert_json5("connect/endpoints", json.dumps(list(connect)))
            conf.insert_json5("connect/timeout_ms", str(int(timeout * 1000)))
            conf.insert_json5("connect/exit_on_failure", "true")
        try:
            self.session = zenoh.open(conf)
        except zenoh.ZError as exc:
            raise TransportError(_cause(str(exc), listen, connect)) from None
        self._zenoh = zenoh
        self._publishers: dict[str, object] = {}
        self._subscribers: list = []
        self._closed = False

    def put(self, key: str, data: bytes) -> None:
        pub = self._publishers.get(key)
        if pub is None:
            pub = self._publishers[key] = self.session.declare_publisher(
                key, express=True, congestion_control=self._zenoh.CongestionControl.BLOCK)
        pub.put(data)

    def subscribe(self, key_expr: str, callback: Callable[[str, bytes], None]) -> object:
        def handler(sample) -> None:
            callback(str(sample.key_expr), sample.payload.to_bytes())

        before = set(threading.enumerate())
        sub = self.session.declare_subscriber(key_expr, handler)
        # the thread zenoh-python started for this subscription's callbacks (joined by close)
        self._subscribers.append((sub, [t for t in threading.enumerate() if t not in before
                                        and "pyo3-closure" in t.name]))
        return sub

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        for sub, _ in self._subscribers:
            with contextlib.suppress(self._zenoh.ZError):
                sub.undeclare()
        for _sub, threads in self._subscribers:  # undeclared: each ends once it has run what was queued
            for thread in threads:
                if thread is not threading.current_thread():
                    thread.join(DRAIN)
        self.session.close()  # and with it the publishers
        self._subscribers, self._publishers = [], {}


def _cause(text: str, listen, connect) -> str:
    if "Address already in use" in text:
        return f"cannot listen on {', '.join(listen)}: the address is in use"
    if "Unable to connect" in text:
        return f"cannot reach {', '.join(connect)} (nothing answers there)"
    return f"Zenoh could not start: {text.split(' at ')[0]}"
