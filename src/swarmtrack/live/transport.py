"""The middleware under the live swarm: a small :class:`Transport` interface (put bytes on a key, subscribe to a key
expression), implemented over Eclipse Zenoh (:class:`ZenohTransport`: peer mode, no daemon, multicast scouting off;
loopback unless endpoints are given; TLS with mutual authentication as an option). Another middleware is one more
class with these three methods.

No peer can block a put (docs/live.md, "Congestion"): every message is published with Zenoh's ``DROP`` congestion
control, express (not batched), on a priority per channel (:data:`PRIORITY`). Zenoh keeps one transmission queue
per peer and per priority; when the queue towards one peer stays full for ``wait_before_drop`` (1 ms), that message
is dropped *towards that peer only* and the queue is marked congested (later messages to it are dropped at once until
it drains); the other peers get theirs as before. With ``BLOCK`` the put waited for the slowest subscriber, up to
5 s, then Zenoh closed its link.

Key space (:func:`key`): ``swarmtrack/<swarm>/uav/<i>/<channel>`` for what UAV i sends to whoever listens,
``swarmtrack/<swarm>/uav/<i>/<channel>/<j>`` for what UAV i sends UAV j alone (its neighbours' messages, addressed
to the UAVs that hear it), and ``swarmtrack/<swarm>/world/<i>/<channel>`` for what the world sends UAV i
(``.../world/all/<channel>`` to every UAV).
"""

from __future__ import annotations

import contextlib
import json
import socket
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Protocol

PREFIX = "swarmtrack"

#: Zenoh's priority of each channel (the last chunk of a key): what says who is alive and when the run ends travels
#: on a queue of its own, never behind the data (a peer's link congested by data still hears the heartbeats).
#: Every other channel (``navigation``, ``share``, ``publish``, ``beacon``, ``plan``, ``command``, ``sample``) is
#: ``DATA``. Each UAV's mailbox is keyed by (channel, sender, step), so what comes first does not matter.
PRIORITY = {"alive": "INTERACTIVE_HIGH", "roster": "INTERACTIVE_HIGH", "stop": "INTERACTIVE_HIGH",
            "hello": "INTERACTIVE_HIGH", "start": "INTERACTIVE_HIGH"}

#: Zenoh's transmission queue per peer and priority, in batches (express: one message each; Zenoh's default is 2,
#: its maximum 16): a member's burst (a rejoined UAV's catch-up, a busy machine's scheduler) fits before a drop.
QUEUE_BATCHES = 16

#: Microseconds Zenoh waits for room in a full queue before it drops a message towards that peer (its default), and
#: before it closes the link of a peer that does not take Zenoh's own reliable messages (declarations; 5 s by
#: default): a frozen stranger is cut off within a second instead of holding the close of every session.
WAIT_BEFORE_DROP_US, WAIT_BEFORE_CLOSE_US = 1000, 1_000_000

#: The files of a TLS folder (``--tls DIR``): the swarm's certificate authority, this process's certificate (signed
#: by it) and its private key. Every process presents its certificate and accepts only peers signed by the CA.
TLS_FILES = ("ca.pem", "cert.pem", "key.pem")

#: The endpoint protocols the live commands take.
PROTOCOLS = ("tcp", "tls")


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


def key(swarm: str, origin: str, to: int | str, channel: str, receiver: int | str | None = None) -> str:
    """``swarmtrack/<swarm>/<origin>/<to>/<channel>``: ``origin`` ``uav`` (then ``to`` is the sender) or ``world``
    (then ``to`` is the receiver, or ``all``); with ``receiver``, ``.../uav/<sender>/<channel>/<receiver>``: a UAV's
    message addressed to one UAV (per-neighbour delivery: only that UAV subscribes to it)."""
    if receiver is None:
        return f"{PREFIX}/{swarm}/{origin}/{to}/{channel}"
    return f"{PREFIX}/{swarm}/{origin}/{to}/{channel}/{receiver}"


def parse(swarm: str, key_expr: str) -> tuple[str, str, str, str | None] | None:
    """``(origin, to, channel, receiver)`` of a key of ``swarm``'s space (``receiver`` None but on an addressed key),
    None for any other key."""
    parts = str(key_expr).split("/")
    if not 5 <= len(parts) <= 6 or parts[0] != PREFIX or parts[1] != swarm or (len(parts) == 6 and parts[2] != "uav"):
        return None
    return parts[2], parts[3], parts[4], parts[5] if len(parts) == 6 else None


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port nothing listens on now (the world's default endpoint on loopback)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def endpoint_problem(endpoint: str, tls: bool) -> str | None:
    """Why ``endpoint`` is not one the live commands take (``tcp/HOST:PORT``, or ``tls/HOST:PORT`` with TLS), or
    None; Zenoh's own parser has the last word (:func:`zenoh_problem`)."""
    proto, sep, rest = endpoint.partition("/")
    address = rest.split("?")[0].split("#")[0]
    host, _, port = address.rpartition(":")
    if not sep or proto not in PROTOCOLS or not host or not port.isdigit() or not 0 < int(port) < 65536:
        return f"{endpoint!r} is not an endpoint: expected {'tls' if tls else 'tcp'}/HOST:PORT (PORT 1..65535)"
    if tls and proto != "tls":
        return f"{endpoint!r}: with --tls every endpoint is tls/HOST:PORT"
    if not tls and proto == "tls":
        return f"{endpoint!r}: a tls/ endpoint needs --tls DIR (the certificates)"
    return zenoh_problem(endpoint)


def zenoh_problem(endpoint: str) -> str | None:
    """What Zenoh's configuration says of ``endpoint`` (None: it takes it), without opening anything."""
    import zenoh

    try:
        zenoh.Config().insert_json5("listen/endpoints", json.dumps([endpoint]))
    except zenoh.ZError as exc:
        return f"{endpoint!r} is not an endpoint Zenoh takes: {_short(str(exc))}"
    return None


def tls_problem(folder: Path) -> str | None:
    """What is missing from a TLS folder (:data:`TLS_FILES`), or None."""
    if not folder.is_dir():
        return f"{folder}: not a folder (expected {', '.join(TLS_FILES)}; docs/live.md, \"TLS\")"
    missing = [name for name in TLS_FILES if not (folder / name).is_file()]
    if missing:
        return f"{folder}: {', '.join(missing)} missing (docs/live.md, \"TLS\", makes them)"
    return None


#: Seconds :meth:`ZenohTransport.close` waits for the subscriptions' callback threads to finish what they have queued
#: (all of them together).
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
    has stopped. The close is bounded: the callback threads get :data:`DRAIN` s together, and Zenoh's own close
    gives up after 10 s (``close operation timed out``), which :meth:`close` notes (:attr:`close_timed_out`) instead
    of raising.

    ``tls``: a folder of :data:`TLS_FILES`; the endpoints are then ``tls/HOST:PORT``, every link is TLS 1.3 with
    both sides' certificates checked against the swarm's CA (mutual TLS), and a peer's certificate must name the
    host it is reached at (``HOST``: an IP address or DNS name in its subjectAltName)."""

    def __init__(self, listen: Sequence[str] = (), connect: Sequence[str] = (), timeout: float = 5.0,
                 tls: Path | None = None):
        import zenoh

        conf = zenoh.Config()
        try:
            for path, value in _settings(listen, connect, timeout, tls):
                conf.insert_json5(path, value)
            self.session = zenoh.open(conf)
        except zenoh.ZError as exc:
            raise TransportError(_cause(str(exc), listen, connect)) from None
        self._zenoh = zenoh
        self._publishers: dict[str, Any] = {}  # zenoh publishers
        self._subscribers: list = []
        self._tallies: list[list] = []
        self._closed = False
        self.close_timed_out = False

    def put(self, key: str, data: bytes) -> None:
        pub = self._publishers.get(key)
        if pub is None:
            priority = getattr(self._zenoh.Priority, PRIORITY.get(key.rsplit("/", 1)[-1], "DATA"))
            pub = self._publishers[key] = self.session.declare_publisher(
                key, express=True, congestion_control=self._zenoh.CongestionControl.DROP, priority=priority)
        pub.put(data)

    def subscribe(self, key_expr: str, callback: Callable[[str, bytes], None]) -> object:
        tally = [0, 0.0]  # this subscription's (its one thread's: no race) messages and their CPU time
        self._tallies.append(tally)

        def handler(sample) -> None:
            cpu = time.thread_time()
            callback(str(sample.key_expr), sample.payload.to_bytes())
            tally[0] += 1
            tally[1] += time.thread_time() - cpu

        return self._declare(key_expr, handler)

    def received(self) -> tuple[int, float]:
        """The messages its subscriptions delivered so far, and the CPU time (s) their callbacks spent on them
        (taking the message from Zenoh, and all the callback did: a node's seal, decoding and mailbox)."""
        return sum(t[0] for t in self._tallies), sum(t[1] for t in self._tallies)

    def subscribe_typed(self, key_expr: str, callback: Callable[[str, bytes, str | None], None]) -> object:
        """:meth:`subscribe`, the callback also given the schema of each sample's encoding (``application/cdr;T``:
        ``T``; None when its encoding has none): a field source's message type (:mod:`swarmtrack.field.sources`)."""
        def handler(sample) -> None:
            _, _, schema = str(sample.encoding).partition(";")
            callback(str(sample.key_expr), sample.payload.to_bytes(), schema or None)

        return self._declare(key_expr, handler)

    def put_typed(self, key: str, data: bytes, msgtype: str) -> None:
        """Put ``data``, a ROS 2 message of type ``msgtype`` (``pkg/msg/Type``) serialised as CDR, with the encoding
        that says so (``application/cdr;pkg/msg/Type``), best effort (a field stand-in's camera and truth)."""
        pub = self._publishers.get(key)
        if pub is None:
            pub = self._publishers[key] = self.session.declare_publisher(
                key, encoding=self._zenoh.Encoding("application/cdr").with_schema(msgtype),
                congestion_control=self._zenoh.CongestionControl.DROP, express=True)
        pub.put(data)

    def _declare(self, key_expr: str, handler) -> object:
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
        deadline = time.monotonic() + DRAIN
        for _sub, threads in self._subscribers:  # undeclared: each ends once it has run what was queued
            for thread in threads:
                if thread is not threading.current_thread():
                    thread.join(max(0.0, deadline - time.monotonic()))
        try:
            self.session.close()  # and with it the publishers; Zenoh gives up after 10 s
        except self._zenoh.ZError:
            self.close_timed_out = True  # a peer that did not let the links close: the process ends all the same
        self._subscribers, self._publishers = [], {}


def _settings(listen, connect, timeout: float, tls: Path | None) -> list[tuple[str, str]]:
    """The Zenoh configuration of a live process: ``(path, JSON5 value)``."""
    queue = "transport/link/tx/queue"
    out = [("mode", '"peer"'), ("scouting/multicast/enabled", "false"),
           (f"{queue}/congestion_control/drop/wait_before_drop", str(WAIT_BEFORE_DROP_US)),
           (f"{queue}/congestion_control/block/wait_before_close", str(WAIT_BEFORE_CLOSE_US))]
    out += [(f"{queue}/size/{priority}", str(QUEUE_BATCHES)) for priority in ("interactive_high", "data")]
    if listen:
        out.append(("listen/endpoints", json.dumps(list(listen))))
    if connect:
        out += [("connect/endpoints", json.dumps(list(connect))), ("connect/timeout_ms", str(int(timeout * 1000))),
                ("connect/exit_on_failure", "true")]
    if tls is not None:
        ca, cert, private = (str(Path(tls, name).absolute()) for name in TLS_FILES)
        link = "transport/link/tls"
        out += [(f"{link}/root_ca_certificate", json.dumps(ca)), (f"{link}/enable_mtls", "true"),
                (f"{link}/listen_certificate", json.dumps(cert)), (f"{link}/listen_private_key", json.dumps(private)),
                (f"{link}/connect_certificate", json.dumps(cert)),
                (f"{link}/connect_private_key", json.dumps(private))]
    return out


def _short(text: str) -> str:
    """A Zenoh error's message without its Rust source locations and wrappers."""
    text = text.split(" at /")[0]
    if "msg: \"" in text:
        text = text.split("msg: \"", 1)[1].split("\"")[0]
    return text.rstrip(".:")


def _cause(text: str, listen, connect) -> str:
    if "Address already in use" in text:
        return f"cannot listen on {', '.join(listen)}: the address is in use"
    if "Unable to connect" in text:
        return f"cannot reach {', '.join(connect)} (nothing answers there)"
    return f"Zenoh could not start: {_short(text)}"
