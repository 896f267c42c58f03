"""The live swarm's speed (issue 23), each figure beside a reference measured in the same run.

* **One hop**: a message from one process to a callback in another, through swarmtrack's stack (msgspec encoding,
  HMAC seal, the mailbox a process waits on), as half a ping-pong round trip; the reference is the raw Zenoh
  ping-pong (bytes out, bytes back) between the same two processes. Goal: median ≤ 2× the raw one.
* **Lockstep ``l24-ct`` with 5 UAV processes**: simulated time over wall time of the step loop (start-up apart,
  printed too), against the simulator's own speed on the same scenario in this process. Goal: ≥ 5× real time.
* **MAVLink round trip** (issue 24): a setpoint sent by the UAV's link until the navigation that reflects it comes
  back from a vehicle process that answers at once, beside the Zenoh hop above; and lockstep ``l24-ct`` with every UAV
  flying through a simulated autopilot (``--mavlink``): its speed and the CPU per UAV process per step, beside the
  Zenoh-only run.
* **Real time ``l24-ct`` with 10 UAV processes for 60 s**: how late after its time each UAV's step was done (goal: not
  more than one period at the 99th percentile), the world's own lateness, the share latency beside the one-hop
  figure, the messages that missed their deadlines, and the CPU time of a UAV's process per estimation step (median,
  from each process's own accounting; start-up apart): what a companion computer must afford.

With ``--tls DIR`` (a folder of ``ca.pem``, ``cert.pem``, ``key.pem``, made as docs/live.md says) every Zenoh link
of the figures above is mutual TLS (``tls/127.0.0.1:PORT``): the cost of confidentiality.

Usage: ``python benchmarks/bench_live.py [--uavs 5] [--duration 30] [--realtime-uavs 10] [--realtime-duration 60]
[--hops 2000] [--quick] [--tls DIR] [--json]``.
"""

from __future__ import annotations

import argparse
import json
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from swarmtrack.autopilot.endpoint import free_base
from swarmtrack.live import wire
from swarmtrack.live.node import Node
from swarmtrack.live.transport import ZenohTransport, free_port, key

SWARM = "bench"

#: The TLS folder (``--tls``), or None: plain TCP.
TLS: Path | None = None


def _endpoint(port: int) -> str:
    return f"{'tcp' if TLS is None else 'tls'}/127.0.0.1:{port}"


def _echo(port: int, raw: bool) -> None:
    """The far side of the ping-pong (a process of its own): echo raw bytes, or answer each sealed ping."""
    transport = ZenohTransport(connect=[_endpoint(port)], tls=TLS)
    if raw:
        transport.subscribe("bench/ping", lambda k, data: transport.put("bench/pong", data))
    else:
        node = Node(transport, wire.Seal(KEY, 2), SWARM, 1)

        def answer(msg_key: str, data: bytes) -> None:
            msg = node.seal.open(msg_key, data)
            node.send(1, wire.Share(k=msg.k, payloads=msg.payloads))

        transport.subscribe(key(SWARM, "uav", 0, "share"), answer)
    time.sleep(3600)


KEY = bytes(range(32))


def _vehicle_echo(port: int) -> None:
    """The far side of the MAVLink round trip (a process of its own): a simulated vehicle that answers each setpoint
    at once with a navigation message stamped with the setpoint's time."""
    import select

    from swarmtrack.autopilot.vehicle import MavlinkVehicle

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        local = s.getsockname()[1]
    vehicle, answered = MavlinkVehicle(0, port, local_port=local, gcs=False), -1
    while True:
        select.select(vehicle.sockets(), [], [], 0.5)
        vehicle.poll(0.0)
        if vehicle.setpoint_ms != answered:
            answered = vehicle.setpoint_ms
            vehicle.publish(answered / 1000, np.zeros(4))


def mavlink_round_trip(trips: int) -> dict:
    """Median and 99th percentile (µs) of a setpoint sent over MAVLink until the navigation that reflects it comes
    back (a vehicle process answering at once)."""
    from swarmtrack.autopilot.link import AutopilotLink

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    far = subprocess.Popen([sys.executable, __file__, "--vehicle-echo", str(port)])
    try:
        link = AutopilotLink(f"udp://127.0.0.1:{port}", 0, timeout=30)
        rtt = []
        for i in range(1, trips + 201):  # the first 200 warm up
            t0 = time.perf_counter()
            link.send_acceleration(np.ones(2), i / 1000)
            link.navigation(i - 1, timeout=5.0)
            if i > 200:
                rtt.append(time.perf_counter() - t0)
        link.close()
    finally:
        far.kill()
        far.wait()
    us = np.asarray(rtt) * 1e6
    return {"median_us": float(np.median(us)), "p99_us": float(np.percentile(us, 99))}


def ping_pong(hops: int) -> dict:
    """Median and 99th percentile of one hop (µs), raw Zenoh and through swarmtrack's stack."""
    out = {}
    for raw in (True, False):
        port = free_port()
        transport = ZenohTransport(listen=[_endpoint(port)], tls=TLS)
        far = subprocess.Popen([sys.executable, __file__, "--echo", str(port), "--raw" if raw else "--sealed",
                                *(["--tls", str(TLS)] if TLS is not None else [])])
        try:
            rtt = _rounds(transport, raw, hops)
        finally:
            far.kill()
            far.wait()
            transport.close()
        half = np.asarray(rtt) / 2 * 1e6
        out["raw_zenoh" if raw else "swarmtrack"] = {"median_us": float(np.median(half)),
                                                     "p99_us": float(np.percentile(half, 99))}
    return out


def _rounds(transport, raw: bool, hops: int) -> list[float]:
    got = threading.Event()
    payload = {"info_vector": wire.pack(np.ones((1, 4))), "info_matrix": wire.pack(np.eye(4)[None])}
    if raw:
        transport.subscribe("bench/pong", lambda k, data: got.set())

        def ping(i: int, timeout: float) -> bool:
            got.clear()
            transport.put("bench/ping", b"x" * 200)
            return got.wait(timeout)
    else:
        node = Node(transport, wire.Seal(KEY, 2), SWARM, 0)
        node.listen(("uav", "1", "share"))

        def ping(i: int, timeout: float) -> bool:
            node.send(0, wire.Share(k=i, payloads=payload))
            return bool(node.wait("share", [1], i, timeout=timeout, missing_ok=True))
    i, deadline = 0, time.monotonic() + 30
    while not ping(i, 0.2):  # until the far side's subscription has reached this side
        i += 1
        if time.monotonic() > deadline:
            raise TimeoutError("the echo process did not answer")
    rtt = []
    for j in range(i + 1, i + 1 + hops + 200):  # the first 200 warm up
        t0 = time.perf_counter()
        if not ping(j, 5.0):
            raise TimeoutError("the echo process stopped answering")
        if j > i + 200:
            rtt.append(time.perf_counter() - t0)
    return rtt


def _live(uavs: int, duration: float, realtime: bool, progress=None, mavlink: bool = False):
    """A live run of ``l24-ct`` with ``uavs`` UAV processes (through simulated autopilots with ``mavlink``): the
    scenario, the report and the world's CPU per step (ms)."""
    from swarmtrack import load_scenario
    from swarmtrack.live.commands import start_agents
    from swarmtrack.live.launch import stop_agents
    from swarmtrack.live.session import run_live

    overrides = [f"duration={duration}", f"swarm.n_uavs={uavs}"]
    scenario = load_scenario("l24-ct", overrides)
    port = free_port()
    endpoints = [_endpoint(port)]
    transport = ZenohTransport(listen=endpoints, tls=TLS)
    node = Node(transport, wire.Seal(None, uavs), f"{SWARM}-{port}", wire.WORLD)
    mavlink_port = free_base(uavs) if mavlink else None
    procs = start_agents(scenario, "l24-ct", None, overrides, endpoints, f"{SWARM}-{port}", None, mavlink_port,
                         tls=TLS)
    try:
        cpu = time.process_time()
        _rec, report, _tables = run_live(scenario, node, progress=progress, realtime=realtime,
                                         mavlink=None if mavlink_port is None else (mavlink_port, "127.0.0.1"))
        world_cpu_ms = 1e3 * (time.process_time() - cpu) / round(duration * scenario.rates.estimation)
    finally:
        stop_agents(procs)
        transport.close()
    return scenario, report, world_cpu_ms


def lockstep(uavs: int, duration: float, mavlink: bool = False) -> dict:
    """A lockstep live run of ``l24-ct`` with ``uavs`` UAV processes, and the simulator on the same scenario."""
    from swarmtrack import load_scenario, simulate

    t0 = time.perf_counter()
    simulate(load_scenario("l24-ct", [f"duration={duration}", f"swarm.n_uavs={uavs}"]))
    simulator_s = time.perf_counter() - t0
    marks = []
    t0 = time.perf_counter()
    _scenario, report, world_cpu = _live(uavs, duration, False,
                                         lambda done: marks.append((time.perf_counter(), done)), mavlink)
    end = time.perf_counter()
    (t_first, done_first) = marks[0]
    loop_s = (end - t_first) / (1 - done_first)  # the steps after the first, scaled to the whole run
    return {"uavs": uavs, "duration_s": duration, "startup_s": t_first - t0, "loop_s": loop_s,
            "real_time_factor": duration / loop_s, "simulator_real_time_factor": duration / simulator_s,
            "cpu_per_uav_step_ms": report.cpu_per_step_ms["median"], "world_cpu_per_step_ms": world_cpu}


def realtime(uavs: int, duration: float) -> dict:
    """A real-time live run of ``l24-ct`` with ``uavs`` UAV processes."""
    scenario, report, world_cpu = _live(uavs, duration, True)
    share = report.latency_ms.get("share", {})
    return {"uavs": uavs, "duration_s": duration, "period_ms": 1e3 / scenario.rates.estimation,
            "step_lateness_periods": report.step_lateness, "world_lateness_periods": report.world_lateness,
            "share_latency_ms": share, "cpu_per_uav_step_ms": report.cpu_per_step_ms,
            "world_cpu_per_step_ms": world_cpu, "late": report.late, "lost": report.lost}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--uavs", type=int, default=5)
    ap.add_argument("--duration", type=float, default=30.0, help="simulated s of the lockstep run")
    ap.add_argument("--realtime-uavs", type=int, default=10)
    ap.add_argument("--realtime-duration", type=float, default=60.0, help="s of the real-time run")
    ap.add_argument("--hops", type=int, default=2000)
    ap.add_argument("--quick", action="store_true", help="short runs (10 s each, 500 hops)")
    ap.add_argument("--tls", type=Path, default=None, metavar="DIR",
                    help="every Zenoh link mutual TLS with the certificates in DIR (ca.pem, cert.pem, key.pem)")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--echo", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--raw", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--sealed", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--vehicle-echo", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    global TLS
    TLS = args.tls
    if args.echo:
        _echo(args.echo, args.raw)
        return 0
    if args.vehicle_echo:
        _vehicle_echo(args.vehicle_echo)
        return 0
    if args.quick:
        args.duration, args.realtime_duration, args.hops = 10.0, 10.0, 500
    hop = ping_pong(args.hops)
    run = lockstep(args.uavs, args.duration)
    trip = mavlink_round_trip(args.hops)
    flown = lockstep(args.uavs, args.duration, mavlink=True)
    live = realtime(args.realtime_uavs, args.realtime_duration)
    if args.json:
        print(json.dumps({"tls": TLS is not None, "hop": hop, "lockstep": run, "mavlink_round_trip": trip,
                          "lockstep_mavlink": flown, "realtime": live}, indent=1))
        return 0
    raw, ours = hop["raw_zenoh"], hop["swarmtrack"]
    print(f"one hop, median / p99: swarmtrack {ours['median_us']:.0f} / {ours['p99_us']:.0f} µs; raw Zenoh "
          f"{raw['median_us']:.0f} / {raw['p99_us']:.0f} µs (ratio {ours['median_us'] / raw['median_us']:.2f}, "
          "goal ≤ 2)")
    print(f"lockstep l24-ct, {run['uavs']} UAV processes, {run['duration_s']:g} s: {run['real_time_factor']:.1f}× "
          f"real time (goal ≥ 5), start-up {run['startup_s']:.1f} s; the simulator on it in this process: "
          f"{run['simulator_real_time_factor']:.0f}× real time; CPU per step: {run['cpu_per_uav_step_ms']:.2f} ms "
          f"per UAV process (median), {run['world_cpu_per_step_ms']:.2f} ms the world (mean, start-up included)")
    print(f"MAVLink round trip (setpoint sent → the navigation that reflects it): {trip['median_us']:.0f} / "
          f"{trip['p99_us']:.0f} µs (median / p99), beside the Zenoh hop above; lockstep l24-ct through simulated "
          f"autopilots: {flown['real_time_factor']:.1f}× real time, CPU per UAV process per step "
          f"{flown['cpu_per_uav_step_ms']:.2f} ms (median) against {run['cpu_per_uav_step_ms']:.2f} ms without")
    late, world, share, cpu = (live["step_lateness_periods"], live["world_lateness_periods"],
                               live["share_latency_ms"], live["cpu_per_uav_step_ms"])
    print(f"real time l24-ct, {live['uavs']} UAV processes, {live['duration_s']:g} s (period "
          f"{live['period_ms']:.0f} ms): UAV steps done {late['median']:.2f} / {late['p99']:.2f} / {late['max']:.2f} "
          f"periods late (median / p99 / max; goal p99 ≤ 1); the world began its steps {world['p99']:.2f} periods "
          f"late at p99; share latency {share['median']:.2f} / {share['p99']:.2f} ms (median / p99) beside the "
          f"one hop above; missed deadlines {live['late'] or 'none'}")
    print(f"CPU per UAV process per estimation step in real time: {cpu['median']:.2f} ms median, "
          f"{cpu['p99']:.2f} ms p99 (start-up apart); the world {live['world_cpu_per_step_ms']:.2f} ms (mean)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
