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
* **Real time ``l24-ct`` with 10 UAV processes for 60 s** (issue 41): how late after its time each UAV's step was
  done (goal: not more than one period at the 99th percentile), the shares that missed their deadline (goal: at most
  1 % of those the radios named), the CPU time of a UAV's process per estimation step (median, from each process's
  own accounting, start-up apart: what a companion computer must afford; goal ≤ 1.5 ms), the world's own lateness and
  the share latency beside the one-hop figure; the reference is the same run with all-to-all delivery (every UAV
  hears every UAV's key, the radio decides what is kept: the live swarm before issue 41).
* **On a line** (issue 41): ``l24-ct`` with its UAVs 4 m apart on a line, holding still (``controller: static``), so
  that every message travels the line (the estimation topology is a line; the beacons' proximity graph, within
  4.8 m, is the same line), in lockstep with 5, 10 and 20 UAV processes: a UAV's receive work per estimation step
  (the messages its subscriptions delivered and the CPU time its callbacks spent on them, median over UAVs and
  steps; goal: flat within 20 % from 5 to 20 UAVs) beside all-to-all delivery at 5 and 20 UAVs (the reference, which
  grows with the swarm), and the 20-UAV run's speed (goal: ≥ 2× real time) beside the all-to-all run's.
  (``l24-ct`` itself spawns its UAVs in a 6 m box and flocks them 4 m apart: its beacons' proximity graph has about
  2, 5 and 10 neighbours per UAV at 5, 10 and 20 UAVs, so its receive work grows with those neighbours.)

With ``--tls DIR`` (a folder of ``ca.pem``, ``cert.pem``, ``key.pem``, made as docs/live.md says) every Zenoh link
of the figures above is mutual TLS (``tls/127.0.0.1:PORT``): the cost of confidentiality.

Each goal is printed MET or NOT MET beside its reference; the 1-minute load average is printed before and after
each live run (the machine's other work moves every real-time figure).

Usage: ``python benchmarks/bench_live.py [--uavs 5] [--duration 30] [--realtime-uavs 10] [--realtime-duration 60]
[--line 5,10,20] [--line-duration 20] [--hops 2000] [--quick] [--tls DIR] [--json]``.
"""

from __future__ import annotations

import argparse
import json
import os
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


def message_path(n: int = 20000) -> dict:
    """The message path of an ``l24-ct`` share (its information contribution and measurement, and the beacon), µs per
    message, best of 5 × ``n``, in this process: packing its arrays, sealing (encoding once, the HMAC tag), opening
    (the tag checked, decoded), filing it in a node's mailbox from the callback (opened, checked for a replay,
    filed), unpacking its arrays. (Before issue 41, on the same machine: pack 14.7 µs, the tag by ``hmac.new``
    2.1-2.5 µs: docs/live.md, issue 41.)"""
    import timeit

    from swarmtrack.live.exchange import pack

    outbox = {"info_matrix": np.ones((1, 2, 2)), "info_vector": np.ones((1, 2)), "z": np.ones((1, 2)),
              "sensor_pos": np.ones((1, 2)), "seen": np.ones(1, dtype=bool)}
    beacon = {"position": np.ones((1, 2)), "velocity": np.ones((1, 2))}
    run = b"r" * 16
    seal, opener = wire.Seal(KEY, 3, run=run), wire.Seal(KEY, 3, run=run)
    key_expr = key(SWARM, "uav", 1, "share", 0)
    msg = wire.Share(k=1, taken=0.05, payloads=pack(outbox), beacon=pack(beacon))
    data = seal.seal(key_expr, msg)
    body = data[wire.TAG_BYTES:]
    opened = opener.open(key_expr, data, fresh=False)

    class Held:
        def put(self, k, d): ...
        def subscribe(self, k, cb): ...
        def close(self): ...

    node = Node(Held(), wire.Seal(KEY, 3, run=run), SWARM, 0)

    def arrive() -> None:
        node.seal._last.clear()
        node._arrive(key_expr, data)

    def best(f) -> float:  # many short rounds: the quietest one counts (other work shares the machine)
        return min(timeit.repeat(f, number=max(1, n // 10), repeat=30)) / max(1, n // 10) * 1e6

    return {"bytes": len(data), "arrays": len(outbox) + len(beacon),
            "pack_us": best(lambda: (pack(outbox), pack(beacon))),
            "seal_us": best(lambda: seal.seal(key_expr, msg)),
            "tag_us": best(lambda: seal._tag(key_expr, body)),
            "open_us": best(lambda: opener.open(key_expr, data, fresh=False)),
            "file_us": best(arrive),
            "unpack_us": best(lambda: ({k: wire.unpack(v) for k, v in opened.payloads.items()},
                                       {k: wire.unpack(v) for k, v in opened.beacon.items()}))}


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


def line(uavs: int) -> list[str]:
    """``l24-ct``'s overrides that put every message on a line: the UAVs 4 m apart on a line (the flocking's spacing;
    the beacons' range is 4.8 m) holding still, so that the beacons' proximity graph is the estimation topology's
    line."""
    positions = [[4.0 * i - 2.0 * uavs, -6.0] for i in range(uavs)]
    return [f"swarm.initial_positions={positions}", "controller={kind: static}"]


def _load() -> float:
    return round(os.getloadavg()[0], 2)


def _live(uavs: int, duration: float, realtime: bool, progress=None, mavlink: bool = False,
          extra: tuple[str, ...] = (), all_to_all: bool = False):
    """A live run of ``l24-ct`` with ``uavs`` UAV processes (through simulated autopilots with ``mavlink``; ``extra``
    overrides; ``all_to_all``: every UAV hears every UAV's key): the scenario, the report, the world's CPU per step
    (ms) and the 1-minute load average before and after."""
    from swarmtrack import load_scenario
    from swarmtrack.live.commands import start_agents
    from swarmtrack.live.launch import stop_agents
    from swarmtrack.live.session import run_live

    overrides = [f"duration={duration}", f"swarm.n_uavs={uavs}", *extra]
    scenario = load_scenario("l24-ct", overrides)
    load = [_load()]
    port = free_port()
    endpoints = [_endpoint(port)]
    transport = ZenohTransport(listen=endpoints, tls=TLS)
    node = Node(transport, wire.Seal(None, uavs), f"{SWARM}-{port}", wire.WORLD)
    mavlink_port = free_base(uavs) if mavlink else None
    procs = start_agents(scenario, "l24-ct", None, overrides, endpoints, f"{SWARM}-{port}", None, mavlink_port,
                         tls=TLS)
    try:
        cpu = time.process_time()
        # patience: 20 processes starting on 2 busy cores can take longer than the 60 s a world waits by default
        _rec, report, _tables = run_live(scenario, node, progress=progress, realtime=realtime, patience=300.0,
                                         mavlink=None if mavlink_port is None else (mavlink_port, "127.0.0.1"),
                                         all_to_all=all_to_all)
        world_cpu_ms = 1e3 * (time.process_time() - cpu) / round(duration * scenario.rates.estimation)
    finally:
        stop_agents(procs)
        transport.close()
    load.append(_load())
    return scenario, report, world_cpu_ms, load


def lockstep(uavs: int, duration: float, mavlink: bool = False, extra: tuple[str, ...] = (),
             all_to_all: bool = False) -> dict:
    """A lockstep live run of ``l24-ct`` with ``uavs`` UAV processes (``extra`` overrides), and the simulator on the
    same scenario."""
    from swarmtrack import load_scenario, simulate

    t0 = time.perf_counter()
    simulate(load_scenario("l24-ct", [f"duration={duration}", f"swarm.n_uavs={uavs}", *extra]))
    simulator_s = time.perf_counter() - t0
    marks = []
    t0 = time.perf_counter()
    _scenario, report, world_cpu, load = _live(uavs, duration, False,
                                               lambda done: marks.append((time.perf_counter(), done)), mavlink,
                                               extra, all_to_all)
    end = time.perf_counter()
    (t_first, done_first) = marks[0]
    loop_s = (end - t_first) / (1 - done_first)  # the steps after the first, scaled to the whole run
    received = report.received_per_step or {}
    return {"uavs": uavs, "duration_s": duration, "all_to_all": all_to_all, "startup_s": t_first - t0,
            "loop_s": loop_s, "real_time_factor": duration / loop_s,
            "simulator_real_time_factor": duration / simulator_s,
            "cpu_per_uav_step_ms": report.cpu_per_step_ms["median"], "world_cpu_per_step_ms": world_cpu,
            "received_per_uav_step": (received.get("messages") or {}).get("median"),
            "receive_cpu_per_uav_step_ms": (received.get("cpu_ms") or {}).get("median"), "load": load}


def realtime(uavs: int, duration: float, all_to_all: bool = False) -> dict:
    """A real-time live run of ``l24-ct`` with ``uavs`` UAV processes."""
    scenario, report, world_cpu, load = _live(uavs, duration, True, all_to_all=all_to_all)
    share = report.latency_ms.get("share", {})
    received = report.received_per_step or {}
    return {"uavs": uavs, "duration_s": duration, "all_to_all": all_to_all,
            "period_ms": 1e3 / scenario.rates.estimation,
            "step_lateness_periods": report.step_lateness, "world_lateness_periods": report.world_lateness,
            "share_latency_ms": share, "cpu_per_uav_step_ms": report.cpu_per_step_ms,
            "world_cpu_per_step_ms": world_cpu, "late": report.late, "lost": report.lost,
            "shares_due": report.shares_due,
            "shares_late_fraction": report.late.get("share", 0) / max(1, report.shares_due or 0),
            "received_per_uav_step": (received.get("messages") or {}).get("median"),
            "receive_cpu_per_uav_step_ms": (received.get("cpu_ms") or {}).get("median"), "load": load}


def on_a_line(sizes: list[int], duration: float) -> dict:
    """Lockstep runs on a line (:func:`line`) with each of ``sizes`` UAV processes, and with all-to-all delivery at
    the smallest and the largest."""
    runs = [lockstep(n, duration, extra=tuple(line(n))) for n in sizes]
    reference = [lockstep(n, duration, extra=tuple(line(n)), all_to_all=True) for n in (min(sizes), max(sizes))]
    cpu = [r["receive_cpu_per_uav_step_ms"] for r in runs]
    messages = [r["received_per_uav_step"] for r in runs]
    return {"runs": runs, "all_to_all": reference, "receive_cpu_spread": max(cpu) / min(cpu) - 1,
            "received_spread": max(messages) / min(messages) - 1}


def _met(ok: bool) -> str:
    return "MET" if ok else "NOT MET"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--uavs", type=int, default=5)
    ap.add_argument("--duration", type=float, default=30.0, help="simulated s of the lockstep run")
    ap.add_argument("--realtime-uavs", type=int, default=10)
    ap.add_argument("--realtime-duration", type=float, default=60.0, help="s of the real-time run")
    ap.add_argument("--line", default="5,10,20", help="the UAV processes of the runs on a line")
    ap.add_argument("--line-duration", type=float, default=20.0, help="simulated s of each run on a line")
    ap.add_argument("--hops", type=int, default=2000)
    ap.add_argument("--quick", action="store_true", help="short runs (10 s each, 5 s on a line, 500 hops)")
    ap.add_argument("--tls", type=Path, default=None, metavar="DIR",
                    help="every Zenoh link mutual TLS with the certificates in DIR (ca.pem, cert.pem, key.pem)")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--echo", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--raw", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--sealed", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--vehicle-echo", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--say", type=Path, metavar="JSON", help="print the figures of an earlier --json run, and stop")
    args = ap.parse_args()
    global TLS
    TLS = args.tls
    if args.echo:
        _echo(args.echo, args.raw)
        return 0
    if args.vehicle_echo:
        _vehicle_echo(args.vehicle_echo)
        return 0
    if args.say:
        say(json.loads(args.say.read_text()))
        return 0
    if args.quick:
        args.duration, args.realtime_duration, args.line_duration, args.hops = 10.0, 10.0, 5.0, 500
    path = message_path(5000 if args.quick else 20000)
    hop = ping_pong(args.hops)
    run = lockstep(args.uavs, args.duration)
    trip = mavlink_round_trip(args.hops)
    flown = lockstep(args.uavs, args.duration, mavlink=True)
    live = realtime(args.realtime_uavs, args.realtime_duration)
    everyone = realtime(args.realtime_uavs, args.realtime_duration, all_to_all=True)
    lined = on_a_line([int(n) for n in args.line.split(",")], args.line_duration)
    results = {"tls": TLS is not None, "message_path": path, "hop": hop, "lockstep": run, "mavlink_round_trip": trip,
               "lockstep_mavlink": flown, "realtime": live, "realtime_all_to_all": everyone, "line": lined}
    if args.json:
        print(json.dumps(results, indent=1))
    else:
        say(results)
    return 0


def say(results: dict) -> None:
    """The figures of :func:`main`'s ``results`` (``--json``'s), each goal MET or NOT MET beside its reference."""
    path, hop, run, trip, flown = (results[name] for name in ("message_path", "hop", "lockstep", "mavlink_round_trip",
                                                              "lockstep_mavlink"))
    live, everyone, lined = results["realtime"], results["realtime_all_to_all"], results["line"]
    print(f"message path of an l24-ct share ({path['bytes']} bytes, {path['arrays']} arrays), µs per message: pack "
          f"{path['pack_us']:.1f}, seal {path['seal_us']:.1f} (its tag {path['tag_us']:.1f}), open "
          f"{path['open_us']:.1f}, into the mailbox "
          f"{path['file_us']:.1f} (opened, replay check, filed), unpack {path['unpack_us']:.1f}")
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
    for r in (live, everyone):
        late, world, share, cpu = (r["step_lateness_periods"], r["world_lateness_periods"], r["share_latency_ms"],
                                   r["cpu_per_uav_step_ms"])
        print(f"real time l24-ct, {r['uavs']} UAV processes, {r['duration_s']:g} s (period {r['period_ms']:.0f} ms), "
              f"{'all-to-all (reference)' if r['all_to_all'] else 'per-neighbour'}, load {r['load'][0]} → "
              f"{r['load'][1]}: UAV steps done {late['median']:.2f} / {late['p99']:.2f} / {late['max']:.2f} periods "
              f"late (median / p99 / max); the world sent its steps {world['p99']:.2f} periods late at p99; share "
              f"latency {share['median']:.2f} / {share['p99']:.2f} ms (median / p99) beside the one hop above; "
              f"shares past their deadline {r['late'].get('share', 0)} of {r['shares_due']} "
              f"({100 * r['shares_late_fraction']:.2f} %); missed deadlines {r['late'] or 'none'}; CPU per UAV "
              f"process per estimation step {cpu['median']:.2f} ms median, {cpu['p99']:.2f} ms p99 (start-up apart), "
              f"of which receiving {r['receive_cpu_per_uav_step_ms']:.2f} ms ({r['received_per_uav_step']:g} "
              f"messages); the world {r['world_cpu_per_step_ms']:.2f} ms (mean, start-up included)")
    late, ref_late = live["step_lateness_periods"]["p99"], everyone["step_lateness_periods"]["p99"]
    frac, ref_frac = live["shares_late_fraction"], everyone["shares_late_fraction"]
    cpu, ref_cpu = live["cpu_per_uav_step_ms"]["median"], everyone["cpu_per_uav_step_ms"]["median"]
    print(f"  goal, steps done ≤ 1 period late at p99: {late:.2f} periods, {_met(late <= 1)} (all-to-all "
          f"{ref_late:.2f})")
    print(f"  goal, ≤ 1 % of shares past their deadline: {100 * frac:.2f} %, {_met(frac <= 0.01)} (all-to-all "
          f"{100 * ref_frac:.2f} %)")
    print(f"  goal, CPU per UAV step ≤ 1.5 ms (median): {cpu:.2f} ms, {_met(cpu <= 1.5)} (all-to-all {ref_cpu:.2f} ms)")
    print("on a line (UAVs 4 m apart holding still: every message on the line), lockstep:")
    for r in lined["runs"] + lined["all_to_all"]:
        print(f"  {r['uavs']:2d} UAV processes, {'all-to-all' if r['all_to_all'] else 'per-neighbour'}, load "
              f"{r['load'][0]} → {r['load'][1]}: {r['real_time_factor']:.2f}× real time (start-up "
              f"{r['startup_s']:.0f} s); a UAV's receive work per step {r['received_per_uav_step']:g} messages, "
              f"{r['receive_cpu_per_uav_step_ms']:.3f} ms CPU (median; "
              f"{1e3 * r['receive_cpu_per_uav_step_ms'] / r['received_per_uav_step']:.0f} µs a message); its CPU "
              "per step "
              f"{r['cpu_per_uav_step_ms']:.2f} ms; the world {r['world_cpu_per_step_ms']:.2f} ms")
    runs, ref = lined["runs"], lined["all_to_all"]
    spread, counted = lined["receive_cpu_spread"], lined["received_spread"]
    ref_growth = ref[-1]["receive_cpu_per_uav_step_ms"] / ref[0]["receive_cpu_per_uav_step_ms"] - 1
    ref_counted = ref[-1]["received_per_uav_step"] / ref[0]["received_per_uav_step"] - 1
    print(f"  goal, a UAV's receive work flat within 20 % from {runs[0]['uavs']} to {runs[-1]['uavs']} UAVs "
          f"(largest over smallest): its messages {100 * counted:+.0f} %, {_met(counted <= 0.2)} (all-to-all "
          f"{100 * ref_counted:+.0f} % from {ref[0]['uavs']} to {ref[-1]['uavs']}); their CPU time "
          f"{100 * spread:+.0f} %, {_met(spread <= 0.2)} (all-to-all {100 * ref_growth:+.0f} %; a busy machine's "
          "load, which the larger swarms' processes raise, costs each message more CPU time)")
    big, ref_big = runs[-1], ref[-1]
    print(f"  goal, lockstep with {big['uavs']} UAV processes ≥ 2× real time: {big['real_time_factor']:.2f}×, "
          f"{_met(big['real_time_factor'] >= 2)} (all-to-all {ref_big['real_time_factor']:.2f}×)")


if __name__ == "__main__":
    sys.exit(main())
