"""What travels between the live swarm's processes: one typed, versioned message per channel, sealed per swarm.

**Messages** (``msgspec`` structs, MessagePack on the wire, :data:`VERSION` in every one). Every message carries its
``sender`` (a UAV index, or :data:`WORLD`), a sequence number ``seq`` (per sender and channel, increasing), the
wall-clock time ``sent`` (s since the Unix epoch: a receiver measures its latency) and the time ``taken`` (s,
simulated) its data describe, and the estimation step ``k`` and control step ``c`` (−1: the estimation step itself)
it belongs to:

==============  ==========  ===================================================================================
channel         from → to   content
==============  ==========  ===================================================================================
``hello``       UAV → world  the UAV is up (said until ``start``): its process, the hash of its resolved scenario
``start``       world → all  the sensor's label of every sensed object, by group (what a UAV's sensor reports)
``navigation``  world → UAV  its own navigation solution (1, d), and the simulated radio's word on whose messages
                            reach it now (:class:`Radio`); at an estimation step also its own detections, the
                            time of the control step starting with it, and an external tracker's target (guide)
``share``       UAV → UAVs   its estimator's broadcast (the outbox row: L24 eq. 6, W20's, IB21 eq. 30), and its
                            beacon of the control step that starts with the estimation step
``publish``     UAV → UAVs   its estimator's second broadcast of the step (W20's posteriors)
``beacon``      UAV → UAVs   its controller's beacon (flocking, W20 eq. 5.24, IB21 eq. 48) at a control step
                            between estimation steps
``plan``        UAV → UAVs   its plans of this control step (IB21 Sec. 5.3's sequential rounds)
``command``     UAV → world  its controller's command (1, w) at a control step between estimation steps
``sample``      UAV → world  its probes of the step (what the recorder keeps), its aim for the next frame, what the
                            truth-side monitors read of its components (their telemetry), and the command of the
                            control step that started with the estimation step
``alive``       UAV → world  a heartbeat, every 0.2 s (the world's to every UAV)
``roster``      world → all  the UAVs it hears now (the others are lost: nobody waits for them)
``stop``        world → all  the run is over
==============  ==========  ===================================================================================

Payloads (outbox rows, probes, detections) are dictionaries of values in a small self-describing form
(:func:`pack`): numeric arrays as dtype, shape and raw bytes (bit for bit), object arrays element by element,
shapely geometries as WKB (coordinates bit for bit), raster fields (IB21) as their window and data.

**Seal** (:class:`Seal`): ``HMAC-SHA256(key, key expression ‖ body)`` (standard library) prefixed to the body; the
body holds the sender, the run (:func:`new_run`), the sending process (``proc``) and the sequence number, so the tag
covers them with the channel (in the key expression). A message whose tag does not verify (outside the swarm,
tampered), whose sender is not one the swarm has, of another run (``other_run``), whose sequence number is not above
the last accepted one of its sending process and channel (a replay), or whose body does not decode is dropped and
counted by cause, never raised.
"""

from __future__ import annotations

import functools
import hmac
import os
import secrets
import threading
import time
from collections import Counter
from typing import Any

import msgspec
import numpy as np
import shapely

VERSION = 1
#: The sender id of the world process.
WORLD = -1
TAG_BYTES = 32
_NO_TAG = bytes(TAG_BYTES)


class Message(msgspec.Struct, tag_field="channel", kw_only=True):
    version: int = VERSION
    sender: int = WORLD
    run: bytes = b""
    """The run the message belongs to (:attr:`Seal.run`: drawn by the world at its start); empty in what a UAV's
    process says before it is started (``hello``, ``alive``)."""
    proc: int = 0
    """The sending process's random identity (:attr:`Seal.proc`): replays are judged per process."""
    seq: int = 0
    sent: float = 0.0
    taken: float = 0.0
    k: int = 0
    c: int = -1


class Hello(Message, tag="hello"):
    """Said until the world answers with ``start`` (a process that joins before the world listens is heard at the next
    one): its process id and start time (µs), the hash of its resolved scenario, and ``worlds``: the runs of the
    worlds it has heard (latest first): the world takes a hello only when its own run is among them, so a hello is
    fresh (an earlier run's, replayed, is not). ``autopilot``: it flies through an autopilot (``--autopilot``);
    ``rejoin``: it replaces the UAV's earlier process (``--rejoin``); ``error``: it cannot fly, and says why before
    it exits (its autopilot link does not open, or refused)."""

    pid: int
    started: int
    scenario: str
    worlds: list[bytes] = []
    autopilot: bool = False
    rejoin: bool = False
    error: str = ""


class Start(Message, tag="start"):
    """``labels`` the sensor's label of each sensed object, by group; ``k`` the step a UAV starts at (0, or the
    step a rejoining UAV joins at); ``realtime``: the world runs at wall-clock rate (the UAVs wait for their
    neighbours until deadlines, and log every message's latency); ``mavlink``: each UAV flies through its autopilot
    (its navigation comes from it, not in ``navigation``; its command goes to it as a setpoint)."""

    labels: dict[str, list[int]]
    to: int = 0
    """The process it starts (its hello's ``proc``): a process takes only the start bound to its own hello."""
    realtime: bool = False
    mavlink: bool = False


class Radio(msgspec.Struct):
    """The simulated radio's word on whose messages reach the UAV now (carried by :class:`Navigation`; absent on
    real radios): ``parts`` ``[(send step, senders)]`` of estimation messages (this step's first, then late ones),
    ``links`` the senders whose estimation message of this step it hears (the second broadcast travels over them),
    ``beacons`` the senders whose beacon of this control step it hears.

    ``to`` and ``beacon_to``: the other way round, the UAVs that hear this UAV's estimation message of this step
    (now, or later when the channel delays it) and its beacon of this control step; its messages are addressed to
    them alone (per-neighbour delivery, docs/live.md "Key space"): its share to both, its second broadcast to
    ``to``, its plans to the higher-indexed of ``beacon_to``, a beacon between estimation steps to ``beacon_to``.
    None: put on the UAV's own key for whoever listens (the field, where no world knows who hears whom, and the
    all-to-all delivery a world can be asked for, for comparison)."""

    parts: list[tuple[int, list[int]]] = []
    links: list[int] = []
    beacons: list[int] = []
    to: list[int] | None = None
    beacon_to: list[int] | None = None


class Navigation(Message, tag="navigation"):
    """The UAV's own navigation solution ``nav`` (1, d) at ``taken``, and the simulated radio's word (absent on real
    radios). At an estimation step (``c = −1``) also its ``detections``
    (:class:`~swarmtrack.sensors.detections.Detections` fields), the followed target from an external tracker where
    the scenario asks for one (``guide``: ``controller.follow: truth``, W20's motion capture: the UAV's row of the
    view its controller follows, ``state`` (1, 4) and where known ``model`` (1,) and ``motion`` (1, 3)), and
    ``control``: the time of the control step that starts with this estimation step (its beacons in
    ``radio.beacons``; None: none starts now)."""

    nav: Any
    radio: Radio | None = None
    detections: dict[str, Any] | None = None
    guide: dict[str, Any] | None = None
    control: float | None = None
    due: float | None = None
    """In real time, the wall-clock time (s since the Unix epoch) the step is at, from which the UAV's deadlines
    run; None in lockstep."""


class Share(Message, tag="share"):
    """The estimator's broadcast of step ``k``, and the controller's beacon of the control step that starts with it
    (None: none starts now): one message where the simulator has two."""

    payloads: dict[str, Any]
    beacon: dict[str, Any] | None = None


class Publish(Message, tag="publish"):
    payloads: dict[str, Any]


class Beacon(Message, tag="beacon"):
    payloads: dict[str, Any]


class Plan(Message, tag="plan"):
    payloads: dict[str, Any]


class Command(Message, tag="command"):
    """The controller's command (1, w) of a control step between estimation steps (the one that starts with an
    estimation step travels in its :class:`Sample`)."""

    u: Any


class Sample(Message, tag="sample"):
    """The step's probes (taken before its control step, as the simulator records them), where the sensor should aim
    at the next frame, the telemetry of the truth-side checks, and ``u``: the command of the control step that started
    with the estimation step (None: none did)."""

    probes: dict[str, Any]
    aim: Any = None
    u: Any = None
    telemetry: dict[str, dict[str, Any]] = {}
    rejected: dict[str, int] = {}  # what this UAV's process dropped so far, by cause
    cpu: float = 0.0
    """The CPU time (s) the UAV's process spent since its previous sample."""
    received: int = 0
    """The messages its subscriptions delivered since its previous sample (its neighbours', the world's, its own
    heard back), and ``receive_cpu`` the CPU time (s) its callbacks spent on them: its receive work."""
    receive_cpu: float = 0.0
    heard: list[tuple[str, int, int, int, float, float]] = []
    """Real time: the messages the UAV received since its previous sample, ``(channel, sender, k, c, sent,
    latency)`` (wall-clock s)."""
    late: dict[str, int] = {}
    """Real time: its neighbours' messages that came after its deadline, or after the scenario's delay bound (never
    fused), so far, by channel."""
    autopilot: list[dict[str, Any]] = []
    """With an autopilot: its handovers to the operator and engagements so far
    (:attr:`swarmtrack.autopilot.authority.Authority.events`)."""
    nav: Any = None
    """In the field (:mod:`swarmtrack.field`): its navigation solution (1, d) of the step, which the monitor records
    where the world's truth would be."""
    skipped: dict[str, int] = {}
    """In the field: the messages of its sources it skipped so far, by cause and topic
    (:func:`swarmtrack.replay.grid.skip`)."""


class Alive(Message, tag="alive"):
    """A process's heartbeat (every :data:`~swarmtrack.live.node.HEARTBEAT` s, from a thread of its own): its process
    id and start time (µs); from the world also ``heard``: the processes whose hellos it heard in the last
    :data:`~swarmtrack.live.node.LOST_AFTER` s (a waiting UAV knows the world has heard it)."""

    pid: int = 0
    started: int = 0
    heard: list[int] = []


class Roster(Message, tag="roster"):
    """The UAVs the world hears now (0-based): the others are lost, nobody waits for their messages."""

    alive: list[int]


class Stop(Message, tag="stop"):
    """The run is over (``reason`` ``done``), or the world refuses (``refused``) or stops: ``to`` 0 for every process
    of the run, else the one process it is bound to (its hello's ``proc``: a process not started yet takes only a
    stop bound to its own hello)."""

    reason: str = "done"
    to: int = 0
    refused: bool = False


ANY = Hello | Start | Navigation | Share | Publish | Beacon | Plan | Command | Sample | Alive | Roster | Stop
_encoder = msgspec.msgpack.Encoder()
_decoder = msgspec.msgpack.Decoder(ANY)


def pack(value) -> Any:
    """``value`` in the wire's self-describing form (MessagePack-able): arrays, object arrays, geometries, raster
    fields, dicts, lists, scalars and None."""
    if type(value) is np.ndarray and value.ndim and value.dtype.kind != "O":  # the common case, first (3x faster)
        return {"a": value.dtype.str, "shape": list(value.shape), "data": value.tobytes()}  # tobytes: C order
    from swarmtrack.estimation.raster_field import Field

    if value is None or isinstance(value, (bool, int, float, str, bytes)):
        return value
    if isinstance(value, dict):
        return {"d": {str(k): pack(v) for k, v in value.items()}}
    if isinstance(value, (list, tuple)):
        return {"l": [pack(v) for v in value]}
    if isinstance(value, np.generic):
        value = np.asarray(value)
    if isinstance(value, np.ndarray):
        if value.dtype == object:
            return {"o": list(value.shape), "items": [pack(v) for v in value.ravel()]}
        a = np.ascontiguousarray(value)
        return {"a": a.dtype.str, "shape": list(a.shape), "data": a.tobytes()}
    if isinstance(value, shapely.Geometry):
        return {"g": shapely.to_wkb(value, include_srid=False, flavor="iso")}
    if isinstance(value, Field):
        return {"f": [value.i0, value.j0, list(value.core)], "data": pack(value.data)}
    raise TypeError(f"cannot send a {type(value).__name__}")


def unpack(value) -> Any:
    """The inverse of :func:`pack`."""
    if not isinstance(value, dict):
        return value
    if "a" in value:
        return np.frombuffer(value["data"], dtype=_dtype(value["a"])).reshape(value["shape"]).copy()
    if "o" in value:
        out = np.empty(len(value["items"]), dtype=object)
        out[:] = [unpack(v) for v in value["items"]]
        return out.reshape(value["o"])
    if "d" in value:
        return {k: unpack(v) for k, v in value["d"].items()}
    if "l" in value:
        return [unpack(v) for v in value["l"]]
    if "g" in value:
        return shapely.from_wkb(value["g"])
    if "f" in value:
        from swarmtrack.estimation.raster_field import Field

        i0, j0, core = value["f"]
        return Field(i0, j0, unpack(value["data"]), tuple(core))
    raise ValueError("an unknown value form")


@functools.cache
def _dtype(code: str) -> np.dtype:
    return np.dtype(code)


def keygen() -> bytes:
    """A new swarm key: 32 random bytes (hex in the key file)."""
    return secrets.token_bytes(32)


class Rejected(Exception):
    """A message dropped by :meth:`Seal.open`; ``cause`` is one of :data:`CAUSES`."""

    def __init__(self, cause: str):
        super().__init__(cause)
        self.cause = cause


CAUSES = ("forged", "replayed", "unknown_sender", "impersonated", "undecodable", "wrong_version", "other_run",
          "other_process")
#: What a UAV's process says before it knows the run (its ``run`` empty).
UNBOUND = ("hello", "alive")


class Seal:
    """Seals outgoing messages and opens incoming ones for one swarm: ``key`` (bytes; None: no tag, for
    ``--insecure``), ``n_uavs`` the senders it accepts (0..n−1 and the world). Thread-safe; counts what it drops
    (:attr:`rejected`, by cause).

    ``proc``: this process's identity, 63 random bits drawn at its start (every message carries it; replays are
    judged per sending process, so a second process of a sender does not make the first one's messages look
    replayed). ``run``: the run this process belongs to (the world draws it, :func:`new_run`; a UAV's process takes
    it from the ``start`` bound to its hello; None until then): every message carries it, and once it is set a
    message of another run is dropped (``other_run``), but for what a UAV says before it is started (``hello`` and
    ``alive`` with an empty run, :data:`UNBOUND`; a hello answering other worlds than this run's is another run's)."""

    def __init__(self, key: bytes | None, n_uavs: int, run: bytes | None = None):
        self.key, self.n, self.run = key, n_uavs, run
        self.proc = secrets.randbits(63) or 1
        self.pid = os.getpid()
        # sequence numbers start at the process's start time in µs: a process restarted (--rejoin) continues above
        # what its earlier life sent
        self.started = time.time_ns() // 1000
        self._seq: dict[str, int] = {}
        self._last: dict[tuple[int, str, int], int] = {}
        self.rejected: Counter = Counter()
        self._lock = threading.Lock()

    def seal(self, key_expr: str, msg: Message) -> bytes:
        return self.seal_each((key_expr,), msg)[0]

    def seal_each(self, key_exprs, msg: Message) -> list[bytes]:
        """``msg`` sealed for each of ``key_exprs`` (one body, one sequence number, encoded once; a tag per key: a
        message addressed to one receiver does not verify on another's key)."""
        channel = type(msg).__struct_config__.tag  # one sequence per channel: what a receiver checks
        with self._lock:
            msg.seq = self._seq[channel] = self._seq.get(channel, self.started) + 1
        msg.proc = self.proc
        if self.run is not None:
            msg.run = self.run
        msg.sent = time.time()
        body = _encoder.encode(msg)
        return [self._tag(key_expr, body) + body for key_expr in key_exprs]

    def _tag(self, key_expr: str, body: bytes) -> bytes:
        if self.key is None:
            return _NO_TAG
        # hmac.digest: OpenSSL's one-shot HMAC, 2.5x faster than hmac.new(...).digest() on a share
        return hmac.digest(self.key, b"%s\0%s" % (key_expr.encode(), body), "sha256")

    def count(self, cause: str, n: int = 1) -> None:
        """Count ``n`` messages dropped for ``cause`` (by the caller, after :meth:`open` accepted them)."""
        with self._lock:
            self.rejected[cause] += n

    def open(self, key_expr: str, data: bytes, fresh: bool = True) -> Message:
        """The message in ``data`` received on ``key_expr``, or :class:`Rejected` (counted). ``fresh=False``: not
        checked for a replay yet (:meth:`fresh`: a process before its start knows which messages are its run's only
        then)."""
        try:
            msg = self._open(key_expr, data)
            if fresh:
                self._fresh(msg)
            return msg
        except Rejected as exc:
            self.count(exc.cause)
            raise

    def fresh(self, msg: Message) -> bool:
        """Whether ``msg`` is not a replay (counted if it is)."""
        try:
            self._fresh(msg)
        except Rejected as exc:
            self.count(exc.cause)
            return False
        return True

    def _fresh(self, msg: Message) -> None:
        channel = type(msg).__struct_config__.tag
        with self._lock:
            last = self._last.get((msg.sender, channel, msg.proc), 0)
            if msg.seq <= last:
                raise Rejected("replayed")
            self._last[(msg.sender, channel, msg.proc)] = msg.seq

    def _open(self, key_expr: str, data: bytes) -> Message:
        tag, body = data[:TAG_BYTES], data[TAG_BYTES:]
        if len(tag) < TAG_BYTES or not hmac.compare_digest(tag, self._tag(key_expr, body)):
            raise Rejected("forged")
        try:
            msg = _decoder.decode(body)
        except (msgspec.DecodeError, msgspec.ValidationError):
            raise Rejected("undecodable") from None
        if msg.version != VERSION:
            raise Rejected("wrong_version")
        if msg.sender != WORLD and not 0 <= msg.sender < self.n:
            raise Rejected("unknown_sender")
        channel = type(msg).__struct_config__.tag
        if self.run is not None and msg.run != self.run:
            if msg.run or channel not in UNBOUND or (channel == "hello" and msg.worlds and self.run not in msg.worlds):
                raise Rejected("other_run")
        return msg


def new_run() -> bytes:
    """A run's identity: 16 random bytes (a nonce, not a simulation draw), drawn by the world at its start."""
    return os.urandom(16)


def peek(data: bytes) -> Message | None:
    """The message in ``data`` as it claims to be, its seal not checked (None: it does not decode): what a message
    that fails the seal says of its sender, as evidence of who sent it (a process with another key)."""
    try:
        return _decoder.decode(data[TAG_BYTES:])
    except (msgspec.DecodeError, msgspec.ValidationError):
        return None


def channel_of(msg: Message) -> str:
    return type(msg).__struct_config__.tag
