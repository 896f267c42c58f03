"""ROS 2 message types for cyclonedds without ROS (swarmtrack.streams.ros2_types): the generated types write rosbags'
CDR byte for byte and read it back; type and topic names follow the rmw conventions."""

from __future__ import annotations

import numpy as np
import pytest
from rosbags.interfaces import Nodetype

from swarmtrack.streams import ros2_types

STORE = ros2_types.typestore()
T = STORE.types


# --- the types ----------------------------------------------------------------------------------------------------

def _header(sec: int, nanosec: int, frame_id: str = "map"):
    return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec),
                                    frame_id=frame_id)


def _point(x, y, z):
    return T["geometry_msgs/msg/Point"](x=x, y=y, z=z)


def _pose(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return T["geometry_msgs/msg/Pose"](position=_point(*rng.normal(size=3)),
                                       orientation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]))


def _messages():
    """Messages of the published types with every field set (random numbers, text, points, an image; float32
    fields to values a float32 holds)."""
    rng = np.random.default_rng(7)
    vector = lambda: T["geometry_msgs/msg/Vector3"](*rng.normal(size=3))  # noqa: E731
    covariance = rng.normal(size=36)
    pose_cov = T["geometry_msgs/msg/PoseWithCovariance"](pose=_pose(rng), covariance=covariance)
    twist_cov = T["geometry_msgs/msg/TwistWithCovariance"](
        twist=T["geometry_msgs/msg/Twist"](linear=vector(), angular=vector()), covariance=rng.normal(size=36))
    marker = ros2_types.zero_message(
        "visualization_msgs/msg/Marker", header=_header(12, 345, "map"), ns="sets", id=-3, type=4, action=0,
        pose=_pose(rng), scale=vector(), color=T["std_msgs/msg/ColorRGBA"](r=0.125, g=0.25, b=0.375, a=1.0),
        points=[_point(*rng.normal(size=3)) for _ in range(5)], text="région 2", frame_locked=True,
        colors=[T["std_msgs/msg/ColorRGBA"](r=1.0, g=0.5, b=0.25, a=0.5)])
    marker.texture.data = rng.integers(0, 255, 17).astype(np.uint8)
    return {
        "geometry_msgs/msg/PoseWithCovarianceStamped": T["geometry_msgs/msg/PoseWithCovarianceStamped"](
            header=_header(1_700_000_000, 999_999_999), pose=pose_cov),
        "visualization_msgs/msg/MarkerArray": T["visualization_msgs/msg/MarkerArray"](
            markers=[marker, ros2_types.zero_message("visualization_msgs/msg/Marker", action=3)]),
        "geometry_msgs/msg/PointStamped": T["geometry_msgs/msg/PointStamped"](header=_header(5, 6, "uav_1/camera"),
                                                                              point=_point(1.5, -2.25, 1e-300)),
        "nav_msgs/msg/Odometry": T["nav_msgs/msg/Odometry"](header=_header(-1, 7, "odom"), child_frame_id="base_link",
                                                            pose=pose_cov, twist=twist_cov),
    }


def _generated(message, msgtype: str):
    """The same content as an instance of the generated cyclonedds class (fields walked by their definitions)."""
    values = {}
    for name, (node, desc) in STORE.fielddefs[msgtype][1]:
        value = getattr(message, name)
        if node == Nodetype.NAME:
            value = _generated(value, desc)
        elif node in (Nodetype.ARRAY, Nodetype.SEQUENCE) and desc[0][0] == Nodetype.NAME:
            value = [_generated(v, desc[0][1]) for v in value]
        elif isinstance(value, np.ndarray):
            value = value.tolist()
        values[name] = value
    return ros2_types.idl_type(msgtype)(**values)


@pytest.mark.parametrize("msgtype", list(_messages()))
def test_generated_types_serialize_to_rosbags_cdr_byte_for_byte_and_back(msgtype):
    message = _messages()[msgtype]
    expected = bytes(STORE.serialize_cdr(message, msgtype))
    generated = _generated(message, msgtype)
    assert generated.serialize() == expected
    assert ros2_types.idl_type(msgtype).deserialize(expected) == generated  # rosbags' bytes read by cyclonedds
    back = STORE.deserialize_cdr(generated.serialize(), msgtype)  # cyclonedds' bytes read by rosbags
    assert bytes(STORE.serialize_cdr(back, msgtype)) == expected
    # what Ros2Out writes and what Ros2Source reads
    assert ros2_types.cdr(message, msgtype).serialize() == expected
    received = ros2_types.reader_type(msgtype).deserialize(expected)
    assert bytes(STORE.serialize_cdr(received, msgtype)) == expected and type(received) is type(message)


def test_type_and_topic_names_follow_the_rmw_conventions():
    assert ros2_types.dds_type_name("geometry_msgs/PoseWithCovarianceStamped") == \
        "geometry_msgs::msg::dds_::PoseWithCovarianceStamped_"
    assert ros2_types.ros_type_of("visualization_msgs::msg::dds_::MarkerArray_") == "visualization_msgs/msg/MarkerArray"
    assert ros2_types.ros_type_of("DCPSParticipant") is None
    assert ros2_types.dds_topic("/uav_1/estimate") == ros2_types.dds_topic("uav_1/estimate") == "rt/uav_1/estimate"
    assert ros2_types.idl_type("geometry_msgs/PointStamped") is ros2_types.idl_type("geometry_msgs/msg/PointStamped")
    assert ros2_types.type_hash("geometry_msgs/msg/PoseWithCovarianceStamped") == \
        "RIHS01_26432f9803e43727d3c8f668d1fdb3c630f548af631e2f4e31382371bfea3b6e"  # what rclpy's endpoints announce
    with pytest.raises(ValueError, match="'px4_msgs/msg/VehicleOdometry': not a ROS 2 message type"):
        ros2_types.ros_type("px4_msgs/msg/VehicleOdometry")
    for bad in ("/uav-1/estimate", "/1uav/pose", "", "/a//b"):
        with pytest.raises(ValueError, match="not a ROS 2 topic name"):
            ros2_types.dds_topic(bad)
