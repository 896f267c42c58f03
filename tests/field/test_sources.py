"""Source URLs: what parses, what is refused (one message naming the URL), and message types as rosbags knows them."""

from __future__ import annotations

import pytest

from swarmtrack.field.sources import SourceError, parse


@pytest.mark.parametrize(("url", "scheme", "topic", "msgtype"), [
    ("zenoh://field/uav_1/detections?type=geometry_msgs/msg/PointStamped", "zenoh", "field/uav_1/detections",
     "geometry_msgs/msg/PointStamped"),
    ("zenoh://field/uav_1/detections", "zenoh", "field/uav_1/detections", None),
    ("ros2:///uav_1/detections?type=geometry_msgs/PointStamped", "ros2", "/uav_1/detections",
     "geometry_msgs/msg/PointStamped"),
    ("/uav1/pose", "ros2", "/uav1/pose", None),  # a map file's plain topic: ROS 2
    ("/px4_1/fmu/out/vehicle_odometry?type=nav_msgs/msg/Odometry", "ros2", "/px4_1/fmu/out/vehicle_odometry",
     "nav_msgs/msg/Odometry"),
])
def test_a_source_url_names_its_transport_topic_and_type(url, scheme, topic, msgtype):
    got = parse(url)
    assert (got.scheme, got.topic, got.msgtype, got.text) == (scheme, topic, msgtype, url)


@pytest.mark.parametrize(("url", "says"), [
    ("udp://1.2.3.4:5", "not a source"),
    ("uav_1/detections", "not a source"),
    ("ros2://uav_1/detections", "three slashes"),
    ("zenoh://", "no key"),
    ("zenoh://a//b", "empty chunk"),
    ("zenoh://a/b?kind=x", "unknown parameter 'kind'"),
    ("zenoh://a/b?type=geometry_msgs/msg/NoSuchThing", "not a ROS 2 message type"),
    ("zenoh://a/b?type=PointStamped", "not a ROS 2 message type"),
])
def test_a_source_url_that_does_not_parse_is_one_message_naming_it(url, says):
    with pytest.raises(SourceError, match=says) as err:
        parse(url)
    assert url in str(err.value) and "\n" not in str(err.value)
