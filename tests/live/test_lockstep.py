"""``swarmtrack live``: every UAV's onboard stack in its own process over Zenoh on loopback, in lockstep with the
world process, records what ``swarmtrack run`` records, bit for bit; what cannot run live is refused with exit 2.

Live runs start real processes: each is bounded in time, and the test checks none of the UAV processes it started
(found by the swarm's name on their command line) is left behind.
"""

from __future__ import annotations

import json
import os
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
from swarmtrack.live.node import LOST_AFTER
from swarmtrack.live.transport import free_port, key

pytestmark = pytest.mark.xdist_group("live")  # one worker runs these (each starts several processes) in turn


def _processes_of(swarm: str) -> list[str]:
    out = subprocess.run(["ps", "-ww", "-eo", "pid,args"], capture_output=True, text=True).stdout
    return [line for line in out.splitlines() if f"--swarm {swarm}" in line and "agent" in line]


def start_live(out, scenario: str, overrides: list[str]) -> tuple[subprocess.Popen, str]:
    """``swarmtrack live`` (insecure, no figures) started in the background; returns the process and its swarm."""
    swarm = f"test-{uuid.uuid4().hex[:8]}"
    args = [sys.executable, "-m", "swarmtrack", "live", scenario, "--out", str(out), "--no-plots", "--insecure",
            "--swarm", swarm]
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
}


@pytest.mark.slow
def test_a_live_run_records_what_run_records(tmp_path):
    """The runs go together (each swarm on its own key space and port): a live run waits on messages most of the
    time."""
    runs = {name: start_live(tmp_path / name, name, overrides) for name, overrides in EQUAL.items()}
    try:
        done = {name: proc.communicate(timeout=240) for name, (proc, _) in runs.items()}
    finally:
        for proc, _ in runs.values():
            if proc.poll() is None:
                proc.kill()
    for name, (proc, swarm) in runs.items():
        assert not _processes_of(swarm), "UAV processes left behind"
        assert proc.returncode == 0, done[name][1][-3000:]
        assert "written to" in done[name][0]
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
        _, world_err = world.communicate(timeout=30)
        _, agent_err = agent.communicate(timeout=30)
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
    overrides = ["duration=6"]
    args = [sys.executable, "-m", "swarmtrack", "live", "l24-ct", "--out", str(tmp_path / "live"), "--no-plots",
            "--key", str(key_file), "--swarm", swarm, "--listen", f"tcp/127.0.0.1:{port}", "--set", *overrides]
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    captured, sent = [], {"forged": 0, "replayed": 0, "undecodable": 0}
    try:
        intruder = peer.join(port)
        share = key(swarm, "uav", 1, "share")
        intruder.subscribe(share, lambda k, data: captured.append(data))
        outsider, insider = wire.Seal(wire.keygen(), 3), wire.Seal(secret, 3)
        deadline = time.monotonic() + 60
        while not captured and time.monotonic() < deadline:
            time.sleep(0.05)
        while proc.poll() is None and time.monotonic() < deadline:
            intruder.put(share, outsider.seal(share, wire.Share(sender=1, k=0, payloads={})))
            intruder.put(share, captured[0])  # a real message of UAV 2, again
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
    median. In real time the new process catches up through the steps it is sent."""
    port, swarm = free_port(), f"test-{uuid.uuid4().hex[:8]}"
    base, overrides = [sys.executable, "-m", "swarmtrack"], ["--set", "duration=35"]
    world = subprocess.Popen(base + ["live", "l24-ct", "--insecure", "--no-plots", "--out", str(tmp_path / "live"),
                                     "--swarm", swarm, "--listen", f"tcp/127.0.0.1:{port}", *clock, *overrides],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    rejoined = None
    try:
        steps = peer.flown(port, swarm, 1, 60)  # UAV 2 has shared 60 steps (3 s)
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
    assert world.returncode == 0, err[-3000:]
    live_report = json.loads((tmp_path / "live" / "metrics.json").read_text())["live"]
    (lost,), (back,) = live_report["lost"], live_report["rejoined"]
    assert lost["uav"] == back["uav"] == 2 and lost["t"] < back["t"]
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
    # in real time a sample late to the world is recorded as NaN (a busy machine): judged on those that came
    assert after.any() and np.isfinite(error[after, 1]).mean() > 0.8
    assert np.nanmean(error[after, 1]) < 2 * np.nanmedian(error[after])


@pytest.mark.slow
def test_ctrl_c_stops_every_process_within_2_s_and_keeps_the_steps_completed(tmp_path, peer):
    port, swarm = free_port(), f"test-{uuid.uuid4().hex[:8]}"
    world = subprocess.Popen([sys.executable, "-m", "swarmtrack", "live", "l24-ct", "--insecure", "--no-plots",
                              "--out", str(tmp_path / "live"), "--swarm", swarm, "--listen", f"tcp/127.0.0.1:{port}",
                              "--set", "duration=60"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        peer.flown(port, swarm, 0, 40)
        world.send_signal(2)  # SIGINT, as Ctrl-C
        stopped = time.monotonic()
        while _processes_of(swarm) and time.monotonic() < stopped + 10:
            time.sleep(0.05)
        assert time.monotonic() - stopped < 2.5 and not _processes_of(swarm)  # the UAVs' processes, by their ids
        out, err = world.communicate(timeout=60)
    finally:
        if world.poll() is None:
            world.kill()
    assert world.returncode == 130 and "interrupted at t =" in err, err[-2000:]
    metrics = json.loads((tmp_path / "live" / "metrics.json").read_text())
    t_stop = metrics["live"]["interrupted"]
    assert 2.0 <= t_stop < 60 and any("interrupted" in w["message"] for w in metrics["warnings"])
    t = np.concatenate([c.t for c in swarmtrack.load_run(tmp_path / "live").chunks()])
    assert len(t) == round(t_stop / 0.05) and t[-1] < t_stop  # the steps completed, written whole
