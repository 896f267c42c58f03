"""ROS 2 topics over cyclonedds without ROS (swarmtrack.streams.ros2): the generated types write rosbags' CDR byte
for byte; a recording's steps published by Ros2Out arrive through Ros2Source (both cyclonedds, one process, the
loopback interface) with their values, stamps and markers; names, types and discovery settings that cannot work
are refused naming them."""

from __future__ import annotations

import itertools
import os
import re
import threading
import time

import numpy as np
import pytest
from rosbags.interfaces import Nodetype

from swarmtrack.scenarios.loader import load_scenario
from swarmtrack.sim.engine import simulate
from swarmtrack.streams import ros2, ros2_types
from swarmtrack.streams.frame import StepFrame, frames
from swarmtrack.streams.ros2 import Ros2Out, Ros2Source, TopicNotPublished, TypeMismatch

STORE = ros2_types.typestore()
T = STORE.types
_DOMAINS = itertools.count()


@pytest.fixture
def domain(monkeypatch) -> int:
    """A DDS domain of this test alone (parallel workers apart by their pid), discovery on this machine only."""
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    monkeypatch.delenv("CYCLONEDDS_URI", raising=False)
    return 1 + (os.getpid() * 17 + next(_DOMAINS)) % 200


@pytest.fixture(scope="module")
def recording():
    return simulate(load_scenario("l24-ct", ["duration=1"]))


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


# --- discovery ----------------------------------------------------------------------------------------------------

def test_discovery_follows_ros2s_environment_variables():
    local = ros2.discovery_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    assert "<AllowMulticast>false</AllowMulticast>" in local and '<NetworkInterface address="127.0.0.1"/>' in local
    assert '<Peers><Peer address="localhost"/></Peers>' in local and local.endswith(",")
    peers = ros2.discovery_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "localhost", "ROS_STATIC_PEERS": "a.lan; 10.0.0.2"})
    assert '<Peer address="localhost"/><Peer address="a.lan"/><Peer address="10.0.0.2"/>' in peers
    assert 'autodetermine="true"' in peers  # an interface that reaches the peers besides the loopback
    subnet = ros2.discovery_config({"ROS_STATIC_PEERS": "b.lan", "CYCLONEDDS_URI": "file:///etc/cyclone.xml"})
    assert "AllowMulticast" not in subnet and '<Peer address="b.lan"/>' in subnet
    assert subnet.endswith(",file:///etc/cyclone.xml")  # the user's configuration last: it has the final word
    assert f"<Tag>ros_discovery_off_{os.getpid()}</Tag>" in ros2.discovery_config({"ROS_AUTOMATIC_DISCOVERY_RANGE":
                                                                                    "OFF"})
    assert "<Discovery></Discovery>" in ros2.discovery_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT",
                                                              "ROS_STATIC_PEERS": "ignored"})
    with pytest.raises(ValueError, match="ROS_AUTOMATIC_DISCOVERY_RANGE='LAN'"):
        ros2.discovery_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "lan"})


# --- out and in ---------------------------------------------------------------------------------------------------

class Inbox:
    """What Ros2Sources received, by topic, with a wait until a message of a given stamp came."""

    def __init__(self):
        self.messages: dict[str, list] = {}
        self.changed = threading.Condition()

    def on(self, topic: str):
        def receive(msgtype, message, received):
            with self.changed:
                self.messages.setdefault(topic, []).append((msgtype, message, received))
                self.changed.notify_all()
        return receive

    def wait(self, topic: str, done, poke=None, timeout: float = 5.0) -> list:
        """The messages of ``topic`` once ``done(messages)`` holds, calling ``poke()`` (a send) every 50 ms until
        then (AssertionError after ``timeout`` s)."""
        deadline = time.monotonic() + timeout
        with self.changed:
            while not done(self.messages.get(topic, [])):
                left = deadline - time.monotonic()
                assert left > 0, f"{topic}: timed out"
                if poke is not None:
                    poke()
                self.changed.wait(min(left, 0.05))
            return list(self.messages[topic])


def _stamp(message) -> float:
    return message.header.stamp.sec + message.header.stamp.nanosec * 1e-9


def _sources(inbox: Inbox, domain: int, topics: list[str]) -> list[Ros2Source]:
    return [Ros2Source(topic, None, inbox.on(topic), domain_id=domain, timeout=10.0) for topic in topics]


def test_a_recordings_steps_arrive_on_ros2_topics_with_their_values(recording, domain):
    steps = list(frames(recording))
    topics = ["/uav_1/estimate", "/uav_3/estimate", "/uav_2/pose", "/target/truth"]
    inbox = Inbox()
    out = Ros2Out(domain_id=domain)
    out.open(recording.meta)
    out.send(steps[0])  # its writers, which the sources discover
    sources = _sources(inbox, domain, topics)
    try:
        for topic in topics:  # each reader matched: the first step, sent again, arrives
            inbox.wait(topic, bool, poke=lambda: out.send(steps[0]))
        for step in steps[1:]:
            out.send(step)
            for topic in topics:
                inbox.wait(topic, lambda got, t=step.t: any(abs(_stamp(m) - t) < 1e-9 for _, m, _ in got))
    finally:
        for source in sources:
            source.close()
        out.close()
    assert [s.msgtype for s in sources] == ["geometry_msgs/msg/PoseWithCovarianceStamped"] * 2 + \
        ["geometry_msgs/msg/PoseStamped"] * 2
    by_stamp = {topic: {round(_stamp(m), 6): m for _, m, _ in inbox.messages[topic]} for topic in topics}
    for step in steps[1:]:
        key = round(step.t, 6)
        for uav, topic in ((0, "/uav_1/estimate"), (2, "/uav_3/estimate")):
            message = by_stamp[topic][key]
            assert message.header.frame_id == "map"
            assert (message.pose.pose.position.x, message.pose.pose.position.y) == tuple(step.estimate[uav, :2])
            covariance = message.pose.covariance.reshape(6, 6)
            np.testing.assert_array_equal(covariance[:2, :2], step.covariance[uav, :2, :2])
            assert covariance[2, 2] == 0.0 and np.all(np.diag(covariance)[3:] == ros2.UNESTIMATED_VARIANCE)
        pose = by_stamp["/uav_2/pose"][key].pose
        assert (pose.position.x, pose.position.y, pose.position.z) == (*step.uav[1, :2], 0.0)
        assert pose.orientation.w == 1.0
        truth = by_stamp["/target/truth"][key].pose.position
        assert (truth.x, truth.y) == tuple(step.target[:2])
    received = [r for _, _, r in inbox.messages["/uav_1/estimate"]]
    assert all(abs(r - time.time()) < 60 for r in received) and received == sorted(received)


def _frame(t: float, **fields) -> StepFrame:
    """Three UAVs at rest; UAV 3 absent."""
    base = dict(t=t, uavs=np.array([1, 2, 3]), uav=np.array([[1.0, 2.0, 0, 0], [3.0, 4.0, 0, 0], [np.nan] * 4]),
                present=np.array([True, True, False]))
    return StepFrame(**(base | fields))


def test_sets_formation_and_setpoints_arrive_as_markers_and_accelerations(domain):
    square = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    triangle = np.array([[-1.0, -1.0], [1.0, -1.0], [0.0, 2.0]])
    step = _frame(0.5, polygons=[(0, square), (2, triangle), (2, square + 20), (3, square)],
                  formation=np.array([[0.0, 4.0], [4.0, 0.0], [np.nan, np.nan]]),
                  command=np.array([[0.5, -0.25], [1.0, 2.0], [0.0, 0.0]]))
    topics = ["/swarm/sets", "/uav_2/sets", "/formation", "/uav_1/setpoint"]
    inbox = Inbox()
    out = Ros2Out(domain_id=domain, stamp_epoch=1_700_000_000.25)
    out.open({})
    out.send(step)
    sources = _sources(inbox, domain, topics)
    try:
        for topic in topics:
            inbox.wait(topic, bool, poke=lambda: out.send(step))
        out.send(_frame(0.55, polygons=[(0, square)]))  # UAV 2's regions are gone
        cleared = inbox.wait("/uav_2/sets", lambda got: len(got[-1][1].markers) == 1)
        with pytest.raises(TopicNotPublished, match="/uav_3/sets"):  # an absent UAV's: never published
            Ros2Source("/uav_3/sets", None, print, domain_id=domain, timeout=0.3)
    finally:
        for source in sources:
            source.close()
        out.close()
    marker_type = T["visualization_msgs/msg/Marker"]
    swarm = inbox.messages["/swarm/sets"][0][1].markers
    assert [m.action for m in swarm] == [marker_type.DELETEALL, marker_type.ADD]
    assert swarm[1].type == marker_type.LINE_STRIP and swarm[1].color.a == 1.0 and swarm[1].scale.x > 0
    assert [(p.x, p.y) for p in swarm[1].points] == [*map(tuple, square), (0.0, 0.0)]  # closed
    assert _stamp(swarm[1]) == pytest.approx(1_700_000_000.75, abs=1e-6)
    assert (swarm[1].header.stamp.sec, swarm[1].header.stamp.nanosec) == (1_700_000_000, 750_000_000)
    uav2 = inbox.messages["/uav_2/sets"][0][1].markers
    assert [m.id for m in uav2[1:]] == [0, 1] and len(uav2[1].points) == 4 and len(uav2[2].points) == 5
    assert [m.action for m in cleared[-1][1].markers] == [marker_type.DELETEALL]
    formation = inbox.messages["/formation"][0][1].markers[0]
    assert formation.type == marker_type.SPHERE_LIST and [(p.x, p.y) for p in formation.points] == [(0, 4), (4, 0)]
    accel = inbox.messages["/uav_1/setpoint"][0][1].accel
    assert (accel.linear.x, accel.linear.y, accel.linear.z, accel.angular.z) == (0.5, -0.25, 0.0, 0.0)


def test_namespaces_are_formatted_with_the_uavs_number_and_refused_naming_themselves(domain):
    for bad in ("uav_{m}", "uav_{}", "uav-{n}", "uav_{n:.2f}"):
        with pytest.raises(ValueError, match=re.escape(f"namespace {bad!r}")):
            Ros2Out(namespace=bad)
    inbox = Inbox()
    px4 = Ros2Out(namespace="px4_{n}", domain_id=domain)
    one = Ros2Out(namespace="drone", domain_id=domain)
    lone = {"uavs": np.array([4]), "uav": np.array([[7.0, 8.0, 0, 0]]), "present": np.array([True])}
    px4.open({})
    one.open({})
    try:
        px4.send(_frame(0.0))
        one.send(_frame(0.0, **lone))
        with pytest.raises(ValueError, match=re.escape("namespace 'drone' has no {n}: the topics of 3 UAVs")):
            one.send(_frame(0.1))
        [source] = _sources(inbox, domain, ["/px4_2/pose"])
        [drone] = _sources(inbox, domain, ["/drone/pose"])
        with source, drone:
            got = inbox.wait("/px4_2/pose", bool, poke=lambda: px4.send(_frame(0.2)))
            assert (got[0][1].pose.position.x, got[0][1].pose.position.y) == (3.0, 4.0)
            got = inbox.wait("/drone/pose", bool, poke=lambda: one.send(_frame(0.2, **lone)))
            assert got[0][1].pose.position.x == 7.0
    finally:
        px4.close()
        one.close()


def test_a_topic_nobody_publishes_or_of_another_type_is_refused_naming_it(domain):
    started = time.monotonic()
    with pytest.raises(TopicNotPublished, match=r"/uav_1/detections: nobody published it within 0.3 s"):
        Ros2Source("uav_1/detections", "geometry_msgs/msg/PointStamped", print, domain_id=domain, timeout=0.3)
    assert time.monotonic() - started < 3
    out = Ros2Out(domain_id=domain)
    out.open({})
    try:
        out.send(_frame(0.0))
        with pytest.raises(TypeMismatch, match="/uav_1/pose: published as geometry_msgs/msg/PoseStamped, not "
                                               "geometry_msgs/msg/PointStamped") as refused:
            Ros2Source("/uav_1/pose", "geometry_msgs/PointStamped", print, domain_id=domain, timeout=5)
        assert isinstance(refused.value, ValueError)  # as a type unknown: the callers' one refusal of a bad type
        with pytest.raises(ValueError, match="not a ROS 2 message type"):
            Ros2Source("/uav_1/pose", "geometry_msgs/msg/Nothing", print, domain_id=domain, timeout=5)
    finally:
        out.close()


def test_a_closed_output_leaves_the_network_and_a_failing_callback_is_raised_by_close(domain):
    out = Ros2Out(domain_id=domain)
    out.open({})
    out.send(_frame(0.0))

    called = threading.Event()

    def fail(msgtype, message, received):
        called.set()
        raise RuntimeError(f"callback failed on {msgtype}")

    source = Ros2Source("/uav_1/pose", None, fail, domain_id=domain, timeout=5)
    deadline = time.monotonic() + 5
    while not called.wait(0.02) and time.monotonic() < deadline:
        out.send(_frame(0.1))
    with pytest.raises(RuntimeError, match="callback failed on geometry_msgs/msg/PoseStamped"):
        source.close()
    source.close()  # idempotent, the error raised once
    out.close()
    out.close()
    with pytest.raises(TopicNotPublished):  # its writers went with it
        Ros2Source("/uav_1/pose", None, print, domain_id=domain, timeout=0.5)
    assert domain not in ros2._DOMAINS  # every participant of the domain ended


def test_a_source_closed_from_its_own_callback_stops_delivering(domain):
    out = Ros2Out(domain_id=domain)
    out.open({})
    out.send(_frame(0.0))
    calls: list = []
    first = threading.Event()

    def once(msgtype, message, received):
        calls.append(message)
        source.close()
        first.set()

    source = Ros2Source("/uav_1/pose", None, once, domain_id=domain, timeout=5)
    try:
        deadline = time.monotonic() + 5
        while not first.wait(0.02) and time.monotonic() < deadline:
            out.send(_frame(0.1))
        for _ in range(20):
            out.send(_frame(0.2))
        time.sleep(0.1)
        source.close()  # again, from here: nothing left to end
    finally:
        out.close()
    assert len(calls) == 1


def test_a_3d_estimate_carries_the_targets_altitude_and_its_xyz_covariance(domain):
    assert ros2.altitude_column({"model": "ct3d"}) == 4  # [x, y, vx, vy, z, vz, omega]
    assert ros2.altitude_column({"estimator": {"models": ["cv3d", "ct3d", "fs3d"]}}) == 4
    assert ros2.altitude_column({"model": "ct"}) is None and ros2.altitude_column({}) is None
    assert ros2.altitude_column({"estimator": {"models": ["cv", "cv3d"]}}) is None
    rng = np.random.default_rng(3)
    a = rng.normal(size=(3, 7, 7))
    covariance = a @ a.transpose(0, 2, 1) + np.eye(7)
    estimate = rng.normal(size=(3, 7))
    step = _frame(1.0, estimate=estimate, covariance=covariance, uav_altitude=np.array([5.0, 6.0, np.nan]))
    inbox = Inbox()
    out = Ros2Out(domain_id=domain)
    out.open({"model": "ct3d"})
    out.send(step)
    sources = _sources(inbox, domain, ["/uav_2/estimate", "/uav_2/pose"])
    try:
        estimated = inbox.wait("/uav_2/estimate", bool, poke=lambda: out.send(step))[0][1]
        pose = inbox.wait("/uav_2/pose", bool, poke=lambda: out.send(step))[0][1]
    finally:
        for source in sources:
            source.close()
        out.close()
    position = estimated.pose.pose.position
    assert (position.x, position.y, position.z) == tuple(estimate[1, [0, 1, 4]])
    full = estimated.pose.covariance.reshape(6, 6)
    np.testing.assert_array_equal(full[:3, :3], covariance[1][np.ix_([0, 1, 4], [0, 1, 4])])
    assert np.all(full[:3, 3:] == 0) and np.all(np.diag(full)[3:] == ros2.UNESTIMATED_VARIANCE)
    assert pose.pose.position.z == 6.0
