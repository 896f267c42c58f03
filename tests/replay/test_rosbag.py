"""A ROS 2 bag of a simulated flight (navigation, detections, ground truth; uneven rates, reordered messages)
replays to the simulator's accuracy; bad bags and maps are refused naming the file, topic or field."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

import swarmtrack
from swarmtrack.analysis.metrics import summary
from swarmtrack.cli import main
from swarmtrack.replay import rosbag
from swarmtrack.replay.engine import replay
from swarmtrack.replay.mapping import ReplayMap
from swarmtrack.replay.steps import LogError
from swarmtrack.sim.engine import simulate

STORE = get_typestore(Stores.ROS2_HUMBLE)
T = STORE.types
POSE, POINT = "geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/PointStamped"
SIMPLE_MAP = """
uavs:
  1: {navigation: /uav1/pose, detections: /uav1/target}   # PoseStamped or Odometry; PointStamped
  2: {navigation: /uav2/pose, detections: /uav2/target}
  3: {navigation: /uav3/pose, detections: /uav3/target}
truth: /target/pose                                        # optional ground truth
"""


def _header(stamp: float):
    ns = int(round(stamp * 1e9))
    return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                                    frame_id="map")


def _pose(stamp: float, xy) -> object:
    return T[POSE](header=_header(stamp), pose=T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=float(xy[0]), y=float(xy[1]), z=0.0),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))


def _point(stamp: float, xy) -> object:
    return T[POINT](header=_header(stamp), point=T["geometry_msgs/msg/Point"](x=float(xy[0]), y=float(xy[1]), z=0.0))


def flight(rec, drop: float = 0.1, reorder: float = 0.05, seed: int = 0) -> list[tuple[float, str, str, object]]:
    """The messages of a simulated run as a flight would log them: ``(log time, topic, type, message)``; each
    message stamped with the time its data is from, a fraction ``drop`` of each topic's never sent (uneven rates),
    logged 1-20 ms after its stamp, and a fraction ``reorder`` logged 50-300 ms late (after later-stamped ones)."""
    rng = np.random.default_rng(seed)
    out = []

    def send(stamp, topic, kind, msg):
        if rng.random() < drop:
            return
        late = rng.uniform(0.05, 0.3) if rng.random() < reorder else rng.uniform(0.001, 0.02)
        out.append((stamp + late, topic, kind, msg))

    chunk_truth = {c.k0 + j: c.truth[j] for c in rec.chunks() for j in range(len(c.t))}
    for k, t, nav, det in rec.inputs():
        for i in range(len(nav)):
            send(t, f"/uav{i + 1}/pose", POSE, _pose(t, nav[i, :2]))
        taken = t if det.taken is None else det.taken
        if taken < 0:  # the sensor's latency buffer at the start: nothing was seen before the flight
            continue
        for owner, (r, b) in zip(det.owner, det.z, strict=True):
            send(taken, f"/uav{owner + 1}/target", POINT, _point(taken, (r * np.cos(b), r * np.sin(b))))
        send(t, "/target/pose", POSE, _pose(t, chunk_truth[k][rec.tracked, :2]))
    out.sort(key=lambda m: m[0])
    return out


def write_bag(path: Path, messages, storage: str = "MCAP") -> Path:
    with Writer(path, version=8, storage_plugin=getattr(StoragePlugin, storage)) as w:
        conns = {}
        for logged, topic, kind, msg in messages:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, kind, typestore=STORE)
            w.write(conns[topic], int(round(logged * 1e9)), STORE.serialize_cdr(msg, kind))
    return path


def write_ros1_bag(path: Path, messages) -> Path:
    """The same messages in a ROS 1 bag (Noetic's types: a header with a sequence number)."""
    from rosbags.rosbag1 import Writer as Writer1

    store = get_typestore(Stores.ROS1_NOETIC)
    t1 = store.types
    with Writer1(path) as w:
        conns = {}
        for seq, (logged, topic, kind, msg) in enumerate(messages):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, kind, typestore=store)
            h = msg.header
            header = t1["std_msgs/msg/Header"](seq=seq, stamp=t1["builtin_interfaces/msg/Time"](
                sec=h.stamp.sec, nanosec=h.stamp.nanosec), frame_id=h.frame_id)
            p = msg.pose.position if kind == POSE else msg.point
            point = t1["geometry_msgs/msg/Point"](x=p.x, y=p.y, z=p.z)
            one = (t1[POSE](header=header, pose=t1["geometry_msgs/msg/Pose"](
                position=point, orientation=t1["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))
                if kind == POSE else t1[POINT](header=header, point=point))
            w.write(conns[topic], int(round(logged * 1e9)), store.serialize_ros1(one, kind))
    return path


def _rmse(rec) -> dict:
    return summary(rec)["rmse"]["total"]


@pytest.fixture(scope="module")
def flown(tmp_path_factory):
    """A 30 s l24-ct flight (seed 3), its recording and inputs in memory. Its sensor has no latency: a replay
    places each detection at its stamp, which the simulator's filter does only when it fuses data at its time
    stamp (with L24's untime-stamped 0.15 s latency the replay is the better filter: 3.6 cm where the run had
    8.3 cm in x)."""
    scenario = swarmtrack.load_scenario("l24-ct", ["duration=30", "sensor.latency=0"], seed=3)
    return scenario, simulate(scenario, inputs=True)


@pytest.mark.parametrize("storage", ["MCAP", pytest.param("SQLITE3", marks=pytest.mark.slow),
                                     pytest.param("ROS1", marks=pytest.mark.slow)])
def test_a_bag_of_a_flight_with_uneven_rates_and_reordered_messages_replays_to_the_simulators_accuracy(
        tmp_path, flown, storage):
    scenario, rec = flown
    bag = (write_ros1_bag(tmp_path / "flight.bag", flight(rec)) if storage == "ROS1"
           else write_bag(tmp_path / "flight", flight(rec), storage))
    counts = {}
    mapping = ReplayMap.model_validate(yaml.safe_load(SIMPLE_MAP))
    again = replay(scenario, rosbag.steps([bag], scenario, mapping, counts), phases=False)
    want, got = _rmse(rec), _rmse(again)
    for axis in ("x", "y"):
        assert abs(got[axis] - want[axis]) <= 0.10 * want[axis], (axis, got, want)
    # the reordered messages were placed at their stamps; only a detection before its UAV's first navigation
    # message (the first was dropped) has no place to be taken from
    assert set(counts) <= {"detection with no navigation of its UAV at its time"} and sum(counts.values()) <= 5
    # the truth is the bag's: the target's logged positions (interpolated where a message was dropped)
    assert np.nanmax(np.abs(again.target[:, :2] - rec.target[:len(again.t), :2])) < 0.05


@pytest.mark.slow
def test_the_simplest_map_works_as_written_through_the_command(tmp_path, flown):
    scenario, rec = flown
    bag = write_bag(tmp_path / "flight", flight(rec))
    (tmp_path / "map.yaml").write_text(SIMPLE_MAP)
    out = tmp_path / "replayed"
    res = CliRunner().invoke(main, ["replay", str(bag), "--scenario", "l24-ct", "--map", str(tmp_path / "map.yaml"),
                                    "--no-plots", "--out", str(out)])
    assert res.exit_code == 0, res.output
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["replay"]["format"] == "rosbag" and metrics["rmse"]["total"]["x"] > 0


@pytest.mark.slow
def test_unusable_messages_are_skipped_and_counted_not_fatal(tmp_path, flown):
    scenario, rec = flown
    messages = flight(rec, drop=0.0, reorder=0.0)
    nan_at = next(j for j, m in enumerate(messages) if m[1] == "/uav2/pose" and m[0] > 5)
    logged, topic, kind, _ = messages[nan_at]
    messages[nan_at] = (logged, topic, kind, _pose(logged, (np.nan, 1.0)))
    bag = write_bag(tmp_path / "flight", messages)
    counts = {}
    mapping = ReplayMap.model_validate(yaml.safe_load(SIMPLE_MAP))
    again = replay(scenario, rosbag.steps([bag], scenario, mapping, counts), phases=False)
    assert counts == {"NaN or infinite value in a message on /uav2/pose": 1}
    assert len(again.t) > 500


def _refused(tmp_path, bag, map_text: str) -> str:
    (tmp_path / "map.yaml").write_text(map_text)
    out = tmp_path / "never"
    res = CliRunner().invoke(main, ["replay", str(bag), "--scenario", "l24-ct", "--map", str(tmp_path / "map.yaml"),
                                    "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output and not out.exists()
    return res.output


def test_bad_bags_and_maps_are_refused_with_one_message_naming_the_cause(tmp_path, flown):
    scenario, rec = flown
    messages = flight(rec, drop=0.0, reorder=0.0)
    bag = write_bag(tmp_path / "flight", messages[:4000])
    assert "no topic /uav9/pose" in _refused(tmp_path, bag, SIMPLE_MAP.replace("/uav1/pose", "/uav9/pose"))
    four = SIMPLE_MAP.replace("truth:", "  4: {navigation: /uav1/pose}\ntruth:")
    assert "uavs.4 is in the map" in _refused(tmp_path, bag, four)
    nothing = SIMPLE_MAP.replace("truth: /target/pose", "truth: {topic: /target/pose, position: pose.nothing}")
    assert "no field 'pose.nothing'" in _refused(tmp_path, bag, nothing)
    # a topic whose clock jumps back by more than the window
    back = list(messages[:4000])
    j = next(j for j, m in enumerate(back) if m[1] == "/uav1/pose" and m[0] > 10)
    logged, topic, kind, _ = back[j]
    back[j] = (logged, topic, kind, _pose(logged - 5.0, (0.0, 0.0)))
    bent = write_bag(tmp_path / "bent", back)
    assert "/uav1/pose: time stamps go backwards" in _refused(tmp_path, bent, SIMPLE_MAP)
    # a truncated file
    (mcap,) = bag.glob("*.mcap")
    cut = tmp_path / "cut"
    cut.mkdir()
    (cut / "metadata.yaml").write_text((bag / "metadata.yaml").read_text())
    (cut / mcap.name).write_bytes(mcap.read_bytes()[: mcap.stat().st_size // 2])
    assert f"{cut}: not a readable ROS bag" in _refused(tmp_path, cut, SIMPLE_MAP)
    assert "not YAML" in _refused(tmp_path, bag, "uavs: [")
    with pytest.raises(LogError, match="no topic"):
        list(rosbag.steps([bag], scenario, ReplayMap.model_validate(
            {"uavs": {1: {"navigation": "/nothing"}}}), {}))


@pytest.mark.slow
def test_a_navigation_message_whose_covariance_is_not_positive_definite_is_skipped_and_counted(tmp_path, flown):
    scenario, rec = flown
    cov_type = "geometry_msgs/msg/PoseWithCovarianceStamped"

    def with_covariance(msg, bad: bool):
        c = np.zeros((6, 6))
        c[:2, :2] = [[1.0, 2.0], [2.0, 1.0]] if bad else [[0.01, 0.0], [0.0, 0.01]]  # eigenvalues −1, 3: not PD
        return T[cov_type](header=msg.header, pose=T["geometry_msgs/msg/PoseWithCovariance"](
            pose=msg.pose, covariance=c.ravel()))

    messages, bad = [], 0
    for logged, topic, kind, msg in flight(rec, drop=0.0, reorder=0.0):
        if topic == "/uav1/pose":
            wrong = 5.0 < logged < 6.0
            bad += wrong
            messages.append((logged, topic, cov_type, with_covariance(msg, wrong)))
        else:
            messages.append((logged, topic, kind, msg))
    bag = write_bag(tmp_path / "flight", messages)
    counts = {}
    again = replay(scenario, rosbag.steps([bag], scenario, ReplayMap.model_validate(yaml.safe_load(SIMPLE_MAP)),
                                          counts), phases=False)
    assert bad > 10 and counts == {"covariance not positive definite on /uav1/pose": bad}
    assert np.isfinite(again.estimate[-1]).all()


@pytest.mark.parametrize("name", ["flight.bag", "flight.mcap", "flight.db3", "folder"])
def test_a_bag_that_is_not_its_format_or_not_utf8_is_refused_naming_it(tmp_path, name):
    junk = b"\xff\xfe\x00\x80 not a bag \x81" * 8
    bag = tmp_path / name
    if name == "folder":
        bag.mkdir()
        (bag / "metadata.yaml").write_bytes(junk)  # a ROS 2 bag folder whose metadata is not text
    else:
        bag.write_bytes(junk)
    msg = _refused(tmp_path, bag, SIMPLE_MAP)
    assert f"{bag}: not a readable ROS bag" in msg and msg.count("\n") == 1, msg


def test_a_map_that_is_not_utf8_text_is_refused_naming_it(tmp_path):
    log = tmp_path / "flight.csv"
    log.write_text("t,uav,kind,x,y\n0.0,1,navigation,0.0,0.0\n")
    (tmp_path / "map.yaml").write_bytes(b"uavs:\n  1: {navigation: /a\xff\xfe}\n")
    res = CliRunner().invoke(main, ["replay", str(log), "--scenario", "l24-ct", "--map", str(tmp_path / "map.yaml"),
                                    "--out", str(tmp_path / "never")])
    assert res.exit_code == 2 and "Traceback" not in res.output and not (tmp_path / "never").exists()
    assert f"--map {tmp_path / 'map.yaml'}: not a text (UTF-8) file" in res.output
