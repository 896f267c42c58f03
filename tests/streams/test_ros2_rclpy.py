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


def test_an_rclpy_node_feeds_a_field_agent_and_hears_its_fused_estimates(domain, node, tmp_path):
    """A ROS 2 node publishes UAV 1's navigation (PoseStamped) and its detections of a target standing 3 m east and 4 m
    north of it (PointStamped); ``swarmtrack agent --field --ros2`` (its own process, no world, its neighbours
    absent) fuses them and publishes its estimate on /uav_1/estimate, which the node receives near the target."""
    import subprocess
    import sys

    from geometry_msgs.msg import PoseStamped

    made, executor = node
    pose_pub = made.create_publisher(PoseStamped, "/uav_1/pose_in", 10)
    detection_pub = made.create_publisher(PointStamped, "/uav_1/detections", 10)
    estimates: list = []
    made.create_subscription(PoseWithCovarianceStamped, "/uav_1/estimate", estimates.append, 10)
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain)}
    start = time.time() + 1.0
    agent = subprocess.Popen([sys.executable, "-m", "swarmtrack", "agent", "l24-ct", "--uav", "1", "--field",
                              "--insecure", "--set", "duration=60", "--start", repr(start), "--navigation",
                              "/uav_1/pose_in", "--detections", "/uav_1/detections", "--wait", "20", "--ros2"],
                             env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    def publish() -> None:  # the UAV hovering at (1, 2), the target at (4, 6): 20 Hz, stamped now
        now = time.time()
        pose, point = PoseStamped(), PointStamped()
        for msg in (pose, point):
            msg.header.stamp.sec, msg.header.stamp.nanosec = int(now), int((now % 1) * 1e9)
            msg.header.frame_id = "map"
        pose.pose.position.x, pose.pose.position.y = 1.0, 2.0
        point.point.x, point.point.y = 3.0, 4.0
        pose_pub.publish(pose)
        detection_pub.publish(point)

    try:
        deadline = time.monotonic() + 60
        last = 0.0
        while (not estimates or time.time() < start + 5.0) and time.monotonic() < deadline:
            if time.monotonic() - last >= 0.05:
                publish()
                last = time.monotonic()
            executor.spin_once(timeout_sec=0.01)
            assert agent.poll() is None, agent.communicate()[1][-3000:]
    finally:
        agent.terminate()
        try:
            agent.wait(10)
        except subprocess.TimeoutExpired:
            agent.kill()
            agent.wait()
    assert estimates, "no estimate came"
    late = estimates[-1].pose.pose.position
    assert abs(late.x - 4.0) < 0.2 and abs(late.y - 6.0) < 0.2
    assert estimates[-1].header.frame_id == "map" and estimates[-1].pose.covariance[0] > 0.0
