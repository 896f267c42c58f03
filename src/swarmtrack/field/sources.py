"""Where a field agent's and a monitor's inputs come from: sources named by URL, decoded as ``swarmtrack replay``
decodes a bag's messages (:class:`~swarmtrack.replay.rosbag.Topics`), so one map file serves both.

=====================================================  ==============================================================
URL                                                    what it names
=====================================================  ==============================================================
``zenoh://KEY[?type=PKG/msg/TYPE]``                    a Zenoh key whose samples carry a ROS 2 message serialised as
                                                       CDR (as ``zenoh-bridge-ros2dds`` carries ROS 2 topics); its
                                                       type from ``type=``, or from the samples' encoding
                                                       (``application/cdr;PKG/msg/TYPE``)
``ros2:///TOPIC[?type=PKG/msg/TYPE]``, ``/TOPIC``      a ROS 2 topic over DDS (``cyclonedds``, no ROS installation);
                                                       its type from ``type=`` or from discovery
=====================================================  ==============================================================

A map file's plain topic (``/uav1/pose``) is a ROS 2 topic. The types and fields read are replay's: navigation and
truth ``geometry_msgs/PoseStamped``, ``PoseWithCovarianceStamped``, ``nav_msgs/Odometry`` or a ``position`` path;
detections ``geometry_msgs/PointStamped`` (the target relative to the UAV along the map frame's axes), a ``point``
path, or ``range`` and ``bearing`` paths. A message's time is its header's stamp (s since the Unix epoch, the
clocks synchronised by NTP or PTP). A message that does not decode as its type is skipped and counted; a source
whose samples say they are of another type than its URL names stops the agent at its start (:class:`SourceError`).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from urllib.parse import parse_qs, urlsplit

#: The schemes of a source URL.
SCHEMES = ("zenoh", "ros2")


class SourceError(Exception):
    """A source URL that does not parse, a topic that never comes, a message type that does not match: the
    message names the source."""


@dataclass(frozen=True)
class SourceUrl:
    """A parsed source URL: ``scheme`` (``zenoh`` or ``ros2``), ``topic`` (a Zenoh key expression, or a ROS 2 topic
    name from its ``/``), ``msgtype`` (``pkg/msg/Type``, or None: learnt from the source) and ``text`` (as given)."""

    scheme: str
    topic: str
    msgtype: str | None
    text: str


def parse(url: str) -> SourceUrl:
    """``url`` parsed (module docstring), or :class:`SourceError` saying what is wrong with it."""
    text = url.strip()
    if text.startswith("/"):
        text = "ros2://" + text
    parts = urlsplit(text)
    if parts.scheme not in SCHEMES:
        raise SourceError(f"{url!r} is not a source: expected zenoh://KEY, ros2:///TOPIC or /TOPIC "
                          f"(optionally ?type=PKG/msg/TYPE)")
    topic = parts.netloc + parts.path
    if parts.scheme == "ros2" and (parts.netloc or not parts.path.startswith("/")):
        raise SourceError(f"{url!r}: a ROS 2 topic is ros2:///TOPIC (three slashes: the topic name starts with /)")
    if not topic.strip("/") or any(c in topic for c in " #?$") or (parts.scheme == "zenoh" and "//" in topic):
        raise SourceError(f"{url!r}: no {'key' if parts.scheme == 'zenoh' else 'topic'} named, or one with a space, "
                          "#, ?, $ or an empty chunk")
    query = parse_qs(parts.query, keep_blank_values=True)
    unknown = sorted(set(query) - {"type"})
    if unknown:
        raise SourceError(f"{url!r}: unknown parameter {unknown[0]!r} (a source takes ?type=PKG/msg/TYPE)")
    msgtype = query["type"][-1] if "type" in query else None
    return SourceUrl(parts.scheme, topic if parts.scheme == "ros2" else topic.strip("/"),
                     None if msgtype is None else message_type(msgtype, url), url)


def message_type(name: str, where: str) -> str:
    """``name`` as ``pkg/msg/Type`` (``pkg/Type`` is taken too), checked against the ROS 2 message definitions
    ``rosbags`` knows; :class:`SourceError` naming ``where`` otherwise."""
    parts = name.strip("/").split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    full = "/".join(parts)
    if len(parts) != 3 or parts[1] != "msg" or full not in typestore().fielddefs:
        raise SourceError(f"{where}: {name!r} is not a ROS 2 message type (expected e.g. "
                          "geometry_msgs/msg/PointStamped)")
    return full


@cache
def typestore():
    """The ROS 2 message definitions (``rosbags``, the ROS 2 distribution of the community wheels)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


#: ``on_message(msgtype, message, received)``: a decoded message (its fields as ``rosbags`` names them), its type
#: (``pkg/msg/Type``) and when it came (wall-clock s).
OnMessage = Callable[[str, object, float], None]


class ZenohSource:
    """Samples of a Zenoh key on ``transport`` (a :class:`~swarmtrack.live.transport.ZenohTransport`), decoded as
    CDR of their ROS 2 type, handed to ``on_message``; ``on_skip(cause)`` for a sample that does not decode."""

    def __init__(self, url: SourceUrl, transport, on_message: OnMessage, on_skip: Callable[[str], None]):
        self.url, self.on_message, self.on_skip = url, on_message, on_skip
        self.problem: str | None = None  # a type that does not match the URL's, seen on its first sample
        self.first = threading.Event()
        transport.subscribe_typed(url.topic, self._arrive)

    def _arrive(self, key: str, data: bytes, schema: str | None) -> None:
        received = time.time()
        msgtype = self.url.msgtype or schema
        if self.url.msgtype and schema and schema != self.url.msgtype:
            if not self.first.is_set():
                self.problem = (f"{self.url.text}: its samples are {schema}, the URL names {self.url.msgtype}")
                self.first.set()
            self.on_skip("message of another type than its source names")
            return
        if msgtype is None:
            if not self.first.is_set():
                self.problem = (f"{self.url.text}: its samples do not say their type (their encoding has no "
                                "schema): name it, ?type=PKG/msg/TYPE")
                self.first.set()
            return
        try:
            msg = typestore().deserialize_cdr(data, msgtype)
        except Exception:  # noqa: BLE001 - whatever the bytes are, the sample is counted and dropped
            self.on_skip("message that does not decode as its type")
            return
        self.first.set()
        self.on_message(msgtype, msg, received)

    def close(self) -> None:
        """Its subscription ends with the transport."""


class Ros2Input:
    """A ROS 2 topic through ``cyclonedds`` (:class:`~swarmtrack.streams.ros2.Ros2Source`): it waits up to
    ``timeout`` s for a publisher and takes its type (a type named that differs, or no publisher: a
    :class:`SourceError` naming the source)."""

    def __init__(self, url: SourceUrl, on_message: OnMessage, timeout: float):
        from swarmtrack.streams.ros2 import Ros2Source

        self.url, self.problem, self.first = url, None, threading.Event()

        def deliver(msgtype: str, msg, received: float) -> None:
            self.first.set()
            on_message(msgtype, msg, received)

        try:
            self.source = Ros2Source(url.topic, url.msgtype, deliver, timeout=timeout)
        except (TimeoutError, ValueError) as exc:
            raise SourceError(f"{url.text}: {exc}") from None

    def close(self) -> None:
        self.source.close()


def open_source(url: SourceUrl, transport, on_message: OnMessage, on_skip: Callable[[str], None],
                timeout: float) -> ZenohSource | Ros2Input:
    """A running source for ``url``: Zenoh on ``transport``, or a ROS 2 topic (which waits up to ``timeout`` s for
    its publisher)."""
    if url.scheme == "zenoh":
        return ZenohSource(url, transport, on_message, on_skip)
    return Ros2Input(url, on_message, timeout)
