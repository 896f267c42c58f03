"""The Foxglove view (:mod:`swarmtrack.streams.foxglove`): what a client of foxglove-sdk's WebSocket server receives
and what an MCAP file holds are the recording's numbers, decoded here from the wire per the advertised schemas.

The client speaks Foxglove's WebSocket protocol with the ``websockets`` library (serverInfo, advertise, subscribe,
binary messageData). foxglove-sdk's server (0.30) names it ``foxglove.sdk.v1`` and refuses the older name
``foxglove.websocket.v1`` of the same protocol (HTTP 400 at the handshake); protobuf payloads are decoded with
the FileDescriptorSet the server advertises (a small reader of protobuf's wire format below, so the tests need no
protobuf package), JSON ones with ``json``. Loopback only, free ports, and every wait has a timeout.
"""

from __future__ import annotations

import base64
import dataclasses
import json
import math
import socket
import struct
import time
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from websockets.sync.client import connect

from swarmtrack.outputs import OutputError
from swarmtrack.scenarios.loader import load_scenario
from swarmtrack.sim.engine import simulate
from swarmtrack.streams import foxglove as fx
from swarmtrack.streams.frame import frames

TIMEOUT = 10.0  # s: a bound on every wait (the whole exchange takes well under a second)
EPOCH = 1_700_000_000  # stamp_epoch of the tests: log time = EPOCH s + the run's time
TOL = 1e-9
SUBPROTOCOL = "foxglove.sdk.v1"
#: The topics of an l24-ct run: its scene, the errors computed and the filter's NIS recorded.
TOPICS = ("/scene", "/plot/error", "/plot/nees", "/plot/nis")


@pytest.fixture(scope="module")
def rec():
    return simulate(load_scenario("l24-ct", ["duration=2"]))


@pytest.fixture(scope="module")
def steps(rec):
    return list(frames(rec))


# --- protobuf's wire format, read by the FileDescriptorSet a channel advertises --------------------------------------

def _varint(buf: bytes, i: int) -> tuple[int, int]:
    shift = value = 0
    while True:
        byte = buf[i]
        i += 1
        value |= (byte & 0x7F) << shift
        if byte < 0x80:
            return value, i
        shift += 7


def _wire(buf: bytes):
    """``(field number, wire type, raw value)`` of each field of a protobuf message."""
    i = 0
    while i < len(buf):
        key, i = _varint(buf, i)
        number, wire = key >> 3, key & 7
        if wire == 0:
            value, i = _varint(buf, i)
        elif wire == 1:
            value, i = buf[i:i + 8], i + 8
        elif wire == 2:
            n, i = _varint(buf, i)
            value, i = buf[i:i + n], i + n
        elif wire == 5:
            value, i = buf[i:i + 4], i + 4
        else:
            raise ValueError(f"wire type {wire}")
        yield number, wire, value


def descriptors(file_descriptor_set: bytes) -> dict[str, dict[int, tuple[str, int, str, bool]]]:
    """Every message type of a FileDescriptorSet: ``.package.Name → field number → (name, type, type name,
    repeated)`` (descriptor.proto: FileDescriptorSet.file 1; FileDescriptorProto.package 2, message_type 4;
    DescriptorProto.name 1, field 2, nested_type 3; FieldDescriptorProto.name 1, number 3, label 4, type 5,
    type_name 6)."""
    types: dict[str, dict[int, tuple[str, int, str, bool]]] = {}

    def walk(desc: bytes, scope: str) -> None:
        parts = list(_wire(desc))
        full = f"{scope}.{next(v.decode() for n, _, v in parts if n == 1)}"
        fields = types[full] = {}
        for n, _, v in parts:
            if n == 2:
                f = {k: val for k, _, val in _wire(v)}
                fields[f[3]] = (f[1].decode(), f[5], f.get(6, b"").decode(), f.get(4) == 3)
            elif n == 3:
                walk(v, full)

    for n, _, file in _wire(file_descriptor_set):
        if n == 1:
            parts = list(_wire(file))
            package = next((v.decode() for k, _, v in parts if k == 2), "")
            for k, _, v in parts:
                if k == 4:
                    walk(v, f".{package}" if package else "")
    return types


_FIXED = {1: "<d", 2: "<f", 6: "<Q", 7: "<I", 15: "<i", 16: "<q"}


def decode(types: dict, name: str, buf: bytes) -> dict:
    """Message ``name`` (``.package.Name``) from its protobuf bytes: a dict of the fields present (proto3 leaves
    out zeros: read absent numbers as 0)."""
    out: dict = {}
    for number, wire, raw in _wire(buf):
        if number not in types[name]:
            continue
        field, kind, type_name, repeated = types[name][number]
        if kind == 11:
            values = [decode(types, type_name, raw)]
        elif kind == 9:
            values = [raw.decode()]
        elif kind == 12:
            values = [raw]
        elif kind in _FIXED:
            fmt = _FIXED[kind]
            values = [v for (v,) in struct.iter_unpack(fmt, raw)] if wire == 2 else [struct.unpack(fmt, raw)[0]]
        elif wire == 2:  # packed varints
            values, i = [], 0
            while i < len(raw):
                v, i = _varint(raw, i)
                values.append(v)
        else:
            values = [raw]
        if repeated:
            out.setdefault(field, []).extend(values)
        else:
            out[field] = values[0]
    return out


def _xyz(v: dict) -> tuple[float, float, float]:
    return v.get("x", 0.0), v.get("y", 0.0), v.get("z", 0.0)


# --- a Foxglove WebSocket client ------------------------------------------------------------------------------------

def watch(view: fx.FoxgloveView, feed) -> tuple[dict[str, dict], list[tuple[str, int, bytes]]]:
    """Connect to ``view``, subscribe to every channel it advertises, wait until the server has the
    subscriptions, run ``feed()``, then take messages until none comes for 0.5 s: the advertised channels
    (topic → advertisement) and ``(topic, log time, payload)`` in the order received."""
    deadline = time.monotonic() + TIMEOUT
    with connect(view.url, subprotocols=[SUBPROTOCOL], open_timeout=TIMEOUT, close_timeout=2,
                 max_queue=None) as ws:
        info = json.loads(ws.recv(timeout=TIMEOUT))
        assert info["op"] == "serverInfo"
        channels: dict[str, dict] = {}
        while set(TOPICS) - set(channels):
            msg = json.loads(ws.recv(timeout=max(0.01, deadline - time.monotonic())))
            if msg["op"] == "advertise":
                channels.update({c["topic"]: c for c in msg["channels"]})
        by_sub = dict(enumerate(channels))
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": i, "channelId": channels[topic]["id"]}
                                                                  for i, topic in by_sub.items()]}))
        while view.watched() != set(channels):
            assert time.monotonic() < deadline, f"the server has {view.watched()} of {set(channels)} subscribed"
            time.sleep(0.005)
        feed()
        got = []
        while True:
            try:
                data = ws.recv(timeout=0.5)
            except TimeoutError:
                break
            assert time.monotonic() < deadline + TIMEOUT
            if isinstance(data, bytes):
                assert data[0] == 1  # messageData
                sub, log_time = struct.unpack_from("<IQ", data, 1)
                got.append((by_sub[sub], log_time, data[13:]))
    return channels, got


def _log_time(t: float) -> int:
    return EPOCH * 1_000_000_000 + round(t * 1e9)


@pytest.fixture(scope="module")
def live(rec, steps, tmp_path_factory):
    """A view serving on a free port and writing an MCAP beside, every step sent while a client watched."""
    path = tmp_path_factory.mktemp("live") / "live.mcap"
    view = fx.FoxgloveView(port=0, mcap=path, rate=None, stamp_epoch=EPOCH)
    view.open(rec.meta)
    try:
        channels, got = watch(view, lambda: [view.send(f) for f in steps])
    finally:
        view.close()
    return channels, got, path


def read_mcap(path: Path) -> tuple[dict[str, tuple[str, str, bytes]], list[tuple[str, int, bytes]]]:
    """An MCAP file's channels (topic → message encoding, schema name, schema data) and its messages."""
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        channels = {c.topic: (c.message_encoding, summary.schemas[c.schema_id].name, summary.schemas[c.schema_id].data)
                    for c in summary.channels.values()}
        messages = [(ch.topic, m.log_time, m.data) for _, ch, m in reader.iter_messages(log_time_order=True)]
    return channels, messages


# --- what the recording says, checked against what came -------------------------------------------------------------

def check_scene(scene: dict, frame, log_time: int) -> None:
    """A decoded ``/scene`` SceneUpdate against ``frame``: the UAVs' positions and numbers, the target, each
    estimate's centre and its 95 % ellipse (axes from numpy's eigen-decomposition, and the block rebuilt from
    the axes and the rotation), all to 1e-9."""
    entities = {e["id"]: e for e in scene["entities"]}
    assert set(entities) == {"uavs", "target", "estimates", "sets", "formation"}
    for e in entities.values():
        assert e["frame_id"] == "map"
        assert e["timestamp"].get("seconds", 0) * 1_000_000_000 + e["timestamp"].get("nanos", 0) == log_time
    shown = frame.present & np.isfinite(frame.uav[:, :2]).all(axis=1)
    uavs = entities["uavs"]
    np.testing.assert_allclose([_xyz(s["pose"]["position"]) for s in uavs["spheres"]],
                               np.column_stack([frame.uav[shown, :2], np.zeros(shown.sum())]), atol=TOL, rtol=0)
    assert [t["text"] for t in uavs["texts"]] == [str(n) for n in frame.uavs[shown]]
    np.testing.assert_allclose(_xyz(entities["target"]["spheres"][0]["pose"]["position"]),
                               [*frame.target[:2], 0.0], atol=TOL, rtol=0)
    spheres = entities["estimates"]["spheres"]
    centres = [s for s in spheres if _xyz(s["size"])[2] == fx.CENTRE_SIZE]
    ellipses = [s for s in spheres if _xyz(s["size"])[2] == fx.ELLIPSE_THICKNESS]
    has = frame.present & np.isfinite(frame.estimate[:, :2]).all(axis=1)
    np.testing.assert_allclose([_xyz(s["pose"]["position"])[:2] for s in centres], frame.estimate[has, :2],
                               atol=TOL, rtol=0)
    np.testing.assert_allclose([_xyz(s["pose"]["position"])[:2] for s in ellipses], frame.estimate[has, :2],
                               atol=TOL, rtol=0)
    for s, block in zip(ellipses, frame.covariance[has, :2, :2], strict=True):
        a, b, thickness = (v / 2 for v in _xyz(s["size"]))
        eig = np.linalg.eigvalsh(block)
        np.testing.assert_allclose([a, b], np.sqrt(fx.CHI2_2D * eig[::-1]), atol=TOL, rtol=0)
        q = s["pose"]["orientation"]
        angle = 2.0 * math.atan2(q.get("z", 0.0), q.get("w", 0.0))
        rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
        np.testing.assert_allclose(rot @ np.diag([a * a, b * b]) @ rot.T / fx.CHI2_2D, block, atol=TOL, rtol=0)


def check_plot(message: dict, frame, name: str) -> None:
    assert message["t"] == frame.t
    values = frame.plots[name]
    ok = frame.present & np.isfinite(values)
    assert set(message) - {"t"} == {f"uav{n}" for n in frame.uavs[ok]}
    np.testing.assert_allclose([message[f"uav{n}"] for n in frame.uavs[ok]], values[ok], atol=TOL, rtol=0)


def check_messages(messages, schemas: dict[str, tuple[str, bytes]], steps) -> None:
    """``(topic, log time, payload)`` of every step on ``/scene``, ``/plot/error`` and ``/plot/nees``, decoded per
    ``schemas`` (topic → (encoding, schema)) and checked against ``steps``."""
    by_time = {_log_time(f.t): f for f in steps}
    seen = {topic: 0 for topic in TOPICS}
    types = descriptors(schemas["/scene"][1])
    assert schemas["/scene"][0] == "protobuf"
    for topic, log_time, payload in messages:
        frame = by_time[log_time]
        seen[topic] += 1
        if topic == "/scene":
            check_scene(decode(types, ".foxglove.SceneUpdate", payload), frame, log_time)
        else:
            assert schemas[topic][0] == "json"
            check_plot(json.loads(payload), frame, topic.removeprefix("/plot/"))
    assert seen == dict.fromkeys(seen, len(steps))


# --- the tests ------------------------------------------------------------------------------------------------------

def test_a_websocket_client_receives_every_step_as_the_recording_has_it(live, steps):
    channels, got, _ = live
    assert channels["/scene"]["schemaName"] == "foxglove.SceneUpdate"
    assert channels["/plot/error"]["encoding"] == "json"
    schemas = {t: (c["encoding"], base64.b64decode(c["schema"]) if c["encoding"] == "protobuf" else c["schema"])
               for t, c in channels.items()}
    check_messages(got, schemas, steps)
    assert json.loads(schemas["/plot/error"][1])["properties"].keys() == {"t", "uav1", "uav2", "uav3"}


def test_the_mcap_written_beside_the_live_view_holds_the_same_messages_byte_for_byte(live):
    _, got, path = live
    channels, messages = read_mcap(path)
    assert set(channels) == set(TOPICS)
    assert sorted(messages) == sorted(got)
    assert not [p.name for p in path.parent.iterdir() if p != path]  # its temporary file renamed, nothing else


def test_write_mcap_writes_every_step_through_the_live_views_channels(rec, steps, live, tmp_path):
    path = tmp_path / "run.mcap"
    assert fx.write_mcap(rec, path, stamp_epoch=EPOCH) == len(steps)
    assert [p.name for p in tmp_path.iterdir()] == ["run.mcap"]
    channels, messages = read_mcap(path)
    check_messages(messages, {t: (enc, data) for t, (enc, _, data) in channels.items()}, steps)
    assert {t: name for t, (_, name, _) in channels.items()} == {
        "/scene": "foxglove.SceneUpdate", "/plot/error": "swarmtrack.plot.error", "/plot/nees": "swarmtrack.plot.nees",
        "/plot/nis": "swarmtrack.plot.nis"}
    assert sorted(messages) == sorted(read_mcap(live[2])[1])  # what the live view's MCAP holds, byte for byte


def test_absent_uavs_and_nan_values_are_left_out(rec, steps, tmp_path):
    frame = steps[10]
    uav, estimate = frame.uav.copy(), frame.estimate.copy()
    uav[2, 0] = np.nan  # UAV 3's position unknown
    estimate[0, 1] = np.nan  # UAV 1's estimate diverged
    holed = dataclasses.replace(frame, uav=uav, estimate=estimate, present=np.array([True, False, True]),
                                plots={**frame.plots, "latency_ms": np.array([5.0, 7.0, np.nan])})
    view = fx.FoxgloveView(server=False, mcap=tmp_path / "v.mcap", stamp_epoch=EPOCH)
    view.open(rec.meta)
    view.send(holed)
    view.close()
    channels, messages = read_mcap(tmp_path / "v.mcap")
    got = {topic: payload for topic, _, payload in messages}
    scene = decode(descriptors(channels["/scene"][2]), ".foxglove.SceneUpdate", got["/scene"])
    check_scene(scene, holed, _log_time(frame.t))
    entities = {e["id"]: e for e in scene["entities"]}
    assert [t["text"] for t in entities["uavs"]["texts"]] == ["1"]  # 2 absent, 3 unknown
    assert len(entities["estimates"]["spheres"]) == 2  # UAV 3's centre and ellipse: 1 diverged, 2 absent
    assert json.loads(got["/plot/latency_ms"]) == {"t": frame.t, "uav1": 5.0}  # a driver's series, NaN left out
    check_plot(json.loads(got["/plot/error"]), holed, "error")


def test_sets_are_line_loops_and_the_formation_points(rec, steps, tmp_path):
    square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    frame = dataclasses.replace(steps[0], polygons=[(0, square), (2, square + 5.0), (3, np.full((3, 2), np.nan))],
                                formation=np.array([[1.0, 1.0], [np.nan, 0.0], [3.0, -1.0]]))
    path = tmp_path / "sets.mcap"
    view = fx.FoxgloveView(server=False, mcap=path, stamp_epoch=EPOCH)
    view.open(rec.meta)
    view.send(frame)
    view.close()
    channels, messages = read_mcap(path)
    scene = decode(descriptors(channels["/scene"][2]), ".foxglove.SceneUpdate",
                   next(p for t, _, p in messages if t == "/scene"))
    entities = {e["id"]: e for e in scene["entities"]}
    lines = entities["sets"]["lines"]
    assert [line.get("type", 0) for line in lines] == [1, 1]  # LINE_LOOP; the set without a finite vertex left out
    for line, expected in zip(lines, [square, square + 5.0], strict=True):
        np.testing.assert_allclose([_xyz(p)[:2] for p in line["points"]], expected, atol=TOL, rtol=0)
    assert lines[0]["color"] != lines[1]["color"]  # the swarm's set and a UAV's
    np.testing.assert_allclose([_xyz(s["pose"]["position"])[:2] for s in entities["formation"]["spheres"]],
                               [[1.0, 1.0], [3.0, -1.0]], atol=TOL, rtol=0)


def test_ellipse_axes_are_numpys_eigen_decomposition_at_95_percent():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(20, 4, 4))
    cov = a @ a.transpose(0, 2, 1)
    cov[0, :2, :2] = [[4.0, 0.0], [0.0, 1.0]]  # axis-aligned, major along x
    cov[1, :2, :2] = [[1.0, 0.0], [0.0, 4.0]]  # major along y
    cov[2, :2, :2] = [[2.0, 0.0], [0.0, 2.0]]  # a circle
    major, minor, angle = fx.ellipse_axes(cov)
    w, v = np.linalg.eigh(cov[:, :2, :2])
    np.testing.assert_allclose(major, np.sqrt(fx.CHI2_2D * w[:, 1]), rtol=1e-12)
    np.testing.assert_allclose(minor, np.sqrt(fx.CHI2_2D * w[:, 0]), rtol=1e-12)
    direction = np.column_stack([np.cos(angle), np.sin(angle)])
    assert np.allclose(np.abs(np.einsum("ni,ni->n", direction[3:], v[3:, :, 1])), 1.0, atol=1e-9)
    np.testing.assert_allclose(angle[:2], [0.0, np.pi / 2], atol=1e-12)
    assert fx.CHI2_2D == pytest.approx(5.991464547107979, rel=1e-12)  # χ²₂ at 0.95


def test_a_port_in_use_is_an_error_naming_it_and_leaves_nothing_behind(rec, tmp_path):
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        view = fx.FoxgloveView(port=port, mcap=tmp_path / "run.mcap")
        with pytest.raises(fx.PortInUse, match=f"127.0.0.1:{port} is in use"):
            view.open(rec.meta)
    assert list(tmp_path.iterdir()) == []  # the MCAP's temporary file removed
    view.close()


def test_close_is_idempotent_and_a_closed_or_unopened_view_ignores_steps(rec, steps, tmp_path):
    view = fx.FoxgloveView(port=0, mcap=tmp_path / "run.mcap")
    view.close()  # before open
    view.send(steps[0])
    view.open(rec.meta)
    view.send(steps[0])
    view.close()
    view.close()
    view.send(steps[1])
    assert [p.name for p in tmp_path.iterdir()] == ["run.mcap"]
    assert len(read_mcap(tmp_path / "run.mcap")[1]) == len(TOPICS)


def test_with_no_client_subscribed_a_step_builds_no_message(rec, steps, monkeypatch):
    def refuse(*args):
        raise AssertionError("a message was built for nobody")

    monkeypatch.setattr(fx._Scene, "update", refuse)
    monkeypatch.setattr(fx, "plot_message", refuse)
    view = fx.FoxgloveView(port=0, rate=None)
    view.open(rec.meta)
    try:
        for frame in steps:
            view.send(frame)
        assert view.watched() == set()
    finally:
        view.close()


def test_the_rate_cap_thins_the_live_view_and_not_the_mcap(rec, steps, tmp_path):
    view = fx.FoxgloveView(port=0, mcap=tmp_path / "run.mcap", rate=1e-3, stamp_epoch=EPOCH)  # one step in 1000 s
    view.open(rec.meta)
    try:
        _, got = watch(view, lambda: [view.send(f) for f in steps])
    finally:
        view.close()
    assert sorted(topic for topic, _, _ in got) == sorted(TOPICS)  # the first step only
    assert len(read_mcap(tmp_path / "run.mcap")[1]) == len(TOPICS) * len(steps)


def test_the_rate_cap_says_yes_at_most_rate_times_a_second():
    now = [0.0]
    cap = fx.RateCap(10.0, clock=lambda: now[0])
    yes = []
    for _ in range(100):  # 1 s in steps of 10 ms
        yes.append(cap.due())
        now[0] += 0.01
    assert sum(yes) == 10 and yes[0]
    assert all(fx.RateCap(None).due() for _ in range(3))
    with pytest.raises(ValueError, match="rate 0"):
        fx.RateCap(0)


def test_an_existing_mcap_is_never_replaced_and_a_failed_export_leaves_nothing(rec, tmp_path, monkeypatch):
    kept = tmp_path / "kept.mcap"
    kept.write_bytes(b"mine")
    with pytest.raises(OutputError, match="already there"):
        fx.write_mcap(rec, kept)
    with pytest.raises(OutputError, match="already there"):
        fx.FoxgloveView(server=False, mcap=kept).open(rec.meta)
    assert kept.read_bytes() == b"mine"

    def broken(recording):
        yield from list(frames(recording))[:3]
        raise KeyboardInterrupt

    monkeypatch.setattr(fx, "frames", broken)
    with pytest.raises(KeyboardInterrupt):
        fx.write_mcap(rec, tmp_path / "new.mcap")
    assert [p.name for p in tmp_path.iterdir()] == ["kept.mcap"]


def test_a_view_needs_its_server_or_a_file():
    with pytest.raises(ValueError, match="server, an MCAP file, or both"):
        fx.FoxgloveView(server=False)
