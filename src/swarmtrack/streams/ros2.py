"""A run on ROS 2 topics, and ROS 2 topics as a UAV's inputs, over DDS with cyclonedds: no ROS installation, the
ROS 2 type and topic names on the wire (:mod:`swarmtrack.streams.ros2_types`), so ROS 2 nodes, ``ros2 topic``,
RViz and Foxglove see them as any node's.

:class:`Ros2Out` (a :class:`~swarmtrack.streams.frame.Tap`) publishes each step, per UAV ``n`` (1-based) in the
namespace ``uav_{n}`` (the ``namespace`` argument, formatted with ``n``: ``px4_{n}`` puts them beside PX4's)::

    /uav_n/estimate   geometry_msgs/PoseWithCovarianceStamped  UAV n's estimate of the followed target
    /uav_n/pose       geometry_msgs/PoseStamped                 UAV n's position (truth in the simulator)
    /uav_n/setpoint   geometry_msgs/AccelStamped                UAV n's command, when the driver knows it
    /uav_n/sets       visualization_msgs/MarkerArray            UAV n's regions (IB21's sets); the swarm's on
                                                                /swarm/sets
    /target/truth     geometry_msgs/PoseStamped                 the followed target's truth, when known
    /formation        visualization_msgs/MarkerArray            where each UAV is meant to be (W20), when given

Frames: every message is in ``frame_id`` (``map``: ENU, x east, y north, z up, m; REP 103), as swarmtrack's own
coordinates. Orientations are the identity: swarmtrack estimates positions, no attitude. A planar world's
altitudes are 0; in a 3-D world ``pose`` has the UAV's altitude and ``estimate`` the target's when the estimator's
model has one (``z`` of the 3-D models' ``[x, y, vx, vy, z, vz, ...]``). ``/target/truth`` is at z 0 (a step
carries the target's planar truth). Markers lie at z 0.

``estimate``'s covariance (row-major 6 × 6 over x, y, z and the rotations about x, y, z): the position block is
the estimate's (x, y; and z with its cross terms when estimated); a planar estimate's z variance is 0 (the target
is in the plane); the rotations are not estimated, their variances :data:`UNESTIMATED_VARIANCE` (so large that a
fusion ignores them) and their cross terms 0. ``setpoint``: a planar acceleration command (m/s², the map's axes)
in ``accel.linear.x, y``; a fixed wing's yaw acceleration (rad/s²) in ``accel.angular.z``.

``sets``: a ``DELETEALL`` marker (the last step's shapes go), then one closed ``LINE_STRIP`` per region. Header
stamps: the run's time ``t`` plus ``stamp_epoch`` (s since the Unix epoch; 0: stamps are the run's time, as in
a recording; ``time.time()`` at the start: wall-clock stamps a live system lines up with its own). Absent UAVs
(``present`` False) and unknown (NaN) values are not published.

QoS: reliable, keep last :data:`DEPTH` (10), volatile: rclpy's default (``create_subscription(T, topic, cb,
10)``) and ``ros2 topic echo`` match it, best-effort subscribers (sensor-data QoS) too; a slow subscriber loses
old messages and never blocks :meth:`Ros2Out.send`. Writers are made when their topic is first published. To
see them (a ROS 2 shell, same ``ROS_DOMAIN_ID``)::

    ros2 topic list
    ros2 topic echo /uav_1/estimate
    rviz2   # Fixed Frame: map; add PoseWithCovariance on /uav_1/estimate, MarkerArray on /uav_1/sets

:class:`Ros2Source` subscribes to one topic (a detector's, a navigation system's) and hands each message to a
callback as rosbags' message, which replay's field paths read (:mod:`swarmtrack.replay.rosbag`).

Discovery follows ROS 2's environment as its ``rmw`` does: ``ROS_DOMAIN_ID`` (the default domain),
``ROS_AUTOMATIC_DISCOVERY_RANGE`` (``LOCALHOST``: this machine only, over the loopback interface; ``SUBNET``,
the default: multicast on the network; ``OFF``; ``SYSTEM_DEFAULT``: cyclonedds' own configuration),
``ROS_STATIC_PEERS`` (``;``-separated hosts) and ``CYCLONEDDS_URI`` (cyclonedds' configuration, applied after).
The first participant of a domain in a process fixes that domain's configuration.
"""

from __future__ import annotations

import functools
import math
import os
import threading
import time
from collections.abc import Callable
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np

from swarmtrack.streams import ros2_types
from swarmtrack.streams.frame import StepFrame

#: Messages each writer and reader keeps (QoS history keep-last depth): rclpy's default subscription depth.
DEPTH = 10
#: The variance (rad²) of a rotation swarmtrack does not estimate: so large that any fusion ignores it.
UNESTIMATED_VARIANCE = 1e6
#: A region's outline is this fraction of the region's larger extent wide, a formation's spheres this fraction of
#: the formation's (at least :data:`MIN_WIDTH` m): seen at any scale of scene, a W20 formation's or an IB21 field's.
LINE_FRACTION = 0.01
SPHERE_FRACTION = 0.05
MIN_WIDTH = 0.05
#: Colours (r, g, b) of UAV n's markers (n - 1 modulo their number); the swarm's are white.
PALETTE = ((0.12, 0.47, 0.71), (1.0, 0.5, 0.05), (0.17, 0.63, 0.17), (0.84, 0.15, 0.16), (0.58, 0.4, 0.74),
           (0.55, 0.34, 0.29), (0.89, 0.47, 0.76), (0.5, 0.5, 0.5), (0.74, 0.74, 0.13), (0.09, 0.75, 0.81))
#: DDS vendors whose type information cyclonedds ignores, matching by type name as ROS 2 does: Fast DDS (1.15)
#: answers cyclonedds' look-up of its minimal type with its complete one only, and no Fast DDS reader would match.
IGNORE_TYPE_INFORMATION = "1.15"
#: Participants one machine's discovery reaches under ``LOCALHOST`` (as ``rmw_cyclonedds`` and ``rmw_fastrtps``).
MAX_PARTICIPANTS = 32

RANGES = ("OFF", "LOCALHOST", "SUBNET", "SYSTEM_DEFAULT")


class TopicNotPublished(TimeoutError):
    """Nobody published the topic within the time asked."""


class TypeMismatch(ValueError):
    """A topic's publishers use another type (or another definition of it) than the one asked for (a ValueError:
    the type asked for, or the topic, is wrong, as for an unknown type)."""


# --- discovery and participants -----------------------------------------------------------------------------------

def domain_id_of(domain_id: int | None) -> int:
    """The DDS domain: ``domain_id``, else ``ROS_DOMAIN_ID``, else 0 (ROS 2's default)."""
    if domain_id is not None:
        return int(domain_id)
    text = os.environ.get("ROS_DOMAIN_ID", "").strip()
    try:
        return int(text) if text else 0
    except ValueError:
        raise ValueError(f"ROS_DOMAIN_ID={text!r}: not a domain number") from None


def discovery_config(environ: Any = os.environ) -> str:
    """The cyclonedds configuration ROS 2's discovery variables ask for (the module docstring), as
    ``rmw_cyclonedds`` builds it, then ``CYCLONEDDS_URI``'s. ``LOCALHOST`` also enables the loopback interface:
    cyclonedds 11 drops discovery arriving on an interface it does not use."""
    reach = environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip().upper() or "SUBNET"
    if reach not in RANGES:
        raise ValueError(f"ROS_AUTOMATIC_DISCOVERY_RANGE={reach!r}: expected one of {', '.join(RANGES)}")
    peers = [p.strip() for p in environ.get("ROS_STATIC_PEERS", "").split(";") if p.strip()]
    general, discovery = "", ""
    if reach == "OFF":
        general = "<AllowMulticast>false</AllowMulticast>"
        discovery = f"<ParticipantIndex>none</ParticipantIndex><Tag>ros_discovery_off_{os.getpid()}</Tag>"
    elif reach == "LOCALHOST":
        loopback = '<NetworkInterface address="127.0.0.1"/>'
        others = '<NetworkInterface autodetermine="true"/>' if peers else ""  # to reach the static peers
        general = f"<AllowMulticast>false</AllowMulticast><Interfaces>{loopback}{others}</Interfaces>"
        peers = ["localhost", *peers]
        discovery = f"<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>{MAX_PARTICIPANTS}" \
                    "</MaxAutoParticipantIndex>"
    if peers and reach in ("LOCALHOST", "SUBNET"):
        discovery += "<Peers>" + "".join(f"<Peer address={quoteattr(p)}/>" for p in peers) + "</Peers>"
    config = (f"<CycloneDDS><Domain><General>{general}</General><Discovery>{discovery}</Discovery><Compatibility>"
              f"<IgnoreTypeInformation>{IGNORE_TYPE_INFORMATION}</IgnoreTypeInformation></Compatibility></Domain>"
              "</CycloneDDS>")
    return f"{config},{environ.get('CYCLONEDDS_URI', '')}"


_LOCK = threading.Lock()
#: Each domain this process takes part in: its cyclonedds Domain and the participants in it.
_DOMAINS: dict[int, tuple[Any, set]] = {}


def end(*entities: Any) -> None:
    """Delete DDS entities now, in the order given (children before their parent). cyclonedds deletes one when
    its Python object is finalised; this runs that now rather than when the garbage collector comes by, so the
    network learns at once that the entity is gone."""
    for entity in entities:
        if entity is not None:
            entity.__del__()


def join(domain_id: int | None) -> Any:
    """A new DDS participant in the domain (:func:`domain_id_of`); the domain is made with
    :func:`discovery_config` when this process has none in it yet."""
    from cyclonedds.domain import Domain, DomainParticipant

    number = domain_id_of(domain_id)
    with _LOCK:
        if number not in _DOMAINS:
            _DOMAINS[number] = (Domain(number, discovery_config()), set())
        domain, members = _DOMAINS[number]
        participant = DomainParticipant(number)
        members.add(participant)
    return participant


def leave(participant: Any) -> None:
    """Delete a participant of :func:`join` with its entities, and its domain after its last participant."""
    with _LOCK:
        for number, (domain, members) in list(_DOMAINS.items()):
            if participant in members:
                members.discard(participant)
                end(participant)
                if not members:
                    end(domain)
                    del _DOMAINS[number]
                return


def _qos(reliable: bool, msgtype: str) -> Any:
    """Keep last :data:`DEPTH`, volatile, reliable or best effort; the user data ROS 2 (Iron on) gives its
    endpoints: the type's hash."""
    from cyclonedds.qos import Policy, Qos

    reliability = Policy.Reliability.Reliable(max_blocking_time=0) if reliable else Policy.Reliability.BestEffort
    return Qos(reliability, Policy.History.KeepLast(DEPTH), Policy.Durability.Volatile,
               Policy.Userdata(f"typehash={ros2_types.type_hash(msgtype)};".encode()))


# --- out: a run's steps on ROS 2 topics ---------------------------------------------------------------------------

@functools.cache
def _classes() -> dict[str, Any]:
    """rosbags' message classes by short name (the messages :class:`Ros2Out` builds)."""
    types = ros2_types.typestore().types
    names = ("builtin_interfaces/msg/Time", "std_msgs/msg/Header", "std_msgs/msg/ColorRGBA", "geometry_msgs/msg/Point",
             "geometry_msgs/msg/Quaternion", "geometry_msgs/msg/Pose", "geometry_msgs/msg/PoseStamped",
             "geometry_msgs/msg/PoseWithCovariance", "geometry_msgs/msg/PoseWithCovarianceStamped",
             "geometry_msgs/msg/Vector3", "geometry_msgs/msg/Accel", "geometry_msgs/msg/AccelStamped",
             "visualization_msgs/msg/Marker", "visualization_msgs/msg/MarkerArray")
    return {name.rpartition("/")[2]: types[name] for name in names}


POSE = "geometry_msgs/msg/PoseStamped"
ESTIMATE = "geometry_msgs/msg/PoseWithCovarianceStamped"
SETPOINT = "geometry_msgs/msg/AccelStamped"
MARKERS = "visualization_msgs/msg/MarkerArray"


def altitude_column(meta: dict) -> int | None:
    """Where the estimate keeps the target's altitude: ``z`` of the estimator's models when every one of them
    has it (the 3-D models, ``[x, y, vx, vy, z, vz, ...]``); None for a planar estimate or unknown models."""
    from swarmtrack.models import MODEL_NAMES, make_model

    settings = meta.get("estimator") or {}
    names = settings.get("models") or [meta.get("model") or settings.get("model")]
    if not names or not all(isinstance(n, str) and n.lower() in MODEL_NAMES for n in names):
        return None
    states = [make_model(n, 1.0).state_names for n in names]
    columns = {s.index("z") if "z" in s else None for s in states}
    return columns.pop() if len(columns) == 1 else None


def _finite(*values: Any) -> bool:
    return all(bool(np.all(np.isfinite(v))) for v in values)


class Ros2Out:
    """A :class:`~swarmtrack.streams.frame.Tap` publishing each step on ROS 2 topics (the module docstring):
    UAV ``n``'s in the namespace ``namespace.format(n=n)``, in the DDS domain ``domain_id``
    (:func:`domain_id_of`), in the frame ``frame_id``, stamped ``stamp_epoch + t``."""

    def __init__(self, namespace: str = "uav_{n}", domain_id: int | None = None, frame_id: str = "map",
                 stamp_epoch: float = 0.0):
        try:
            first, second = namespace.format(n=1), namespace.format(n=2)
        except (KeyError, IndexError, ValueError, AttributeError):
            raise ValueError(f"namespace {namespace!r}: a ROS 2 namespace formatted with the UAV's number n only, "
                             "e.g. 'uav_{n}'") from None
        try:
            ros2_types.ros_topic(first)
        except ValueError as exc:
            raise ValueError(f"namespace {namespace!r}: {exc}") from None
        if not frame_id:
            raise ValueError("frame_id: empty (the frame of the positions, e.g. 'map')")
        self.namespace, self.domain_id, self.frame_id = namespace, domain_id, frame_id
        self._numbered = first != second
        seconds = math.floor(stamp_epoch)
        self._epoch_ns = seconds * 10**9 + round((stamp_epoch - seconds) * 1e9)
        self._participant: Any = None
        self._writers: dict[str, tuple[str, Any, Any]] = {}  # topic → (type, DDS topic, writer)
        self._namespaces: dict[int, str] = {}
        self._drawn: set[str] = set()  # the sets topics with regions on them
        self._altitude: int | None = None

    # the tap's life -----------------------------------------------------------------------------------------------

    def open(self, meta: dict) -> None:
        """Join the DDS domain; ``meta`` (the recording's) tells where the estimate's altitude is."""
        if self._participant is None:
            self._altitude = altitude_column(meta)
            self._participant = join(self.domain_id)

    def close(self) -> None:
        """Delete the writers and the participant (idempotent)."""
        participant, writers = self._participant, list(self._writers.values())
        self._participant, self._writers = None, {}
        end(*(writer for _, _, writer in writers), *(topic for _, topic, _ in writers))
        if participant is not None:
            leave(participant)

    def send(self, frame: StepFrame) -> None:
        """Publish one step (the module docstring's topics)."""
        if self._participant is None:
            raise RuntimeError("Ros2Out.send before open")
        if not self._numbered and len(frame.uavs) > 1:
            raise ValueError(f"namespace {self.namespace!r} has no {{n}}: the topics of {len(frame.uavs)} UAVs "
                             "would be one namespace's; e.g. 'uav_{n}'")
        c = _classes()
        stamp = self._epoch_ns + round(frame.t * 1e9)
        header = c["Header"](stamp=c["Time"](sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id=self.frame_id)
        present = frame.present.astype(bool)
        # each UAV's position, estimate and command as Python numbers, and which are known (finite)
        z = np.zeros(len(frame.uavs)) if frame.uav_altitude is None else np.asarray(frame.uav_altitude, dtype=float)
        uav = np.column_stack([frame.uav[:, :2], z])
        uav_known = present & np.isfinite(uav).all(axis=1)
        estimates = self._estimates(frame, present)
        commands = None if frame.command is None else np.asarray(frame.command, dtype=float)
        command_known = None if commands is None else present & np.isfinite(commands).all(axis=1)
        for i, (n, (x, y, height)) in enumerate(zip(frame.uavs.tolist(), uav.tolist(), strict=True)):
            if not present[i]:
                continue
            ns = self._namespace(n)
            if uav_known[i]:
                self._write(f"{ns}/pose", POSE, c["PoseStamped"](header=header, pose=_pose(x, y, height)))
            if estimates is not None and estimates[0][i]:
                position, covariance = estimates[1][i], estimates[2][i]
                self._write(f"{ns}/estimate", ESTIMATE, c["PoseWithCovarianceStamped"](
                    header=header, pose=c["PoseWithCovariance"](pose=_pose(*position), covariance=covariance)))
            if commands is not None and command_known is not None and command_known[i]:
                self._write(f"{ns}/setpoint", SETPOINT, c["AccelStamped"](header=header, accel=_accel(commands[i])))
        if frame.target is not None and _finite(frame.target[:2]):
            x, y = frame.target[:2].tolist()
            self._write("/target/truth", POSE, c["PoseStamped"](header=header, pose=_pose(x, y, 0.0)))
        self._sets(header, frame.polygons, dict(zip(frame.uavs.tolist(), present.tolist(), strict=True)))
        if frame.formation is not None:
            points = [p for p in np.asarray(frame.formation, dtype=float) if _finite(p)]
            self._write("/formation", MARKERS, c["MarkerArray"](markers=[_marker(
                header, "formation", 0, "SPHERE_LIST", points, (1.0, 1.0, 1.0), closed=False)]))

    # the messages -------------------------------------------------------------------------------------------------

    def _namespace(self, n: int) -> str:
        if n not in self._namespaces:
            self._namespaces[n] = ros2_types.ros_topic(self.namespace.format(n=n))
        return self._namespaces[n]

    def _estimates(self, frame: StepFrame, present: np.ndarray) -> tuple | None:
        """Which UAVs' estimates are known, their positions (x, y, z) and their 6 × 6 pose covariances, row-major
        (the module docstring's); None without estimates."""
        if frame.estimate is None or frame.covariance is None:
            return None
        n = len(frame.uavs)
        rows = [0, 1] if self._altitude is None else [0, 1, self._altitude]
        position = np.zeros((n, 3))
        position[:, :len(rows)] = frame.estimate[:, rows]
        full = np.zeros((n, 6, 6))
        full[:, :len(rows), :len(rows)] = frame.covariance[:, rows][:, :, rows]
        full[:, 3, 3] = full[:, 4, 4] = full[:, 5, 5] = UNESTIMATED_VARIANCE
        known = present & np.isfinite(position).all(axis=1) & np.isfinite(full).all(axis=(1, 2))
        return known, position.tolist(), full.reshape(n, 36)

    def _sets(self, header: Any, polygons: list, present: dict[int, bool]) -> None:
        """Each namespace's regions as a MarkerArray; a namespace whose regions are gone gets its DELETEALL."""
        regions: dict[str, list] = {}
        for uav, vertices in polygons:
            if present.get(int(uav), True):
                topic = "/swarm/sets" if int(uav) == 0 else f"{self._namespace(int(uav))}/sets"
                regions.setdefault(topic, []).append((int(uav), np.asarray(vertices, dtype=float)))
        for topic in self._drawn - set(regions):
            self._write(topic, MARKERS, _classes()["MarkerArray"](markers=[_clear(header)]))
        for topic, shapes in regions.items():
            markers = [_clear(header)]
            for uav, vertices in shapes:
                known = vertices[np.isfinite(vertices).all(axis=1)]
                if len(known) >= 2:  # a line needs two points
                    markers.append(_marker(header, "sets", len(markers) - 1, "LINE_STRIP", list(known), _colour(uav)))
            self._write(topic, MARKERS, _classes()["MarkerArray"](markers=markers))
        self._drawn = set(regions)

    def _write(self, topic: str, msgtype: str, message: Any) -> None:
        """Publish on ``topic``, its writer made at its first message."""
        entry = self._writers.get(topic)
        if entry is None:
            from cyclonedds.pub import DataWriter
            from cyclonedds.topic import Topic

            dds_topic: Any = Topic(self._participant, ros2_types.dds_topic(topic), ros2_types.writer_type(msgtype))
            entry = self._writers[topic] = (msgtype, dds_topic, DataWriter(self._participant, dds_topic,
                                                                          _qos(True, msgtype)))
        entry[2].write(ros2_types.cdr(message, msgtype))


def _pose(x: float, y: float, z: float) -> Any:
    c = _classes()
    return c["Pose"](position=c["Point"](x=float(x), y=float(y), z=float(z)),
                     orientation=c["Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))


def _accel(command: np.ndarray) -> Any:
    """A command as an Accel: a planar acceleration (2) in ``linear``, a fixed wing's yaw acceleration (1) in
    ``angular.z``."""
    c = _classes()
    linear, angular = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    if len(command) == 2:
        linear = (float(command[0]), float(command[1]), 0.0)
    elif len(command) == 1:
        angular = (0.0, 0.0, float(command[0]))
    else:
        raise ValueError(f"a command of {len(command)} numbers: a setpoint is a planar acceleration (2) or a yaw "
                         "acceleration (1)")
    return c["Accel"](linear=c["Vector3"](x=linear[0], y=linear[1], z=linear[2]),
                      angular=c["Vector3"](x=angular[0], y=angular[1], z=angular[2]))


def _colour(uav: int) -> tuple[float, float, float]:
    return (1.0, 1.0, 1.0) if uav == 0 else PALETTE[(uav - 1) % len(PALETTE)]


def _clear(header: Any) -> Any:
    """The marker that deletes the namespace's earlier markers."""
    marker = _classes()["Marker"]
    return ros2_types.zero_message("visualization_msgs/msg/Marker", header=header, action=marker.DELETEALL)


def _marker(header: Any, ns: str, number: int, kind: str, points: list, colour: tuple, closed: bool = True) -> Any:
    """A LINE_STRIP (closed: back to its first point) or SPHERE_LIST marker through ``points`` (x, y at z 0),
    as wide as :data:`LINE_FRACTION` (:data:`SPHERE_FRACTION`) of their larger extent."""
    c = _classes()
    xy = np.asarray(points, dtype=float).reshape(-1, 2)
    extent = float(np.max(np.ptp(xy, axis=0))) if len(xy) else 0.0
    width = max(MIN_WIDTH, (LINE_FRACTION if kind == "LINE_STRIP" else SPHERE_FRACTION) * extent)
    path = [c["Point"](x=float(x), y=float(y), z=0.0) for x, y in xy]
    if closed and path:
        path.append(path[0])
    return ros2_types.zero_message(
        "visualization_msgs/msg/Marker", header=header, ns=ns, id=number, type=getattr(c["Marker"], kind),
        action=c["Marker"].ADD, pose=_pose(0.0, 0.0, 0.0), scale=c["Vector3"](x=width, y=width, z=width),
        color=c["ColorRGBA"](r=colour[0], g=colour[1], b=colour[2], a=1.0), points=path)


# --- in: a ROS 2 topic's messages ---------------------------------------------------------------------------------

def publications(participant: Any, topic: str, timeout: float) -> list:
    """The publications of ``topic`` (a ROS 2 name) the participant discovers, waiting up to ``timeout`` s for the
    first (DDS discovery: the builtin ``DCPSPublication`` topic); empty when none came."""
    from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication
    from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet
    from cyclonedds.internal import InvalidSample
    from cyclonedds.util import duration

    wanted = ros2_types.dds_topic(topic)
    reader = BuiltinDataReader(participant, BuiltinTopicDcpsPublication)
    arrived = ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any)
    waitset = WaitSet(participant)
    waitset.attach(arrived)
    alive: dict = {}
    deadline = time.monotonic() + timeout
    try:
        while True:
            while samples := reader.take(N=256):
                for s in samples:  # an instance per publication: its handle is the publication's
                    if isinstance(s, InvalidSample) or s.sample_info.instance_state != InstanceState.Alive:
                        alive.pop(s.sample_info.instance_handle, None)
                    elif s.topic_name == wanted:
                        alive[s.sample_info.instance_handle] = s
            left = deadline - time.monotonic()
            if alive or left <= 0:
                return list(alive.values())
            waitset.wait(duration(seconds=left))
    finally:
        waitset.detach(arrived)
        end(waitset, arrived, reader)


def published_type(topic: str, found: list, msgtype: str | None) -> tuple[str, bool]:
    """The type ``pkg/msg/Name`` the publications ``found`` of ``topic`` carry, and whether all are reliable;
    :class:`TypeMismatch` when they disagree, differ from ``msgtype`` (when given), or their definition (its
    ROS 2 hash, when they publish one) is not ours."""
    from cyclonedds.qos import Policy

    names = sorted({s.type_name for s in found})
    types = sorted({ros2_types.ros_type_of(n) or n for n in names})
    if len(types) > 1:
        raise TypeMismatch(f"{topic}: published with several types ({', '.join(types)})")
    learned = ros2_types.ros_type_of(names[0])
    if learned is None:
        raise TypeMismatch(f"{topic}: published as {names[0]}, not a ROS 2 message type (pkg::msg::dds_::Name_)")
    if msgtype is not None and ros2_types.ros_type(msgtype) != learned:
        raise TypeMismatch(f"{topic}: published as {learned}, not {ros2_types.ros_type(msgtype)}")
    try:
        ours = ros2_types.type_hash(learned)
    except ValueError:
        raise TypeMismatch(f"{topic}: published as {learned}, which the definitions ({ros2_types.STORE}) do not "
                           "have") from None
    for s in found:
        userdata = s.qos[Policy.Userdata]
        fields = dict(f.split("=", 1) for f in (userdata.data.decode(errors="replace") if userdata else "")
                      .split(";") if "=" in f)
        theirs = fields.get("typehash")
        if theirs and theirs != ours:
            raise TypeMismatch(f"{topic}: {learned} published with the definition {theirs}, not {ros2_types.STORE}'s "
                               f"{ours} (another ROS 2 distribution's?)")
    # a writer's reliability is reliable unless it says otherwise (DDS's default for writers)
    reliable = all(s.qos[Policy.Reliability] != Policy.Reliability.BestEffort for s in found)
    return learned, reliable


class Ros2Source:
    """The messages of one ROS 2 topic, handed to ``on_message(msgtype, message, received)``: ``msgtype``
    ``pkg/msg/Name``, ``message`` rosbags' (the attributes replay's field paths read), ``received`` the wall time
    (s since the Unix epoch) it was taken.

    It waits up to ``timeout`` s for a publisher of ``topic`` (:class:`TopicNotPublished` naming the topic when
    none comes) and takes the type from it; ``msgtype``, when given, must be that type (:class:`TypeMismatch`
    naming both). The reader is reliable when every publisher found is, else best effort (as ``ros2 topic echo``
    adapts), keeps the last :data:`DEPTH` messages (a slow callback loses the oldest, no queue grows) and
    delivers on its own thread, one message at a time in arrival order. :meth:`close` (from any thread, the
    callback's too) ends it; an exception of the callback stops the delivery and is raised by :meth:`close`."""

    def __init__(self, topic: str, msgtype: str | None, on_message: Callable[[str, Any, float], None],
                 domain_id: int | None = None, timeout: float = 10.0):
        from cyclonedds.core import GuardCondition, InstanceState, ReadCondition, SampleState, ViewState, WaitSet
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic

        self.topic = ros2_types.ros_topic(topic)
        wanted = None if msgtype is None else ros2_types.ros_type(msgtype)
        self._on_message = on_message
        self._lock = threading.Lock()
        self._closing = threading.Event()
        self._error: BaseException | None = None
        self._entities: list = []
        self._participant = join(domain_id)
        try:
            found = publications(self._participant, self.topic, timeout)
            if not found:
                raise TopicNotPublished(f"{self.topic}: nobody published it within {timeout:g} s (domain "
                                        f"{domain_id_of(domain_id)}; ros2 topic list shows what is)")
            self.msgtype, reliable = published_type(self.topic, found, wanted)
            dds_topic: Any = Topic(self._participant, ros2_types.dds_topic(self.topic),
                                   ros2_types.reader_type(self.msgtype))
            self._reader = DataReader(self._participant, dds_topic, _qos(reliable, self.msgtype))
            self._arrived = ReadCondition(self._reader, SampleState.Any | ViewState.Any | InstanceState.Any)
            self._wake = GuardCondition(self._participant)
            self._waitset = WaitSet(self._participant)
            self._waitset.attach(self._arrived)
            self._waitset.attach(self._wake)
            self._entities = [self._waitset, self._wake, self._arrived, self._reader, dds_topic]
        except BaseException:
            end(*self._entities)
            leave(self._participant)
            raise
        self._thread = threading.Thread(target=self._deliver, name=f"ros2 {self.topic}", daemon=True)
        self._thread.start()

    def _deliver(self) -> None:
        from cyclonedds.internal import InvalidSample
        from cyclonedds.util import duration

        try:
            while True:
                self._waitset.wait(duration(infinite=True))
                if self._closing.is_set():
                    break
                for sample in self._reader.take(N=DEPTH):  # the reader keeps DEPTH: this takes them all
                    if self._closing.is_set():
                        break
                    if isinstance(sample, InvalidSample):  # a writer gone: no message
                        continue
                    vars(sample).pop("sample_info", None)  # cyclonedds' note on the sample: not the message's
                    self._on_message(self.msgtype, sample, time.time())
        except BaseException as exc:  # the callback's (or DDS's): kept for close
            self._error = exc
        finally:
            if self._closing.is_set():
                self._finish()

    def _finish(self) -> None:
        """Delete the reader and the participant (once)."""
        with self._lock:
            entities, self._entities = self._entities, []
            participant, self._participant = self._participant, None
        if participant is not None:
            self._waitset.detach(self._arrived)
            self._waitset.detach(self._wake)
            end(*entities)
            leave(participant)

    def close(self) -> None:
        """Stop the delivery and delete the reader (idempotent); raise the callback's exception if it failed."""
        self._closing.set()
        with self._lock:  # not after _finish deleted it
            if self._participant is not None:
                self._wake.set(True)
        if threading.current_thread() is not self._thread:  # from the callback: the thread ends it on its way out
            self._thread.join()
            self._finish()
        error, self._error = self._error, None
        if error is not None:
            raise error

    def __enter__(self) -> Ros2Source:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
