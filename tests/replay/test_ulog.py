"""PX4 ULog files of a simulated flight (one per UAV, navigation in NED on each vehicle's boot clock) with its
detections and truth in a CSV or an MCAP bag replay to the simulator's accuracy; bad ULogs and maps are refused
naming the file, message or field."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import swarmtrack
from swarmtrack.analysis.metrics import summary
from swarmtrack.cli import main
from swarmtrack.replay import timestamped, ulog
from swarmtrack.replay.engine import replay
from swarmtrack.replay.mapping import ReplayMap
from swarmtrack.replay.steps import LogError
from swarmtrack.sim.engine import simulate

#: PX4's vehicle_local_position, the fields the reader reads (msg/VehicleLocalPosition.msg; the rest left out).
LOCAL_POSITION = ("vehicle_local_position", [("uint64_t", "timestamp"), ("uint64_t", "timestamp_sample"),
                                             ("bool", "xy_valid"), ("bool", "v_xy_valid"), ("float", "x"),
                                             ("float", "y"), ("float", "z"), ("float", "vx"), ("float", "vy"),
                                             ("float", "vz")])
#: vehicle_odometry since PX4 v1.14 (msg/versioned/VehicleOdometry.msg), its first fields.
ODOMETRY = ("vehicle_odometry", [("uint64_t", "timestamp"), ("uint64_t", "timestamp_sample"),
                                 ("uint8_t", "pose_frame"), ("float[3]", "position"), ("float[4]", "q"),
                                 ("uint8_t", "velocity_frame"), ("float[3]", "velocity")])
PACK = {"uint64_t": "Q", "bool": "?", "float": "f", "uint8_t": "B"}
#: Each vehicle's boot, on the flight's clock (s): its ULog's stamps are µs since then.
BOOT = {1: 12.5, 2: 3.0, 3: 40.25}


def _message(kind: str, payload: bytes) -> bytes:
    """A ULog message: its header (uint16 size, uint8 type) and payload (PX4's "ULog File Format")."""
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def _layout(fields) -> str:
    return "<" + "".join(PACK[t.split("[")[0]] * (int(t.split("[")[1][:-1]) if "[" in t else 1) for t, _ in fields)


def write_ulog(path: Path, rows, spec=LOCAL_POSITION) -> Path:
    """A minimal valid ULog: the file header (magic, version 1, start time), the flag bits, one format ('F'), its
    subscription ('A', msg_id 0) and one data message ('D') per row (the values of the format's fields, flat)."""
    name, fields = spec
    layout = _layout(fields)
    out = bytearray(ulog.MAGIC + b"\x01" + struct.pack("<Q", 0))
    out += _message("B", bytes(16) + struct.pack("<3Q", 0, 0, 0))
    out += _message("F", f"{name}:{';'.join(f'{t} {n}' for t, n in fields)};".encode())
    out += _message("A", struct.pack("<BH", 0, 0) + name.encode())
    for row in rows:
        out += _message("D", struct.pack("<H", 0) + struct.pack(layout, *row))
    path.write_bytes(bytes(out))
    return path


def local_position(stamp: float, boot: float, nav) -> tuple:
    """A vehicle_local_position row of ENU navigation ``[x, y, vx, vy]``: NED, µs since ``boot``."""
    us = int(round((stamp + boot) * 1e6))
    return (us, us, True, True, nav[1], nav[0], -20.0, nav[3], nav[2], 0.0)


def odometry(stamp: float, boot: float, nav) -> tuple:
    us = int(round((stamp + boot) * 1e6))
    return (us, us, 1, nav[1], nav[0], -20.0, 1.0, 0.0, 0.0, 0.0, 1, nav[3], nav[2], 0.0)


def flight(rec, drop: float = 0.1, reorder: float = 0.05, seed: int = 0):
    """The flight as its logs hold it: each UAV's navigation ``{uav: [(stamp, [x, y, vx, vy])]}`` (ENU, a fraction
    ``drop`` never logged: uneven rates), and the detections and truth as CSV rows ``(logged, t, uav, kind, x, y)``
    (a detection: the target relative to the UAV, stamped when it was taken), a fraction ``drop`` never logged and
    ``reorder`` logged 50-300 ms late, after later-stamped ones."""
    rng = np.random.default_rng(seed)
    navs: dict[int, list] = {i: [] for i in BOOT}
    rows = []

    def row(stamp, uav, kind, x, y):
        if rng.random() < drop:
            return
        late = rng.uniform(0.05, 0.3) if rng.random() < reorder else rng.uniform(0.001, 0.02)
        rows.append((stamp + late, stamp, uav, kind, x, y))

    truth = {c.k0 + j: c.truth[j] for c in rec.chunks() for j in range(len(c.t))}
    for k, t, nav, det in rec.inputs():
        for i in range(len(nav)):
            if rng.random() >= drop:
                navs[i + 1].append((t, nav[i]))
        taken = t if det.taken is None else det.taken
        if taken >= 0:
            for owner, (r, b) in zip(det.owner, det.z, strict=True):
                row(taken, owner + 1, "detection", r * np.cos(b), r * np.sin(b))
        row(t, "", "truth", *truth[k][rec.tracked, :2])
    rows.sort(key=lambda r: r[0])
    return navs, rows


def write_ulogs(folder: Path, navs, make=local_position, spec=LOCAL_POSITION) -> list[Path]:
    return [write_ulog(folder / f"uav{i}.ulg", [make(t, BOOT[i], v) for t, v in navs[i]], spec) for i in navs]


def write_csv(path: Path, rows) -> Path:
    lines = ["t,uav,kind,x,y"] + [f"{float(t)!r},{uav},{kind},{float(x)!r},{float(y)!r}"
                                  for _, t, uav, kind, x, y in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def ulog_map(message: str = "vehicle_local_position", **extra) -> dict:
    return {"uavs": {i: {"log": f"uav{i}.ulg", "navigation": message, "time_offset": -BOOT[i], **extra}
                     for i in BOOT}}


def _rmse(rec) -> dict:
    return summary(rec)["rmse"]["total"]


def _close(again, rec) -> None:
    want, got = _rmse(rec), _rmse(again)
    for axis in ("x", "y"):
        assert abs(got[axis] - want[axis]) <= 0.10 * want[axis], (axis, got, want)


@pytest.fixture(scope="module")
def flown():
    """A 30 s l24-ct flight (seed 3) without sensor latency, as tests/replay/test_rosbag.py flies it."""
    scenario = swarmtrack.load_scenario("l24-ct", ["duration=30", "sensor.latency=0"], seed=3)
    return scenario, simulate(scenario, inputs=True)


@pytest.mark.parametrize("message", ["vehicle_local_position",
                                     pytest.param("vehicle_odometry", marks=pytest.mark.slow)])
def test_ulogs_per_uav_with_a_csv_of_detections_replay_to_the_simulators_accuracy(tmp_path, flown, message):
    scenario, rec = flown
    navs, rows = flight(rec)
    make, spec = (local_position, LOCAL_POSITION) if message == "vehicle_local_position" else (odometry, ODOMETRY)
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(tmp_path)  # the map's relative logs, as replay_logs reads a map given as a dict
        logs = [*write_ulogs(tmp_path, navs, make, spec), write_csv(tmp_path / "detections.csv", rows)]
        counts = {}
        mapping = ReplayMap.model_validate(ulog_map(message))
        again = replay(scenario, timestamped.steps(logs, scenario, mapping, counts), phases=False)
    _close(again, rec)
    assert set(counts) <= {"detection with no navigation of its UAV at its time"} and sum(counts.values()) <= 5
    # the truth is the CSV's, on the ULogs' boot clocks made the flight's by time_offset
    assert np.nanmax(np.abs(again.target[:, :2] - rec.target[:len(again.t), :2])) < 0.05
    assert len(again.t) >= len(rec.t) - 2


@pytest.mark.slow
def test_ulogs_with_an_mcap_bag_of_detections_replay_through_the_command(tmp_path, flown):
    """The map names each UAV's ULog (found beside the map) and its detection topic in the bag, and the truth."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    scenario, rec = flown
    navs, rows = flight(rec)
    write_ulogs(tmp_path, navs)
    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types
    point_type = "geometry_msgs/msg/PointStamped"
    with Writer(tmp_path / "flight", version=8, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {}
        for logged, t, uav, kind, x, y in rows:
            topic = f"/uav{uav}/target" if kind == "detection" else "/target/point"
            if topic not in conns:
                conns[topic] = w.add_connection(topic, point_type, typestore=store)
            ns = int(round(t * 1e9))
            msg = types[point_type](header=types["std_msgs/msg/Header"](
                stamp=types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9), frame_id="map"),
                point=types["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0))
            w.write(conns[topic], int(round(logged * 1e9)), store.serialize_cdr(msg, point_type))
    mapping = ulog_map()
    for i in BOOT:
        mapping["uavs"][i]["detections"] = f"/uav{i}/target"
    mapping["truth"] = "/target/point"
    (tmp_path / "map.yaml").write_text(yaml.safe_dump(mapping))
    out = tmp_path / "replayed"
    res = CliRunner().invoke(main, ["replay", str(tmp_path / "flight"), "--scenario", "l24-ct", "--set",
                                    "duration=30", "--set", "sensor.latency=0", "--seed", "3", "--map",
                                    str(tmp_path / "map.yaml"), "--no-plots", "--out", str(out)])
    assert res.exit_code == 0, res.output
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["replay"]["format"] == "rosbag"
    want = _rmse(rec)
    for axis in ("x", "y"):
        assert abs(metrics["rmse"]["total"][axis] - want[axis]) <= 0.10 * want[axis]


@pytest.mark.slow
def test_invalid_and_nan_navigation_is_skipped_and_counted_not_fatal(tmp_path, flown):
    scenario, rec = flown
    navs, rows = flight(rec, drop=0.0, reorder=0.0)
    rows_of = {i: [local_position(t, BOOT[i], v) for t, v in navs[i]] for i in BOOT}
    invalid = list(rows_of[2][100])
    invalid[2] = False  # xy_valid
    rows_of[2][100] = tuple(invalid)
    nan = list(rows_of[3][200])
    nan[4] = float("nan")  # x (north)
    rows_of[3][200] = tuple(nan)
    slow = list(rows_of[1][300])
    slow[3] = False  # v_xy_valid: the position is kept, its velocity is not read
    rows_of[1][300] = tuple(slow)
    logs = [write_ulog(tmp_path / f"uav{i}.ulg", rows_of[i]) for i in BOOT]
    counts = {}
    mapping = ReplayMap.model_validate(ulog_map())
    for i in BOOT:
        mapping.uavs[i].log = tmp_path / f"uav{i}.ulg"
    # a CSV's navigation of a UAV that flies a ULog is not read: its navigation is the ULog's
    rows += [(t, t, 1, "navigation", 100.0, 100.0) for t in (1.0, 2.0)]
    csv = write_csv(tmp_path / "d.csv", sorted(rows))
    again = replay(scenario, timestamped.steps([*logs, csv], scenario, mapping, counts), phases=False)
    assert counts == {f"xy_valid false on vehicle_local_position in {logs[1]}": 1,
                      f"NaN or infinite value in a message on vehicle_local_position in {logs[2]}": 1,
                      f"navigation rows in {csv} of a UAV whose navigation is its ULog's": 2}
    _close(again, rec)


def _refused(tmp_path, logs, mapping: dict | None) -> str:
    args = ["replay", *map(str, logs), "--scenario", "l24-ct", "--set", "duration=30", "--out", str(tmp_path / "no")]
    if mapping is not None:
        (tmp_path / "map.yaml").write_text(yaml.safe_dump(mapping))
        args += ["--map", str(tmp_path / "map.yaml")]
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output and not (tmp_path / "no").exists()
    return res.output


def test_bad_ulogs_and_maps_are_refused_with_one_message_naming_the_cause(tmp_path, flown):
    scenario, rec = flown
    navs, rows = flight(rec, drop=0.0, reorder=0.0)
    navs = {i: navs[i][:200] for i in navs}  # 10 s
    ulogs = write_ulogs(tmp_path, navs)
    csv = write_csv(tmp_path / "detections.csv", rows[:1000])
    assert "gone.ulg: no such file" in _refused(tmp_path, [tmp_path / "gone.ulg", csv], ulog_map())
    gone = ulog_map()
    gone["uavs"][2]["log"] = "missing.ulg"
    assert "uavs.2.log:" in (msg := _refused(tmp_path, [csv], gone)) and "missing.ulg: no such file" in msg
    # a file cut inside a message
    data = ulogs[0].read_bytes()
    (tmp_path / "cut").mkdir()
    (tmp_path / "cut" / "uav1.ulg").write_bytes(data[: len(data) - 7])
    msg = _refused(tmp_path, [tmp_path / "cut" / "uav1.ulg", *ulogs[1:], csv], ulog_map())
    assert "uav1.ulg: the ULog is truncated" in msg and "cut" in msg
    (tmp_path / "cut" / "uav1.ulg").write_bytes(data[:10])  # inside the file's header
    assert "uav1.ulg: the ULog is truncated" in _refused(tmp_path, [tmp_path / "cut" / "uav1.ulg", csv], ulog_map())
    (tmp_path / "cut" / "uav1.ulg").write_text("not a log at all")
    assert "uav1.ulg: not a readable PX4 ULog file" in _refused(tmp_path, [tmp_path / "cut" / "uav1.ulg", csv],
                                                                ulog_map())
    assert "no message vehicle_odometry" in _refused(tmp_path, [*ulogs, csv], ulog_map("vehicle_odometry"))
    named = ulog_map({"topic": "vehicle_local_position", "position": "pos"})
    assert "vehicle_local_position has no position field (pos[0], pos[1] or pos.x, pos.y" in _refused(
        tmp_path, [*ulogs, csv], named)
    stray = tmp_path / "other" / "uav9.ulg"
    stray.parent.mkdir()
    write_ulog(stray, [])
    assert "uav9.ulg: no UAV of the map names this ULog" in _refused(tmp_path, [*ulogs, stray, csv], ulog_map())
    assert "a ULog needs a map" in _refused(tmp_path, [csv, *ulogs], None)
    # a vehicle's clock that jumps back by more than the window
    back = [local_position(t, BOOT[1], v) for t, v in navs[1]]
    back[120] = local_position(navs[1][120][0] - 5.0, BOOT[1], navs[1][120][1])
    write_ulog(ulogs[0], back)
    assert f"vehicle_local_position in {ulogs[0]}: time stamps go backwards" in _refused(
        tmp_path, [*ulogs, csv], ulog_map())
    (tmp_path / "x.mcap").write_bytes(b"")
    with pytest.raises(LogError, match="a ROS bag needs a map"):
        timestamped.steps([tmp_path / "x.mcap"], scenario, None, {})
    with pytest.raises(LogError, match="map.yaml: not a ") as refused:  # every time-stamped reader's files named
        timestamped.steps([tmp_path / "map.yaml"], scenario, None, {})
    assert all(what in str(refused.value) for what in ("a ROS bag (", "a PX4 ULog (.ulg)", "a CSV file (.csv)"))


def test_a_ulog_is_recognised_by_its_magic_bytes(tmp_path):
    plain = write_ulog(tmp_path / "flight.log", [])
    assert ulog.accepts(plain) and ulog.accepts(tmp_path / "any.ulg") is False
    (tmp_path / "text.log").write_text("hello")
    assert not ulog.accepts(tmp_path / "text.log")
