"""ROS 2 message types on DDS without a ROS installation: cyclonedds type classes generated from the message
definitions rosbags carries, and the names ROS 2 gives types and topics on the wire.

The definitions are rosbags' typestore of ROS 2 Kilted (:data:`STORE`), the distribution of rclpy 9 and of the
``ros-*-msgs`` 5.5 wheels: their ``.msg`` files and that store agree field for field (an empty message has the one
``uint8 structure_needs_at_least_one_member`` that ROS 2's IDL gives it on DDS). Replay reads bags with the same
classes, so a message received here has the attributes a bag's has.

On DDS a ROS 2 type ``pkg/msg/Name`` is ``pkg::msg::dds_::Name_`` and a topic ``/a/b`` is ``rt/a/b``
(the ``rmw`` conventions). A message is plain CDR (XCDR1, little endian, the 4-byte encapsulation header first)
of a final struct whose members are the message's fields in order:

===================================  =================================================================
``.msg``                             cyclonedds type
===================================  =================================================================
bool, float32/64, (u)int8…64         ``bool``, ``types.float32/64``, ``types.(u)int8…64``
byte / char                          ``types.byte`` (octet) / ``types.uint8`` (ROS 2's ``char`` is uint8)
string, string<=N                    ``str``, ``types.bounded_str[N]``
T[N], T[], T[<=N]                    ``types.array[T, N]``, ``types.sequence[T]``, ``types.sequence[T, N]``
pkg/Name                             the generated class of ``pkg/msg/Name``
===================================  =================================================================

:func:`idl_type` builds (once per type) the class DDS topics are made with; messages are written with rosbags'
serializer (:func:`cdr`, :func:`writer_type`: 4 µs for a PoseWithCovarianceStamped where cyclonedds' pure Python
one takes 20 to 40 µs, and byte for byte the same, as the tests hold) and read into rosbags' classes
(:func:`reader_type`).
"""

from __future__ import annotations

import functools
import re
from typing import Any

import numpy as np

#: The rosbags typestore whose definitions are on the wire (rclpy 9 and the ``ros-*-msgs`` 5.5 wheels: Kilted).
STORE = "ros2_kilted"

#: A ROS 2 name's tokens: letters, digits and underscores, not starting with a digit (REP 144 / ROS 2 topic names).
_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_DDS_TYPE = re.compile(r"(\w+)::(msg|srv|action)::dds_::(\w+)_")
#: CDR encapsulation identifiers rosbags reads: plain CDR, big and little endian (XCDR2's are 0x0006 and up).
_PLAIN_CDR = (b"\x00\x00", b"\x00\x01")
#: rosbags' numpy dtype of each numeric base type (its arrays and sequences of them are numpy arrays).
_DTYPES = {"bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8, "uint8": np.uint8,
           "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32, "int64": np.int64,
           "uint64": np.uint64, "float32": np.float32, "float64": np.float64}


@functools.cache
def typestore():
    """rosbags' typestore of :data:`STORE` (its classes are the messages' Python form here and in replay)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores(STORE))


def ros_type(name: str) -> str:
    """The full ROS 2 name ``pkg/msg/Name`` of a message type given as that or as ``pkg/Name``; ValueError for a
    type the definitions (:data:`STORE`) do not have."""
    parts = name.strip("/").split("/")
    full = f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else "/".join(parts)
    if full not in typestore().fielddefs:
        raise ValueError(f"{name!r}: not a ROS 2 message type of {STORE} (known: pkg/msg/Name, e.g. "
                         "geometry_msgs/msg/PoseStamped)")
    return full


def dds_type_name(msgtype: str) -> str:
    """The DDS type name of ``pkg/msg/Name``: ``pkg::msg::dds_::Name_``."""
    package, kind, name = ros_type(msgtype).split("/")
    return f"{package}::{kind}::dds_::{name}_"


def ros_type_of(dds_name: str) -> str | None:
    """``pkg/msg/Name`` of a DDS type name ``pkg::msg::dds_::Name_``; None for a name not of that form."""
    match = _DDS_TYPE.fullmatch(dds_name)
    return None if match is None else "/".join(match.groups())


def ros_topic(topic: str) -> str:
    """A topic name made absolute (``uav_1/estimate`` → ``/uav_1/estimate``: a name relative to the root
    namespace, where these topics live); ValueError naming it when a token is not a ROS 2 name's."""
    tokens = topic.strip("/").split("/")
    if not topic.strip("/") or not all(_TOKEN.fullmatch(t) for t in tokens):
        raise ValueError(f"{topic!r}: not a ROS 2 topic name (tokens of letters, digits and '_' separated by '/', "
                         "none starting with a digit)")
    return "/" + "/".join(tokens)


def dds_topic(topic: str) -> str:
    """The DDS topic of a ROS 2 topic: ``/a/b`` → ``rt/a/b``."""
    return "rt" + ros_topic(topic)


def type_hash(msgtype: str) -> str:
    """The type's ROS 2 hash (``RIHS01_…``, REP 2011), which ROS 2 Iron and later publish in their endpoints'
    user data as ``typehash=<hash>;``."""
    return typestore().hash_rihs01(ros_type(msgtype))


def _field_type(node: int, desc: Any) -> Any:
    """The cyclonedds annotation of one field of rosbags' definitions (module docstring's table)."""
    from cyclonedds.idl import types as idl_types
    from rosbags.interfaces import Nodetype

    types: Any = idl_types  # its generic forms (array[T, N]) are for cyclonedds' mypy plugin, not plain mypy
    if node == Nodetype.BASE:
        name, bound = desc
        if name == "string":
            return types.bounded_str[bound] if bound else str
        return {"bool": bool, "byte": types.byte, "char": types.uint8, "int8": types.int8, "uint8": types.uint8,
                "int16": types.int16, "uint16": types.uint16, "int32": types.int32, "uint32": types.uint32,
                "int64": types.int64, "uint64": types.uint64, "float32": types.float32,
                "float64": types.float64}[name]
    if node == Nodetype.NAME:
        return _idl_type(desc)
    element, length = desc
    if node == Nodetype.ARRAY:
        return types.array[_field_type(*element), length]
    return types.sequence[_field_type(*element), length] if length else types.sequence[_field_type(*element)]


def idl_type(msgtype: str) -> type:
    """The cyclonedds ``IdlStruct`` class of ``pkg/msg/Name`` (DDS name ``pkg::msg::dds_::Name_``), generated
    from the definitions once (nested types first)."""
    return _idl_type(ros_type(msgtype))


def _struct(full: str, prefix: str = "") -> type:
    """A new ``IdlStruct`` class of the type: its DDS name and fields (classes of a type made here have the same
    XTypes type object; a subclass would not, it would be a struct deriving from its base)."""
    from cyclonedds.idl import make_idl_struct

    fields = {name: _field_type(node, desc) for name, (node, desc) in typestore().fielddefs[full][1]}
    return make_idl_struct(prefix + full.rpartition("/")[2], dds_type_name(full), fields)


@functools.cache
def _idl_type(full: str) -> type:
    return _struct(full)


def reader_type(msgtype: str) -> type:
    """The type's class a DDS reader is made with (:func:`idl_type`'s DDS type) whose ``deserialize`` gives
    rosbags' message, the attributes replay reads (a field path such as ``pose.pose.position`` reads the same
    here as in a bag)."""
    return _reader_type(ros_type(msgtype))


@functools.cache
def _reader_type(full: str) -> type:
    store = typestore()

    def deserialize(cls: type, data: bytes, has_header: bool = True, use_version_2: bool | None = None) -> Any:
        if data[:2] not in _PLAIN_CDR:
            raise ValueError(f"{full}: a message in the encapsulation {data[:2].hex()} (XCDR2?); ROS 2 publishes "
                             "plain CDR")
        return store.deserialize_cdr(data, full)

    received = _struct(full, "Received")
    received.deserialize = classmethod(deserialize)  # type: ignore[attr-defined]
    return received


def writer_type(msgtype: str) -> type:
    """The type's class a DDS writer is made with (:func:`idl_type`'s DDS type), whose instances :func:`cdr`
    makes: they carry their CDR, which the writer asks them for (``serialize``)."""
    return _writer_type(ros_type(msgtype))


@functools.cache
def _writer_type(full: str) -> type:
    def __init__(self: Any, data: bytes) -> None:
        self.data = data

    def serialize(self: Any, buffer: Any = None, endianness: Any = None, use_version_2: bool | None = None) -> bytes:
        return self.data

    serialized = _struct(full, "Serialized")
    serialized.__init__ = __init__  # type: ignore[misc]
    serialized.serialize = serialize  # type: ignore[attr-defined]
    return serialized


def cdr(message: Any, msgtype: str) -> Any:
    """A rosbags message of ``pkg/msg/Name`` in CDR (rosbags' serializer), for a writer of :func:`writer_type`."""
    return _writer_type(ros_type(msgtype))(bytes(typestore().serialize_cdr(message, msgtype)))


def _zero(node: int, desc: Any) -> Any:
    """A field's value in a zero message (rosbags' form: numeric arrays and sequences as numpy arrays)."""
    from rosbags.interfaces import Nodetype

    if node == Nodetype.BASE:
        name = desc[0]
        return "" if name == "string" else _DTYPES[name](0).item()
    if node == Nodetype.NAME:
        return zero_message(desc)
    (element_node, element), length = desc
    numeric = element_node == Nodetype.BASE and element[0] != "string"
    if node == Nodetype.ARRAY:
        return np.zeros(length, _DTYPES[element[0]]) if numeric else [_zero(element_node, element)
                                                                       for _ in range(length)]
    return np.zeros(0, _DTYPES[element[0]]) if numeric else []


def zero_message(msgtype: str, **fields: Any) -> Any:
    """A rosbags message of ``pkg/msg/Name`` with ``fields`` given and every other field zero: numbers 0, strings
    and sequences empty, nested messages likewise (not the ``.msg`` defaults: a Quaternion's ``w`` is 0 here), for
    types with many fields (a Marker)."""
    full = ros_type(msgtype)
    values = {name: fields.pop(name) if name in fields else _zero(node, desc)
              for name, (node, desc) in typestore().fielddefs[full][1]}
    if fields:
        raise TypeError(f"{full} has no field {', '.join(map(repr, fields))}")
    return typestore().types[full](**values)
