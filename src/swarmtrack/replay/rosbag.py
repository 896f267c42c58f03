"""Log reader ``rosbag``: ROS 1 bags and ROS 2 bags (sqlite3 or MCAP storage), read with ``rosbags`` (pure Python,
no ROS installation), the topics named by the map file (:mod:`swarmtrack.replay.mapping`).

What a message holds is told by its type, or by the map's dotted field paths:

========================================  ==================================================================
navigation, truth                         ``geometry_msgs/PoseStamped`` (``pose.position``),
                                          ``PoseWithCovarianceStamped`` and ``nav_msgs/Odometry``
                                          (``pose.pose.position``; their covariance is checked), or
                                          ``position: <path>`` to a message with ``x`` and ``y``
detections                                ``geometry_msgs/PointStamped`` (``point``: the target relative to the
                                          UAV along the map frame's axes), ``point: <path>``, or
                                          ``range: <path>`` and ``bearing: <path>`` (m, rad)
========================================  ==================================================================

Positions are in the map frame, ENU (REP 103: x east, y north), as swarmtrack's own; a message's time is its
header's stamp (the log time for a message without a header). Odometry's twist is in the body frame and is not
read: velocities are the positions' finite differences.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Iterator
from pathlib import Path

from swarmtrack.replay.grid import Detection, Navigation, Truth, on_grid, skip
from swarmtrack.replay.steps import LogError, StepInputs

#: Where the position is in the message types the reader knows, and where their covariance is.
POSITION = {"geometry_msgs/msg/PoseStamped": "pose.position",
            "geometry_msgs/msg/PoseWithCovarianceStamped": "pose.pose.position",
            "nav_msgs/msg/Odometry": "pose.pose.position",
            "geometry_msgs/msg/PointStamped": "point"}
COVARIANCE = {"geometry_msgs/msg/PoseWithCovarianceStamped": "pose.covariance",
              "nav_msgs/msg/Odometry": "pose.covariance"}


def accepts(path: Path) -> bool:
    path = Path(path)
    if path.is_dir():
        return (path / "metadata.yaml").is_file()
    return path.suffix in (".bag", ".mcap", ".db3")


@functools.cache
def _getter(path: str):
    return operator.attrgetter(path)


def _field(msg, path: str, topic: str, msgtype: str):
    try:
        return _getter(path)(msg)
    except AttributeError:
        raise LogError(f"{topic}: its messages ({msgtype}) have no field {path!r}") from None


def _xy(msg, path: str, topic: str, msgtype: str) -> tuple[float, float]:
    point = _field(msg, path, topic, msgtype)
    try:
        return float(point.x), float(point.y)
    except AttributeError:
        raise LogError(f"{topic}: its messages' field {path!r} ({msgtype}) has no x and y") from None


def _stamp(msg, logged: int) -> float:
    header = getattr(msg, "header", None)
    if header is None:
        return logged * 1e-9
    stamp = header.stamp
    return stamp.sec + stamp.nanosec * 1e-9


def _covariance_ok(msg, msgtype: str) -> bool:
    """The position block of a message's covariance is positive definite (an all-zero one means "not given")."""
    path = COVARIANCE.get(msgtype)
    if path is None:
        return True
    value = msg
    for part in path.split("."):
        value = getattr(value, part)
    a, b, c, d = (float(value[j]) for j in (0, 1, 6, 7))  # the x-y block of the row-major 6 × 6
    if a == b == c == d == 0.0:
        return True
    # symmetric (to rounding) and positive definite: a 2 × 2's leading minors (NaN fails every comparison)
    return abs(b - c) <= 1e-9 * max(abs(a), abs(d), 1e-300) and a > 0.0 and a * d - b * c > 0.0


class Topics:
    """The map's topics: what each one feeds (navigation / detections of a UAV, truth) and how a message decoded
    by ``rosbags`` (or one with the same fields: the field agent's ROS 2 and Zenoh sources) is read."""

    def __init__(self, mapping=None):
        self.roles: dict[str, list] = {}
        for number, sources in ({} if mapping is None else mapping.uavs).items():
            if sources.log is None:  # a UAV with a log of its own (a ULog) has its navigation there
                self.add("navigation", number - 1, sources.navigation)
            self.add("detections", number - 1, sources.detections)
        self.add("truth", None, None if mapping is None else mapping.truth)

    def add(self, role: str, uav: int | None, source) -> None:
        """``source`` (a map's :class:`~swarmtrack.replay.mapping.Source` or ``DetectionSource``; None: none)
        feeds ``role`` (``navigation``, ``detections`` or ``truth``) of UAV ``uav`` (0-based)."""
        if source is not None:
            self.roles.setdefault(source.topic, []).append((role, uav, source))

    def read(self, topic: str, msgtype: str, msg, logged: int, counts: dict) -> Iterator:
        stamp = _stamp(msg, logged)
        for role, uav, source in self.roles[topic]:
            if role == "detections":
                if source.range is not None:
                    rb = (float(_field(msg, source.range, topic, msgtype)),
                          float(_field(msg, source.bearing, topic, msgtype)))
                    yield Detection(topic, uav, stamp, range_bearing=rb)
                    continue
                path = source.point or POSITION.get(msgtype)
                if path is None:
                    raise LogError(f"{topic}: {msgtype} is not a detection type the reader knows; name its "
                                   "point (or range and bearing) field in the map")
                yield Detection(topic, uav, stamp, relative=_xy(msg, path, topic, msgtype))
                continue
            path = source.position or POSITION.get(msgtype)
            if path is None:
                raise LogError(f"{topic}: {msgtype} is not a pose type the reader knows; name its position field "
                               "in the map")
            if not _covariance_ok(msg, msgtype):
                skip(counts, "covariance not positive definite", f" on {topic}")
                continue
            position = _xy(msg, path, topic, msgtype)
            if role == "truth":
                yield Truth(topic, stamp, position)
            else:
                yield Navigation(topic, uav, stamp, position)


def messages(paths: list[Path], mapping, counts: dict) -> Iterator:
    """The map's messages of the bags ``paths``, in the bags' (log time) order."""
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore

    topics = Topics(mapping)
    try:
        reader = AnyReader([Path(p) for p in paths], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except (AnyReaderError, OSError) as exc:
        raise LogError(f"{', '.join(map(str, paths))}: not a readable ROS bag ({exc})") from None
    except (UnicodeDecodeError, ValueError, KeyError) as exc:  # rosbags reads a .bag's or folder's header as text
        raise LogError(f"{', '.join(map(str, paths))}: not a readable ROS bag, not the format its name says (a ROS 1 "
                       f".bag starts with '#ROSBAG V2.0', a ROS 2 bag is a folder with metadata.yaml; "
                       f"{type(exc).__name__}: {exc})") from None
    try:
        present = {c.topic for c in reader.connections}
        for topic in topics.roles:
            if topic not in present:
                raise LogError(f"{', '.join(map(str, paths))}: no topic {topic} (the map names it; the bag has "
                               f"{', '.join(sorted(present)) or 'none'})")
        wanted = [c for c in reader.connections if c.topic in topics.roles]
        try:
            for connection, logged, raw in reader.messages(connections=wanted):
                try:
                    msg = reader.deserialize(raw, connection.msgtype)
                except Exception as exc:  # a message the type system cannot decode: the file is damaged
                    raise LogError(f"{connection.topic}: a message logged at {logged * 1e-9:.6f} s cannot be "
                                   f"decoded ({exc})") from None
                yield from topics.read(connection.topic, connection.msgtype, msg, logged, counts)
        except (AnyReaderError, UnicodeDecodeError) as exc:
            raise LogError(f"{', '.join(map(str, paths))}: the bag is damaged or truncated ({exc})") from None
    finally:
        reader.close()


def stamped(paths: list[Path], scenario, mapping, counts: dict):
    """The bags' messages per pass (:attr:`~swarmtrack.replay.formats.LogFormat.stamped`); None without a bag."""
    if not paths:
        return None
    if mapping is None:
        raise LogError(f"{paths[0]}: a ROS bag needs a map (--map) naming its topics (docs/replay.md)")
    return lambda counted: messages(paths, mapping, counted)


def steps(paths: list[Path], scenario, mapping, counts: dict) -> Iterator[StepInputs]:
    """The steps of the bags ``paths`` alone. The registered reader's are
    :func:`swarmtrack.replay.timestamped.steps`, which reads bags with ULogs and CSVs of the same flight too (it
    imports this module, so this one cannot go through it)."""
    return on_grid(messages(paths, mapping, counts), scenario, counts, mapping.window, truth_gap=mapping.truth_gap)


