"""``swarmtrack live``: every UAV's onboard stack in its own process over Zenoh on loopback, in lockstep with the
world process, records what ``swarmtrack run`` records, bit for bit; what cannot run live is refused with exit 2.

Live runs start real processes: each is bounded in time, and the test checks none of the UAV processes it started
(found by the swarm's name on their command line) is left behind.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import uuid

import numpy as np
import pytest
from click.testing import CliRunner

import swarmtrack
from swarmtrack.cli import main
from swarmtrack.live import wire
from swarmtrack.live.agent import scenario_hash
from swarmtrack.live.commands import swarm_processes
from swarmtrack.live.launch import GRACE, stop_agents
from swarmtrack.live.node import LOST_AFTER, Node
from swarmtrack.live.transport import free_port, key

# the live tests are two groups, "live" and "live-2", each run in turn by one worker (each starts several processes)
pytestmark = pytest.mark.xdist_group("live")


def _processes_of(swarm: str) -> list[str]:
    return [line for line in swarm_processes(swarm) if "agent" in line]


def start_live(out, scenario: str, overrides: list[str], *extra: str) -> tuple[subprocess.Popen, str]:
    """``swarmtrack live`` (insecure, no figures) started in the background; returns the process and its swarm."""
    swarm = f"test-{uuid.uuid4().hex[:8]}"
    args = [sys.executable, "-m", "swarmtrack", "live", scenario, "--out", str(out), "--no-plots", "--insecure",
            "--swarm", swarm, *extra]
    for o in overrides:
        args += ["--set", o]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "COLUMNS": "200"})
    return proc, swarm


def _columns(rec) -> dict[str, np.ndarray]:
    chunks = list(rec.chunks())
    out = {name: np.concatenate([getattr(c, name) for c in chunks]) for name in ("t", "truth", "phase")}
    out.update({p: np.concatenate([c.probes[p] for c in chunks]) for p in rec.meta["probes"] if p != "solve_time"})
    return out


def assert_same_recording(a, b) -> None:
    """Every truth column and every probe (measured wall times aside) equal bit for bit."""
    ca, cb = _columns(a), _columns(b)
    assert set(ca) == set(cb)
    for name, x in ca.items():
        assert np.array_equal(x, cb[name], equal_nan=x.dtype.kind == "f"), name


#: The live runs that must equal the simulator's: every capability (l24-ct: with a key, under attack, below).
EQUAL = {
    "w20-switching": ["duration=3", "estimator.solo_steps=20"],  # the second exchange round (publish, combine)
    "w20-mpc-formation": ["duration=3", "controller.start=1"],  # following the target's tracked pose (guide)
    # the SM-MPC's plan messages (the UAVs within each other's range) and the guarantee monitor's telemetry
    "ib21-fleet-2": ["duration=3", "network.r_comm=1000"],
    # issue 40's LMB filters: detections and tracks as messages, over a lossy network
    "mtt-box-hard": ["duration=4", "network.loss_probability=0.3"],
}


@pytest.mark.slow
def test_a_live_run_records_what_run_records(tmp_path, peer):
    """The runs go together (each swarm on its own key space and port): a live run waits on messages most of the
    time. Once UAV 2 of the first flies, its process and the world's stall (SIGSTOP) for longer than a dead one is
    given (``LOST_AFTER``), as on a machine too busy for them: the world waits for the process it started and sees
    run, and the other UAVs for their world, which started them."""
    port = free_port()
    runs = {name: start_live(tmp_path / name, name, overrides, *(["--listen", f"tcp/127.0.0.1:{port}"] if first
                                                                 else []))
            for first, (name, overrides) in zip([True, False, False, False], EQUAL.items(), strict=True)}
    try:
        proc, swarm = runs["w20-switching"]
        assert peer.flown(port, swarm, 1, 1) >= 1, proc.stderr.read()[-3000:] if proc.poll() is not None else ""
        stalled = [int(line.split()[0]) for line in _processes_of(swarm) if "--uav 2 " in line]
        assert len(stalled) == 1, _processes_of(swarm)
        for pid in (proc.pid, stalled[0]):
            os.kill(pid, signal.SIGSTOP)
        time.sleep(LOST_AFTER + 1.0)
        for pid in (proc.pid, stalled[0]):
            os.kill(pid, signal.SIGCONT)
        done = {name: proc.communicate(timeout=240) for name, (proc, _) in runs.items()}
    finally:
        for proc, _ in runs.values():
            if proc.poll() is None:
                proc.kill()
    for name, (proc, swarm) in runs.items():
        assert not _processes_of(swarm), "UAV processes left behind"
        assert proc.returncode == 0, done[name][1][-3000:]
        assert "written to" in done[name][0]
        assert not json.loads((tmp_path / name / "metrics.json").read_text())["live"]["lost"]
        ran = swarmtrack.simulate(swarmtrack.load_scenario(name, EQUAL[name]))
        assert_same_recording(swarmtrack.load_run(tmp_path / name), ran)


@pytest.mark.parametrize("args, cause", [
    (["live", "l24-ct"], "no swarm key"),
    (["agent", "l24-ct", "--uav", "4", "--insecure"], "--uav 4"),
    (["live", "robust-5", "--insecure", "--set", "network.liar={uav: 2}"], "liar"),
    (["live", "l24-cv", "--insecure", "--set", "estimator={kind: centralized, model: cv}"], "cannot run live"),
])
def test_what_cannot_run_live_is_refused_naming_the_cause(tmp_path, args, cause):
    res = CliRunner().invoke(main, [*args, *(["--out", str(tmp_path / "x")] if args[0] == "live" else [])])
    assert res.exit_code == 2 and cause in res.output, res.output
    assert not (tmp_path / "x").exists()


def test_a_key_is_written_once_and_a_wrong_one_refused(tmp_path):
    key = tmp_path / "swarm.key"
    assert CliRunner().invoke(main, ["keygen", str(key)]).exit_code == 0
    assert (key.stat().st_mode & 0o777) == 0o600 and len(bytes.fromhex(key.read_text())) == 32
    again = CliRunner().invoke(main, ["keygen", str(key)])
    assert again.exit_code == 2 and "never replaced" in again.output
    bad = tmp_path / "bad.key"
    bad.write_text("not hex")
    res = CliRunner().invoke(main, ["live", "l24-ct", "--key", str(bad), "--out", str(tmp_path / "x")])
    assert res.exit_code == 2 and "not a key" in res.output


def test_an_endpoint_in_use_or_unreachable_is_refused(tmp_path):
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        res = CliRunner().invoke(main, ["live", "l24-ct", "--insecure", "--listen", f"tcp/127.0.0.1:{port}",
                                        "--out", str(tmp_path / "x")])
    assert res.exit_code == 2 and "in use" in res.output, res.output
    assert not (tmp_path / "x").exists()
    res = CliRunner().invoke(main, ["agent", "l24-ct", "--uav", "1", "--insecure", "--connect-timeout", "0.5",
                                    "--connect", f"tcp/127.0.0.1:{free_port()}"])
    assert res.exit_code == 2 and "cannot reach" in res.output, res.output


@pytest.mark.slow
def test_a_uav_with_another_swarm_key_is_refused_by_both_sides_naming_the_key(tmp_path, peer):
    keys = [tmp_path / "a.key", tmp_path / "b.key"]
    for k in keys:
        assert CliRunner().invoke(main, ["keygen", str(k)]).exit_code == 0
    port, swarm = free_port(), f"test-{uuid.uuid4().hex[:8]}"
    base = [sys.executable, "-m", "swarmtrack"]
    world = subprocess.Popen(base + ["world", "l24-ct", "--key", str(keys[0]), "--swarm", swarm, "--listen",
                                     f"tcp/127.0.0.1:{port}", "--out", str(tmp_path / "x")],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    agent = None
    try:
        peer.join(port).close()  # the world listens
        agent = subprocess.Popen(base + ["agent", "l24-ct", "--uav", "1", "--key", str(keys[1]), "--swarm", swarm,
                                         "--connect", f"tcp/127.0.0.1:{port}"],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        _, world_err = world.communicate(timeout=120)  # bounds against a hang, not figures judged
        _, agent_err = agent.communicate(timeout=120)
    finally:
        for p in (world, agent):
            if p is not None and p.poll() is None:
                p.kill()
    assert world.returncode == 2 and "UAVs [1] fail the swarm key" in world_err, world_err[-2000:]
    assert agent.returncode == 2 and "fail this UAV's swarm key" in agent_err, agent_err[-2000:]
    assert "Traceback" not in world_err + agent_err and not (tmp_path / "x").exists()


@pytest.mark.slow
def test_forged_replayed_and_undecodable_messages_are_dropped_counted_and_change_nothing(tmp_path, peer):
    """l24-ct with a swarm key while an outsider publishes forged messages, replays a real one and an insider sends
    bodies that do not decode, on a UAV's share key: all dropped and counted, the recording equal to simulate's."""
    key_file = tmp_path / "swarm.key"
    assert CliRunner().invoke(main, ["keygen", str(key_file)]).exit_code == 0
    secret = bytes.fromhex(key_file.read_text())
    port, swarm = free_port(), f"test-{uuid.uuid4().hex[:8]}"
    overrides = ["duration=15"]  # lockstep runs it in seconds: long enough for the intruder to join on a busy machine
    args = [sys.executable, "-m", "swarmtrack", "live", "l24-ct", "--out", str(tmp_path / "live"), "--no-plots",
            "--key", str(key_file), "--swarm", swarm, "--listen", f"tcp/127.0.0.1:{port}", "--set", *overrides]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    captured, sent = [], {"forged": 0, "replayed": 0, "undecodable": 0}
    try:
        intruder = peer.join(port)
        # UAV 2's share addressed to UAV 1 (per-neighbour delivery), and its own key (all-to-all: UAVs hear it too)
        share, own = key(swarm, "uav", 1, "share", 0), key(swarm, "uav", 1, "share")
        intruder.subscribe(share, lambda k, data: captured.append(data))
        outsider, insider = wire.Seal(wire.keygen(), 3), wire.Seal(secret, 3)
        deadline = time.monotonic() + 60
        while not captured and time.monotonic() < deadline:
            time.sleep(0.05)
        while proc.poll() is None and time.monotonic() < deadline:
            intruder.put(share, outsider.seal(share, wire.Share(sender=1, k=0, payloads={})))
            intruder.put(own, outsider.seal(own, wire.Share(sender=1, k=0, payloads={})))
            intruder.put(share, captured[0])  # a real message of UAV 2 to UAV 1, again
            intruder.put(share, insider._tag(share, b"\x81\xa1x\x01") + b"\x81\xa1x\x01")
            for cause in sent:
                sent[cause] += 1
            time.sleep(0.05)
        intruder.close()
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err[-3000:]
    assert all(n > 0 for n in sent.values())
    rejected = json.loads((tmp_path / "live" / "metrics.json").read_text())["live"]["rejected"]
    assert all(rejected.get(cause, 0) > 0 for cause in sent), rejected  # every kind of intrusion counted
    assert "messages dropped" in out
    ran = swarmtrack.simulate(swarmtrack.load_scenario("l24-ct", overrides))
    assert_same_recording(swarmtrack.load_run(tmp_path / "live"), ran)  # and nothing it computed changed


@pytest.mark.slow
@pytest.mark.parametrize("clock", [[], ["--realtime"]], ids=["lockstep", "realtime"])
def test_a_killed_uav_is_flown_safely_named_and_rejoins_tracking(tmp_path, peer, clock):
    """SIGKILL on UAV 2's process mid-run: the run finishes (exit 0), metrics.json names the UAV and the time it was
    lost; ``swarmtrack agent --uav 2 --rejoin`` brings it back, and within 10 s its error is under twice the swarm's
    median. In real time the new process catches up through the steps it is sent. What the killed process counted
    (forged messages it dropped before the kill) stays in ``live.rejected`` after its new process reports its own."""
    port, swarm = free_port(), f"test-{uuid.uuid4().hex[:8]}"
    # lockstep runs ahead at several times real time while the new process starts (imports, its kernels: seconds,
    # more on a busy machine): a longer flight keeps 10 s after its return
    base, overrides = [sys.executable, "-m", "swarmtrack"], ["--set", f"duration={40 if clock else 80}"]
    world = subprocess.Popen(base + ["live", "l24-ct", "--insecure", "--no-plots", "--out", str(tmp_path / "live"),
                                     "--swarm", swarm, "--listen", f"tcp/127.0.0.1:{port}", *clock, *overrides],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    rejoined = intruder = None
    forged: dict[int, int] = {}  # each UAV's latest count of forged messages dropped, from its samples

    def counted(key_expr, data) -> None:
        try:
            sample = reader.open(key_expr, data)
        except wire.Rejected:  # not a sample of this swarm's
            return
        forged[sample.sender] = sample.rejected.get("forged", 0)

    try:
        steps = peer.flown(port, swarm, 1, 60)  # UAV 2 has shared 60 steps (3 s)
        intruder, reader = peer.join(port), wire.Seal(None, 3)
        intruder.subscribe(key(swarm, "uav", "*", "sample"), counted)
        share = key(swarm, "uav", 2, "share")  # UAV 3's key: UAVs 1 and 2 hear it, and drop what is forged
        outsider, deadline = wire.Seal(wire.keygen(), 3), time.monotonic() + 60
        while min(forged.get(0, 0), forged.get(1, 0)) < 10 and time.monotonic() < deadline:
            intruder.put(share, outsider.seal(share, wire.Share(sender=2, k=0, payloads={})))
            time.sleep(0.02)
        time.sleep(1.0)  # UAV 2's samples since carry its final count
        before_kill = forged.get(1, 0)
        assert before_kill >= 10, forged
        victim = [line.split()[0] for line in _processes_of(swarm) if "--uav 2 " in line]
        assert len(victim) == 1, (steps, _processes_of(swarm))
        os.kill(int(victim[0]), 9)
        time.sleep(LOST_AFTER + 1.0)  # the world has taken it for lost (no heartbeat) and flies it safely
        rejoined = subprocess.Popen(base + ["agent", "l24-ct", "--uav", "2", "--rejoin", "--insecure", "--swarm",
                                            swarm, "--connect", f"tcp/127.0.0.1:{port}", *overrides])
        out, err = world.communicate(timeout=240)
        assert rejoined.wait(timeout=30) == 0
    finally:
        for p in (world, rejoined):
            if p is not None and p.poll() is None:
                p.kill()
        if intruder is not None:
            intruder.close()
    assert world.returncode == 0, err[-3000:]
    live_report = json.loads((tmp_path / "live" / "metrics.json").read_text())["live"]
    (lost,), (back,) = live_report["lost"], live_report["rejoined"]
    assert lost["uav"] == back["uav"] == 2 and lost["t"] < back["t"]
    # UAV 1's count and the killed process's both in the total (its new process counted none: the forging stopped)
    assert live_report["rejected"].get("forged", 0) >= forged[0] + before_kill, (live_report["rejected"], forged)
    assert "UAV 2 stopped answering" in err
    rec = swarmtrack.load_run(tmp_path / "live")
    chunks = list(rec.chunks())
    t = np.concatenate([c.t for c in chunks])
    target = np.concatenate([c.truth for c in chunks])[:, rec.meta["tracked"], :2]
    error = np.linalg.norm(np.concatenate([c.probes["estimate"] for c in chunks])[:, :, :2] - target[:, None], axis=2)
    steps_t = np.round(t, 9)  # as the report rounds its times: the step at which it was lost may hold its sample
    away = (steps_t > lost["t"]) & (steps_t < back["t"])
    assert away.any() and np.isnan(error[away, 1]).all()  # nothing recorded while it was lost
    after = (t >= back["t"] + 5) & (t < back["t"] + 10)
    came = np.isfinite(error[after, 1])
    # lockstep waits for every sample; in real time a sample late to the world is recorded as NaN, as many as the
    # machine's load makes late: judged on those that came
    assert after.any(), (back, t[-1])
    assert came.all() if not clock else came.any()
    assert np.nanmean(error[after, 1]) < 2 * np.nanmedian(error[after])


@pytest.mark.slow
def test_ctrl_c_stops_every_process_it_started_and_keeps_the_steps_completed(tmp_path, peer):
    port, swarm = free_port(), f"test-{uuid.uuid4().hex[:8]}"
    world = subprocess.Popen([sys.executable, "-m", "swarmtrack", "live", "l24-ct", "--insecure", "--no-plots",
                              "--out", str(tmp_path / "live"), "--swarm", swarm, "--listen", f"tcp/127.0.0.1:{port}",
                              "--set", "duration=60"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        peer.flown(port, swarm, 0, 40)
        world.send_signal(2)  # SIGINT, as Ctrl-C
        out, err = world.communicate(timeout=120)
        # the UAVs' processes were ended by their ids (SIGTERM, then SIGKILL after GRACE: the test below) before the
        # world ended; how soon after the signal is the machine's load
        assert not _processes_of(swarm)
    finally:
        if world.poll() is None:
            world.kill()
    assert world.returncode == 130 and "interrupted at t =" in err, err[-2000:]
    metrics = json.loads((tmp_path / "live" / "metrics.json").read_text())
    t_stop = metrics["live"]["interrupted"]
    # UAV 1 had shared step 39: the world had recorded steps 0-38 at least
    assert 1.95 <= t_stop < 60 and any("interrupted" in w["message"] for w in metrics["warnings"])
    t = np.concatenate([c.t for c in swarmtrack.load_run(tmp_path / "live").chunks()])
    assert len(t) == round(t_stop / 0.05) and t[-1] < t_stop  # the steps completed, written whole


def _world(tmp_path, port: int, swarm: str, overrides: list[str], *extra: str) -> subprocess.Popen:
    """``swarmtrack world l24-ct`` (insecure, no figures) listening on ``port``, its run into ``tmp_path / "live"``."""
    args = [sys.executable, "-m", "swarmtrack", "world", "l24-ct", "--insecure", "--no-plots", "--swarm", swarm,
            "--listen", f"tcp/127.0.0.1:{port}", "--out", str(tmp_path / "live"), *extra]
    for o in overrides:
        args += ["--set", o]
    return subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _stand_in(peer, port: int, swarm: str, scenario) -> Node:
    """UAV 1 of ``scenario`` as the world sees it: says hello, is started, says it is ready (its stack built), and
    beats; it answers no step. Returns its node once the world has sent it step 0 (the world waits for its sample)."""
    node = Node(peer.join(port), wire.Seal(None, scenario.swarm.n_uavs), swarm, 0)
    node.listen(("world", "0", "*"), ("world", "all", "*"))
    node.heartbeat()
    hello = wire.Hello(pid=os.getpid(), started=node.seal.started, scenario=scenario_hash(scenario))
    deadline = time.monotonic() + 60
    while True:
        node.send(wire.WORLD, hello)
        try:
            node.first("start", wire.WORLD, timeout=0.5)
            break
        except TimeoutError:
            assert time.monotonic() < deadline, "the world never started the stand-in"
    node.send(wire.WORLD, wire.Sample(k=-1, probes={}, aim=wire.pack(np.zeros((1, 2)))))
    node.wait("navigation", [wire.WORLD], 0, timeout=60)
    return node


@pytest.mark.slow  # a world process and a stand-in UAV: 4-8 s each
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_an_interrupt_before_the_first_step_is_recorded_exits_130_with_one_message_and_writes_nothing(
        tmp_path, peer, signum):
    """The world has sent step 0 and waits for the UAV's sample when the signal comes: nothing was recorded, so no
    run folder is written (and no staging folder is left), one line says so, and the exit code is 130."""
    port, swarm, overrides = free_port(), f"test-{uuid.uuid4().hex[:8]}", ["swarm.n_uavs=1", "duration=5"]
    world, node = _world(tmp_path, port, swarm, overrides), None
    try:
        node = _stand_in(peer, port, swarm, swarmtrack.load_scenario("l24-ct", overrides))
        world.send_signal(signum)
        _, err = world.communicate(timeout=60)
    finally:
        if world.poll() is None:
            world.kill()
        if node is not None:
            node.close()
    assert world.returncode == 130, err[-3000:]
    assert "interrupted before the first step; nothing was written" in err and "Traceback" not in err, err[-3000:]
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no run folder, no staging folder


@pytest.mark.slow
def test_a_lockstep_live_run_folder_replays_to_the_live_runs_numbers(tmp_path):
    """The live world keeps every UAV's inputs (navigation, detections) as run does: ``swarmtrack replay`` of its
    folder gives its estimates bit for bit, so its metrics equal."""
    proc, swarm = start_live(tmp_path / "live", "l24-ct", ["duration=4"])
    try:
        _, err = proc.communicate(timeout=240)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err[-3000:]
    res = CliRunner().invoke(main, ["replay", str(tmp_path / "live"), "--no-plots", "--out", str(tmp_path / "again")])
    assert res.exit_code == 0, res.output
    live, again = (json.loads((tmp_path / name / "metrics.json").read_text()) for name in ("live", "again"))
    assert again["replay"]["format"] == "run" and live["rmse"] == again["rmse"]
    assert live["consistency"] == again["consistency"]
    replayed = _columns(swarmtrack.load_run(tmp_path / "again"))
    ran = _columns(swarmtrack.load_run(tmp_path / "live"))
    assert {"estimate", "t", "truth"} <= set(replayed) and np.isfinite(replayed["estimate"]).all()
    for name, x in replayed.items():  # the estimator's probes (the replay runs no controller) and the truth
        assert np.array_equal(x, ran[name], equal_nan=x.dtype.kind == "f"), name


def test_stop_agents_ends_each_process_by_sigterm_and_one_that_ignores_it_by_sigkill_after_the_grace():
    polite = subprocess.Popen(["sleep", "60"])
    stubborn = subprocess.Popen(["sh", "-c", "trap '' TERM; echo trapped; while :; do sleep 0.05; done"],
                                stdout=subprocess.PIPE, text=True)
    assert stubborn.stdout.readline().strip() == "trapped"
    start = time.monotonic()
    stop_agents([polite, stubborn])
    assert time.monotonic() - start >= GRACE  # the stubborn one had its grace
    assert polite.returncode == -signal.SIGTERM and stubborn.returncode == -signal.SIGKILL
    stubborn.stdout.close()
