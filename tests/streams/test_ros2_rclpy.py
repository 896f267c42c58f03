"""swarmtrack's ROS 2 topics with a real ROS 2 node (rclpy on Fast DDS, its default middleware): an rclpy subscriber
receives a recording's estimates exactly, Ros2Source receives an rclpy publisher's detections with their type
learned from discovery, and the message definitions swarmtrack writes are those of the installed ROS 2 packages.
Discovery on this machine only (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST), one DDS domain per test."""

from __future__ import annotations

import itertools
import operator
import os
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from swarmtrack.replay import rosbag
from swarmtrack.scenarios.loader import load_scenario
from swarmtrack.sim.engine import simulate
from swarmtrack.streams import ros2_types
from swarmtrack.streams.frame import frames
from swarmtrack.streams.ros2 import Ros2Out, Ros2Source

pytestmark = pytest.mark.slow

rclpy = pytest.importorskip("rclpy")
from geometry_msgs.msg import PointStamped, PoseWithCovarianceStamped  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402

#: The most a test waits for discovery and its messages (s).
BOUND = 30.0
_DOMAINS = itertools.count()


@pytest.fixture
def domain(monkeypatch, tmp_path) -> int:
    """A DDS domain of this test alone (parallel workers apart by their pid), discovery on this machine only, for
    both middlewares (rclpy's Fast DDS and swarmtrack's cyclonedds); rclpy's logs in the test's folder."""
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.setenv("ROS_LOG_DIR", str(tmp_path))
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    monkeypatch.delenv("CYCLONEDDS_URI", raising=False)
    return 101 + (os.getpid() * 17 + next(_DOMAINS)) % 100


@pytest.fixture
def node(domain):
    """An rclpy node in the test's domain and an executor spinning it, ended after the test."""
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=domain)
    made = rclpy.create_node("swarmtrack_test", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(made)
    yield made, executor
    executor.shutdown()
    made.destroy_node()
    rclpy.shutdown(context=context)


def _spin_until(executor, done, poke=None) -> None:
    """Spin until ``done()``, calling ``poke()`` (a send) between spins; AssertionError after :data:`BOUND` s."""
    deadline = time.monotonic() + BOUND
    while not done():
        assert time.monotonic() < deadline, "timed out"
        if poke is not None:
            poke()
        executor.spin_once(timeout_sec=0.02)


def test_an_rclpy_subscriber_receives_a_recordings_estimates_exactly(domain, node):
    recording = simulate(load_scenario("l24-ct", ["duration=1"]))
    steps = list(frames(recording))
    made, executor = node
    received: list = []
    made.create_subscription(PoseWithCovarianceStamped, "/uav_1/estimate", received.append, 10)
    out = Ros2Out(domain_id=domain)
    out.open(recording.meta)
    try:
        _spin_until(executor, lambda: bool(received), poke=lambda: out.send(steps[0]))  # discovered, matched
        for step in steps[1:]:
            out.send(step)
            stamp = round(step.t * 1e9)
            _spin_until(executor, lambda s=stamp: any(
                m.header.stamp.sec * 10**9 + m.header.stamp.nanosec == s for m in received))
    finally:
        out.close()
    by_stamp = {m.header.stamp.sec * 10**9 + m.header.stamp.nanosec: m for m in received}
    for step in steps[1:]:
        message = by_stamp[round(step.t * 1e9)]
        assert message.header.frame_id == "map"
        position = message.pose.pose.position
        np.testing.assert_allclose([position.x, position.y], step.estimate[0, :2], rtol=0, atol=1e-12)
        covariance = np.asarray(message.pose.covariance).reshape(6, 6)
        np.testing.assert_allclose(covariance[:2, :2], step.covariance[0, :2, :2], rtol=0, atol=1e-12)


def test_ros2source_learns_the_type_of_rclpy_detections_and_receives_their_values(domain, node):
    made, _ = node
    publisher = made.create_publisher(PointStamped, "/uav_1/detections", 10)
    sent = PointStamped()
    sent.header.frame_id = "map"
    sent.header.stamp.sec, sent.header.stamp.nanosec = 1_700_000_000, 123_456_789
    sent.point.x, sent.point.y, sent.point.z = 3.25, -4.5, 1e-9
    stop = threading.Event()

    def publish() -> None:  # a detector publishing at 50 Hz
        while not stop.wait(0.02):
            publisher.publish(sent)

    detector = threading.Thread(target=publish)
    detector.start()
    got: list = []
    arrived = threading.Event()
    try:
        with Ros2Source("/uav_1/detections", None, lambda *m: (got.append(m), arrived.set()), domain_id=domain,
                        timeout=BOUND) as source:
            assert arrived.wait(BOUND)
    finally:
        stop.set()
        detector.join()
    assert source.msgtype == "geometry_msgs/msg/PointStamped"
    msgtype, message, received = got[0]
    assert msgtype == "geometry_msgs/msg/PointStamped" and abs(received - time.time()) < BOUND + 5
    assert (message.header.stamp.sec, message.header.stamp.nanosec, message.header.frame_id) == \
        (1_700_000_000, 123_456_789, "map")
    point = operator.attrgetter(rosbag.POSITION[msgtype])(message)  # the field path replay reads
    assert (point.x, point.y, point.z) == (3.25, -4.5, 1e-9)


def test_the_definitions_swarmtrack_writes_are_the_installed_ros2_packages():
    import importlib.metadata

    from rosbags.interfaces import Nodetype
    from rosbags.typesys import get_types_from_msg

    store = ros2_types.typestore()
    checked = 0
    for package in ("builtin_interfaces", "std_msgs", "geometry_msgs", "nav_msgs", "visualization_msgs",
                    "sensor_msgs"):
        files = importlib.metadata.distribution("ros-" + package.replace("_", "-")).files or []
        for file in sorted(f for f in files if f.suffix == ".msg" and f.parent.name == "msg"):
            name = f"{package}/msg/{file.stem}"
            consts, fields = get_types_from_msg(Path(file.locate()).read_text(), name)[name]
            if not fields:  # an empty message: ROS 2's IDL gives it one member on DDS
                fields = [("structure_needs_at_least_one_member", (Nodetype.BASE, ("uint8", 0)))]
            assert store.fielddefs[name][1] == fields, name
            checked += 1
    assert checked > 100
