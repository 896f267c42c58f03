"""Replay speed and memory (issue 25), each figure beside a reference measured in the same run.

Goals:

* **Replay is not slower than simulating the same run.** For ``l24-ct``, ``w20-switching`` and ``ib21-fleet-2``
  (``--quick``: ``l24-ct`` only): ``simulate(scenario, record_to=DIR)`` against ``replay(scenario,
  run_folder.steps([DIR], ...), record_to=DIR2)`` (the run-folder round trip), best of ``--repeat``. Goal: replay
  time ≤ simulation time (ratio ≤ 1). Beside them, the replay of the same flight from a ROS 2 MCAP bag
  (``rosbag.steps``, ``phases=False``; written as ``tests/replay/test_rosbag.py`` writes it: each UAV's
  ``PoseStamped`` navigation at the estimation rate, its ``PointStamped`` detections, the target's ``PoseStamped``
  truth, 5 % of the messages logged 50-300 ms late); not timed: writing the bag. Scenarios whose sensor a bag
  cannot carry (``ib21-fleet-2``'s footprint sensor) have no bag figure.
* **Reading a 1 GB bag streams in bounded memory (≤ 500 MB peak RSS).** A long synthetic ``l24-ct`` flight
  (3 UAVs circling a target at 1 m/s), written straight into a ROS 2 MCAP bag of ``--size-gb`` (default 1 GB,
  ``--quick`` 0.1 GB): per UAV ``nav_msgs/Odometry`` at 100 Hz (with a positive definite covariance, which the
  reader checks) and ``PointStamped`` detections at 20 Hz, and the target's ``PoseStamped`` truth at 100 Hz: every
  message is on a mapped topic (the readers skip unmapped topics, so padding with them would flatter the figure).
  The replay (``replay(..., record_to=DIR, phases=False)``, as ``swarmtrack replay`` does it, without the metrics
  and figures) runs in a child process whose peak RSS is read by ``os.wait4``; the reference is the peak RSS of a
  child that only imports swarmtrack and builds the scenario. The full run also replays a 0.1 GB bag: memory that
  grows with the bag shows as the difference. Throughput (messages/s, MB/s of bag) is printed beside a child that
  only reads and deserializes the same messages with rosbags (the reader library's own speed).

``--profile`` adds a cProfile of the replay of a 0.1 GB bag (the functions with the most own time).

Usage: ``python benchmarks/bench_replay.py [--quick] [--json] [--repeat 3] [--size-gb 1] [--profile]``. Times on the
2-core development machine: ``--quick`` about 70 s; the full benchmark about 11 min (6 of them the 1 GB replay).
Temporary files go to one folder under ``$TMPDIR`` (about ``--size-gb`` of disk), removed at the end and on Ctrl-C.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

MB = 1e6
SCENARIOS = ("l24-ct", "w20-switching", "ib21-fleet-2")
N_LONG, NAV_HZ, DET_HZ = 3, 100, 20  # the long synthetic flight: UAVs, Odometry rate, detection rate
POSE, POINT, ODOMETRY = "geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/PointStamped", "nav_msgs/msg/Odometry"
MEMORY_GOAL_MB = 500.0


def _typestore():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def child_env() -> dict[str, str]:
    """This process's environment with the imported ``swarmtrack`` sources first on PYTHONPATH."""
    import swarmtrack

    src = str(Path(swarmtrack.__file__).resolve().parents[1])
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([src, *filter(None, [env.get("PYTHONPATH")])])
    return env


# --- the bag of a simulated flight (as tests/replay/test_rosbag.py writes it) -------------------------------------

def _messages_of(rec, sensor_kind: str, reorder: float = 0.05, seed: int = 0) -> list:
    """``(log time, topic, type, message)`` of a simulated run with its inputs: every UAV's navigation, its
    detections (as the target relative to the UAV), the followed target's truth; logged 1-20 ms after their stamps,
    a fraction ``reorder`` 50-300 ms late."""
    from swarmtrack import registry

    relative_of = registry.resolve(registry.get("sensor", sensor_kind).measurement.relative_of)
    store = _typestore()
    t = store.types

    def header(stamp: float):
        ns = int(round(stamp * 1e9))
        return t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                                        frame_id="map")

    def point(xy):
        return t["geometry_msgs/msg/Point"](x=float(xy[0]), y=float(xy[1]), z=0.0)

    def pose(stamp: float, xy):
        return t[POSE](header=header(stamp), pose=t["geometry_msgs/msg/Pose"](
            position=point(xy), orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))

    rng = np.random.default_rng(seed)
    out = []

    def send(stamp, topic, kind, msg):
        late = rng.uniform(0.05, 0.3) if rng.random() < reorder else rng.uniform(0.001, 0.02)
        out.append((stamp + late, topic, kind, msg))

    truth = {c.k0 + j: c.truth[j] for c in rec.chunks() for j in range(len(c.t))}
    for k, now, nav, det in rec.inputs():
        for i in range(len(nav)):
            send(now, f"/uav{i + 1}/pose", POSE, pose(now, nav[i, :2]))
        taken = now if det.taken is None else det.taken
        if taken < 0:
            continue
        rel = relative_of(det)  # the detection as the target relative to the UAV
        for owner, xy in zip(det.owner, rel, strict=True):
            send(taken, f"/uav{owner + 1}/target", POINT, t[POINT](header=header(taken), point=point(xy)))
        send(now, "/target/pose", POSE, pose(now, truth[k][rec.tracked, :2]))
    out.sort(key=lambda m: m[0])
    return out


def write_bag(path: Path, messages) -> Path:
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = _typestore()
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {}
        for logged, topic, kind, msg in messages:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, kind, typestore=store)
            w.write(conns[topic], int(round(logged * 1e9)), store.serialize_cdr(msg, kind))
    return path


def simple_map(n: int):
    from swarmtrack.replay.mapping import ReplayMap

    return ReplayMap.model_validate({"uavs": {i: {"navigation": f"/uav{i}/pose", "detections": f"/uav{i}/target"}
                                              for i in range(1, n + 1)}, "truth": "/target/pose"})


# --- replay against simulation ------------------------------------------------------------------------------------

def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def replay_vs_simulate(name: str, repeat: int, tmp: Path, progress) -> dict:
    """Best-of-``repeat`` seconds of simulating ``name`` into a run folder, of replaying that folder, and of replaying
    a ROS 2 bag of the same flight (None where the scenario's sensor or estimator cannot be read from a bag)."""
    from swarmtrack import load_scenario
    from swarmtrack.replay import rosbag, run_folder
    from swarmtrack.replay.engine import replay
    from swarmtrack.replay.steps import LogError
    from swarmtrack.sim.engine import simulate

    scn = load_scenario(name)
    progress(f"{name}: warm-up (compiled kernels, caches)")
    warm = load_scenario(name, ["duration=2"])
    replay(warm, run_folder.steps([simulate(warm, record_to=tmp / "warm").path], warm, None, {}))
    shutil.rmtree(tmp / "warm")
    sims, replays, bags = [], [], []
    src = tmp / f"{name}-sim"
    for i in range(repeat):
        progress(f"{name}: simulate ({i + 1}/{repeat})")
        shutil.rmtree(src, ignore_errors=True)
        sims.append(_timed(lambda: simulate(scn, record_to=src)))
    for i in range(repeat):
        progress(f"{name}: replay the run folder ({i + 1}/{repeat})")
        dst = tmp / f"{name}-replay"
        shutil.rmtree(dst, ignore_errors=True)
        replays.append(_timed(lambda dst=dst: replay(scn, run_folder.steps([src], scn, None, {}), record_to=dst)))
        shutil.rmtree(dst)
    out = {"scenario": name, "steps": round(scn.run_duration() * scn.rates.estimation), "simulate_s": min(sims),
           "replay_s": min(replays), "ratio": min(replays) / min(sims), "bag_replay_s": None, "bag_ratio": None,
           "bag_messages": None, "bag_note": None}
    if scn.sensor.kind not in ("range_bearing", "camera"):
        out["bag_note"] = f"sensor.kind {scn.sensor.kind}: a bag carries range/bearing or camera detections only"
        shutil.rmtree(src)
        return out
    progress(f"{name}: write the flight's ROS 2 bag")
    from swarmtrack.sim.recorder import Recording

    messages = _messages_of(Recording.load(src), scn.sensor.kind)
    bag, n_messages = write_bag(tmp / f"{name}-bag", messages), len(messages)
    del messages
    mapping = simple_map(scn.swarm.n_uavs)
    try:
        for i in range(repeat):
            progress(f"{name}: replay the bag ({i + 1}/{repeat})")
            dst = tmp / f"{name}-bag-replay"
            shutil.rmtree(dst, ignore_errors=True)
            bags.append(_timed(lambda dst=dst: replay(scn, rosbag.steps([bag], scn, mapping, {}), record_to=dst,
                                                      phases=False)))
            shutil.rmtree(dst)
    except LogError as exc:
        out["bag_note"] = str(exc)
    else:
        out.update(bag_replay_s=min(bags), bag_ratio=min(bags) / min(sims), bag_messages=n_messages)
    shutil.rmtree(src)
    shutil.rmtree(bag)
    return out


# --- the long synthetic flight ----------------------------------------------------------------------------------

ENCAPSULATION = b"\x00\x01\x00\x00"  # CDR, little endian
_POSE = struct.Struct("<4sIII4s7d")
_POINT = struct.Struct("<4sIII4s3d")
_ODOMETRY = struct.Struct("<4sIII4sI10s2x7d36d6d36d")
COVARIANCE = tuple(np.diag([0.01, 0.01, 0.04, 0.001, 0.001, 0.004]).ravel())


def _pose(sec, ns, x, y) -> bytes:
    return _POSE.pack(ENCAPSULATION, sec, ns, 4, b"map\x00", x, y, 0.0, 0.0, 0.0, 0.0, 1.0)


def _point(sec, ns, x, y) -> bytes:
    return _POINT.pack(ENCAPSULATION, sec, ns, 4, b"map\x00", x, y, 0.0)


def _odometry(sec, ns, x, y, vx, vy) -> bytes:
    return _ODOMETRY.pack(ENCAPSULATION, sec, ns, 4, b"map\x00", 10, b"base_link\x00", x, y, 10.0, 0.0, 0.0, 0.0,
                          1.0, *COVARIANCE, vx, vy, 0.0, 0.0, 0.0, 0.0, *COVARIANCE)


def _check_packing() -> None:
    """The hand-packed CDR bytes are rosbags' own (field order, alignment)."""
    store = _typestore()
    t = store.types
    header = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=12, nanosec=345), frame_id="map")
    pos = t["geometry_msgs/msg/Point"](x=1.5, y=-2.0, z=0.0)
    pose = t["geometry_msgs/msg/Pose"](position=pos, orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0,
                                                                                                   z=0.0, w=1.0))
    assert bytes(store.serialize_cdr(t[POSE](header=header, pose=pose), POSE)) == _pose(12, 345, 1.5, -2.0)
    assert bytes(store.serialize_cdr(t[POINT](header=header, point=pos), POINT)) == _point(12, 345, 1.5, -2.0)
    pose.position.z = 10.0
    vec = t["geometry_msgs/msg/Vector3"]
    twist = t["geometry_msgs/msg/Twist"](linear=vec(x=0.5, y=-0.25, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0))
    odo = t[ODOMETRY](header=header, child_frame_id="base_link",
                      pose=t["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.array(COVARIANCE)),
                      twist=t["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.array(COVARIANCE)))
    assert bytes(store.serialize_cdr(odo, ODOMETRY)) == _odometry(12, 345, 1.5, -2.0, 0.5, -0.25)


def write_long_bag(path: Path, size_bytes: float) -> dict:
    """A synthetic ``l24-ct`` flight of about ``size_bytes`` in a ROS 2 MCAP bag: ``N_LONG`` UAVs 4 m apart in a line
    3 m behind a target circling at 1 m/s (radius 20 m), their Odometry at ``NAV_HZ``, their detections (the target
    relative to the UAV, 5 cm noise) at ``DET_HZ``, the target's truth at ``NAV_HZ``; messages logged 5 ms after
    their stamps, in order."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    _check_packing()
    store = _typestore()
    rng = np.random.default_rng(0)
    every = NAV_HZ // DET_HZ
    offsets = [(4.0 * (i - (N_LONG - 1) / 2), -3.0) for i in range(N_LONG)]
    omega, radius = 0.05, 20.0
    count, k, t0 = 0, 0, time.perf_counter()
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        nav = [w.add_connection(f"/uav{i + 1}/odom", ODOMETRY, typestore=store) for i in range(N_LONG)]
        det = [w.add_connection(f"/uav{i + 1}/target", POINT, typestore=store) for i in range(N_LONG)]
        truth = w.add_connection("/target/pose", POSE, typestore=store)
        file = path / f"{path.name}.mcap"
        while True:
            t = 1.0 + k / NAV_HZ
            ns = round(t * 1e9)
            sec, nsec = divmod(ns, 10**9)
            logged = ns + 5_000_000
            c, s = math.cos(omega * t), math.sin(omega * t)
            tx, ty, vx, vy = radius * c, radius * s, -radius * omega * s, radius * omega * c
            noise = rng.normal(0.0, 0.05, (N_LONG, 2)) if k % every == 0 else None
            for i, (ox, oy) in enumerate(offsets):
                ux, uy = tx + ox, ty + oy
                w.write(nav[i], logged, _odometry(sec, nsec, ux, uy, vx, vy))
                if noise is not None:
                    w.write(det[i], logged, _point(sec, nsec, tx - ux + noise[i, 0], ty - uy + noise[i, 1]))
            w.write(truth, logged, _pose(sec, nsec, tx, ty))
            count += N_LONG + 1 + (N_LONG if noise is not None else 0)
            k += 1
            if k % 2000 == 0 and file.stat().st_size >= size_bytes:
                break
    size = sum(f.stat().st_size for f in path.iterdir())
    return {"messages": count, "bytes": size, "flight_s": k / NAV_HZ, "write_s": time.perf_counter() - t0}


def long_map():
    from swarmtrack.replay.mapping import ReplayMap

    return ReplayMap.model_validate({"uavs": {i: {"navigation": f"/uav{i}/odom", "detections": f"/uav{i}/target"}
                                              for i in range(1, N_LONG + 1)}, "truth": "/target/pose"})


# --- the child processes (peak RSS read by the parent) ----------------------------------------------------------

def child(mode: str, bag: str | None, out: str | None, profile: str | None) -> None:
    """``reference``: import swarmtrack, build the scenario; ``read``: read and deserialize the bag's messages with
    rosbags; ``replay``: replay the bag with l24-ct into the run folder ``out``. Prints one JSON line."""
    from swarmtrack import load_scenario
    from swarmtrack.sim.build import build

    scn = load_scenario("l24-ct")
    build(scn)
    res: dict = {}
    if mode == "read":
        from rosbags.highlevel import AnyReader

        t0, n = time.perf_counter(), 0
        with AnyReader([Path(bag)], default_typestore=_typestore()) as reader:
            for connection, _logged, raw in reader.messages():
                reader.deserialize(raw, connection.msgtype)
                n += 1
        res = {"wall": time.perf_counter() - t0, "messages": n}
    elif mode == "replay":
        from swarmtrack.replay import rosbag
        from swarmtrack.replay.engine import replay

        counts: dict = {}
        steps = [0]

        def counted(it):
            for s in it:
                steps[0] += 1
                yield s

        def run():
            replay(scn, counted(rosbag.steps([Path(bag)], scn, long_map(), counts)), record_to=Path(out),
                   phases=False)

        t0 = time.perf_counter()
        if profile:
            import cProfile

            cProfile.runctx("run()", globals(), {"run": run}, profile)
        else:
            run()
        res = {"wall": time.perf_counter() - t0, "steps": steps[0], "skipped": counts}
    print(json.dumps(res))


# A fresh wrapper process whose only child is the command: its RUSAGE_CHILDREN maxrss is the command's peak (a child
# forked straight from this process would count this process's own RSS: Linux keeps the peak across fork and exec).
# argv[1] = JSON [command, stdout file, stderr file]; prints one JSON line.
_WRAPPER = """\
import json, resource, subprocess, sys
cmd, out, err = json.loads(sys.argv[1])
with open(out, "w") as fo, open(err, "w") as fe:
    code = subprocess.run(cmd, stdout=fo, stderr=fe).returncode
print(json.dumps({"returncode": code, "maxrss_kb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss}))
"""


def run_child(args: list[str], tmp: Path) -> dict:
    """Run ``child`` with ``args`` under the wrapper; its JSON line plus its peak RSS (MB)."""
    out, err = tmp / "child.out", tmp / "child.err"
    cmd = [sys.executable, __file__, "--child", *args]
    p = subprocess.run([sys.executable, "-c", _WRAPPER, json.dumps([cmd, str(out), str(err)])], capture_output=True,
                       text=True, env=child_env())
    if p.returncode != 0:
        raise RuntimeError(f"the memory wrapper failed (exit {p.returncode}): {p.stderr.strip()[-500:]}")
    wrapped = json.loads(p.stdout.strip().splitlines()[-1])
    if wrapped["returncode"] != 0:
        raise RuntimeError(f"child {args[0]} failed (exit {wrapped['returncode']}): "
                           f"{err.read_text().strip().splitlines()[-1:]}")
    res = json.loads(out.read_text().strip().splitlines()[-1])
    res["peak_rss_mb"] = wrapped["maxrss_kb"] * 1024 / MB  # Linux: KiB
    return res


def streaming(size_gb: float, tmp: Path, progress, label: str) -> dict:
    """Write a long bag of ``size_gb``, replay it and read it in children; the peak RSS and speeds."""
    bag = tmp / f"long-{label}"
    progress(f"write a {size_gb:g} GB bag of a long synthetic flight")
    info = write_long_bag(bag, size_gb * 1e9)
    try:
        progress(f"replay the {info['bytes'] / 1e9:.2f} GB bag ({info['messages']:,} messages) in a child")
        rep = run_child(["replay", str(bag), str(tmp / "replayed")], tmp)
        shutil.rmtree(tmp / "replayed", ignore_errors=True)
        progress("read the same bag with rosbags only, in a child")
        read = run_child(["read", str(bag)], tmp)
    finally:
        shutil.rmtree(bag, ignore_errors=True)
    mb = info["bytes"] / MB
    return {"bag_mb": mb, "messages": info["messages"], "flight_s": info["flight_s"], "write_s": info["write_s"],
            "replay_s": rep["wall"], "steps": rep["steps"], "skipped": rep["skipped"],
            "peak_rss_mb": rep["peak_rss_mb"], "messages_per_s": info["messages"] / rep["wall"],
            "mb_per_s": mb / rep["wall"], "read_only_s": read["wall"], "read_only_peak_rss_mb": read["peak_rss_mb"],
            "read_only_messages_per_s": read["messages"] / read["wall"], "read_only_mb_per_s": mb / read["wall"]}


def profile_replay(tmp: Path, progress, top: int = 20) -> list[dict]:
    """cProfile of a 0.1 GB bag's replay: the functions with the most own time, and their share of the total."""
    import pstats

    bag = tmp / "long-profile"
    progress("profile: write a 0.1 GB bag")
    write_long_bag(bag, 0.1e9)
    try:
        progress("profile: replay it under cProfile")
        run_child(["replay", str(bag), str(tmp / "replayed"), "--profile-to", str(tmp / "prof")], tmp)
    finally:
        shutil.rmtree(bag, ignore_errors=True)
        shutil.rmtree(tmp / "replayed", ignore_errors=True)
    stats = pstats.Stats(str(tmp / "prof"))
    total = stats.total_tt
    rows = sorted(stats.stats.items(), key=lambda kv: kv[1][2], reverse=True)[:top]
    src = str(Path(__file__).resolve().parents[1])
    return [{"function": f"{Path(file).name if not file.startswith(src) else os.path.relpath(file, src)}:{line}"
                         f"({func})", "calls": nc, "own_share": tt / total, "cumulative_share": ct / total}
            for (file, line, func), (_cc, nc, tt, ct, _callers) in rows]


# --- output ------------------------------------------------------------------------------------------------------

def print_table(results: dict) -> None:
    def s(x):
        return "-" if x is None else f"{x:.2f} s"

    print("replay against simulation of the same run (best of "
          f"{results['repeat']}; goal: replay ≤ simulate, ratio ≤ 1)")
    print(f"  {'scenario':14s} {'steps':>6s} {'simulate':>10s} {'replay run':>11s} {'ratio':>6s} {'':8s}"
          f"{'replay bag':>11s} {'ratio':>6s}")
    for r in results["replay_vs_simulate"]:
        verdict = "met" if r["ratio"] <= 1 else "NOT MET"
        bag_ratio = "-" if r["bag_ratio"] is None else f"{r['bag_ratio']:.2f}"
        print(f"  {r['scenario']:14s} {r['steps']:6d} {s(r['simulate_s']):>10s} {s(r['replay_s']):>11s} "
              f"{r['ratio']:6.2f} {verdict:8s}{s(r['bag_replay_s']):>11s} {bag_ratio:>6s}")
        if r["bag_note"]:
            print(f"    (no bag replay: {r['bag_note']})")
    ref = results["reference_peak_rss_mb"]
    print(f"\nstreaming a long bag (goal: peak RSS ≤ {MEMORY_GOAL_MB:.0f} MB); reference: a child that imports "
          f"swarmtrack and builds l24-ct peaks at {ref:.0f} MB")
    for r in results["streaming"]:
        verdict = "met" if r["peak_rss_mb"] <= MEMORY_GOAL_MB else "NOT MET"
        print(f"  {r['bag_mb']:.0f} MB bag, {r['messages']:,} messages, {r['flight_s']:.0f} s of flight "
              f"({r['steps']:,} estimation steps; written in {r['write_s']:.0f} s)")
        print(f"    replay: peak RSS {r['peak_rss_mb']:.0f} MB ({verdict}; {r['peak_rss_mb'] - ref:+.0f} MB over the "
              f"reference), {r['replay_s']:.1f} s: {r['messages_per_s']:,.0f} messages/s, {r['mb_per_s']:.1f} MB/s")
        print(f"    rosbags reading and deserializing the same messages: {r['read_only_s']:.1f} s: "
              f"{r['read_only_messages_per_s']:,.0f} messages/s, {r['read_only_mb_per_s']:.1f} MB/s, peak RSS "
              f"{r['read_only_peak_rss_mb']:.0f} MB")
        print(f"    simulated flight time over replay time: {r['flight_s'] / r['replay_s']:.0f}× real time")
        if r["skipped"]:
            print(f"    skipped: {r['skipped']}")
    if results.get("profile"):
        print("\nprofile of the replay of a 0.1 GB bag (own time, share of the total):")
        for p in results["profile"]:
            print(f"  {100 * p['own_share']:5.1f} % own {100 * p['cumulative_share']:5.1f} % cum "
                  f"{p['calls']:>9,d} calls  {p['function']}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json", action="store_true", help="print one JSON object of the figures instead")
    ap.add_argument("--quick", action="store_true", help="l24-ct only, one repeat, a 0.1 GB bag (under a minute)")
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs for the timings (default 3)")
    ap.add_argument("--size-gb", type=float, default=1.0, help="size of the long bag (default 1 GB)")
    ap.add_argument("--scenarios", nargs="+", default=list(SCENARIOS), metavar="NAME")
    ap.add_argument("--profile", action="store_true", help="add a cProfile of a 0.1 GB bag's replay")
    ap.add_argument("--child", nargs="+", help=argparse.SUPPRESS)
    ap.add_argument("--profile-to", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        mode, *paths = args.child
        child(mode, *(paths + [None, None])[:2], args.profile_to)
        return 0
    if args.quick:
        args.repeat, args.size_gb, args.scenarios = 1, 0.1, ["l24-ct"]

    start = time.perf_counter()

    def progress(msg: str) -> None:  # on stderr, with the time since the start
        print(f"[{time.perf_counter() - start:6.0f} s] {msg}", file=sys.stderr, flush=True)

    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))  # clean up the temporary folder on kill too
    tmp = Path(tempfile.mkdtemp(prefix="bench-replay-"))
    try:
        free = shutil.disk_usage(tmp).free
        if free < 1.5 * args.size_gb * 1e9 + 1e9:
            raise SystemExit(f"{tmp}: {free / 1e9:.1f} GB free, the {args.size_gb:g} GB bag needs about "
                             f"{1.5 * args.size_gb + 1:.1f} GB")
        results: dict = {"repeat": args.repeat, "load_average_1min": os.getloadavg()[0],
                         "replay_vs_simulate": [replay_vs_simulate(name, args.repeat, tmp, progress)
                                                for name in args.scenarios]}
        progress("reference child: import swarmtrack, build l24-ct")
        results["reference_peak_rss_mb"] = run_child(["reference"], tmp)["peak_rss_mb"]
        sizes = [args.size_gb] if args.quick or args.size_gb <= 0.1 else [0.1, args.size_gb]
        results["streaming"] = [streaming(size, tmp, progress, f"{size:g}") for size in sizes]
        if args.profile:
            results["profile"] = profile_replay(tmp, progress)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    results["wall_s"] = time.perf_counter() - start
    progress("done")
    if args.json:
        print(json.dumps(results, indent=1))
    else:
        print(f"1-min load average at start {results['load_average_1min']:.2f} on {os.cpu_count()} cores")
        print_table(results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
