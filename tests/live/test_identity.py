"""A run's identity (issue 36): every message is bound to its run (the seal covers the run the world drew, the sending
process, the channel and the sequence number), a UAV's process takes only the start bound to its own hello, nothing
a stranger sends before the start changes who is refused, one process flies a UAV, and every wait ends when its
cause is known.

The live tests start real processes, each bounded in time; they end only the processes they started, by their ids.
"""

from __future__ import annotations

import importlib.util
import json
import os
import socket
import subprocess
import sys
import time
import uuid
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import swarmtrack
from swarmtrack.cli import main
from swarmtrack.live import wire
from swarmtrack.live.node import EVIDENCE, Node
from swarmtrack.live.transport import free_port, key


def _sibling(name: str):
    spec = importlib.util.spec_from_file_location(f"_identity_{name}", Path(__file__).with_name(f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


assert_same_recording = _sibling("test_lockstep").assert_same_recording

pytestmark = pytest.mark.xdist_group("live")

BASE = [sys.executable, "-m", "swarmtrack"]


# --- the seal (no process) -------------------------------------------------------------------------------------


def _share(seal: wire.Seal, key_expr: str, sender: int, k: int = 0) -> bytes:
    return seal.seal(key_expr, wire.Share(sender=sender, k=k, payloads={}))


def test_a_message_of_another_run_is_rejected_as_other_run_however_genuine():
    secret, k = wire.keygen(), "swarmtrack/s/uav/1/share"
    earlier, now = wire.Seal(secret, 3, run=wire.new_run()), wire.Seal(secret, 3, run=wire.new_run())
    receiver = wire.Seal(secret, 3, run=now.run)
    with pytest.raises(wire.Rejected, match="other_run"):
        receiver.open(k, _share(earlier, k, 1))
    assert receiver.open(k, _share(now, k, 1)).run == now.run
    # what a UAV says before it knows the run passes, but a hello answering another world is another run's
    hello_key = "swarmtrack/s/uav/1/hello"
    unstarted = wire.Seal(secret, 3)
    hello = wire.Hello(sender=1, pid=1, started=1, scenario="x", worlds=[earlier.run])
    with pytest.raises(wire.Rejected, match="other_run"):
        receiver.open(hello_key, unstarted.seal(hello_key, hello))
    hello.worlds = [now.run]
    assert receiver.open(hello_key, unstarted.seal(hello_key, hello)).worlds == [now.run]
    assert receiver.rejected == {"other_run": 2}


def test_replays_are_judged_per_process_so_a_second_process_does_not_silence_the_first():
    secret, k = wire.keygen(), "swarmtrack/s/uav/1/alive"
    first, second, receiver = wire.Seal(secret, 3), wire.Seal(secret, 3), wire.Seal(secret, 3)
    second.started = first.started + 10**9  # started much later: its sequence numbers are far above the first's
    for seal in (second, first, first):
        assert receiver.open(k, seal.seal(k, wire.Alive(sender=1))).proc == seal.proc
    old = first.seal(k, wire.Alive(sender=1))
    receiver.open(k, old)
    with pytest.raises(wire.Rejected, match="replayed"):
        receiver.open(k, old)


class _Held:
    def __init__(self):
        self.sent = []

    def put(self, key_expr, data):
        self.sent.append((key_expr, data))

    def subscribe(self, key_expr, callback):
        return None

    def close(self):
        pass


def test_a_unstarted_uav_takes_only_the_start_bound_to_its_hello_and_drops_earlier_runs_messages():
    secret, swarm = wire.keygen(), "s"
    world = Node(_Held(), wire.Seal(secret, 2, run=wire.new_run()), swarm, wire.WORLD)
    uav = Node(_Held(), wire.Seal(secret, 2), swarm, 0)
    uav.greeting = True
    earlier = Node(_Held(), wire.Seal(secret, 2, run=wire.new_run()), swarm, wire.WORLD)
    earlier.send(0, wire.Start(labels={}, to=12345))  # an earlier run's start, for an earlier process
    earlier.send(0, wire.Navigation(k=0, nav=None))
    earlier.send("all", wire.Stop())
    world.send(0, wire.Navigation(k=0, nav=wire.pack(np.ones((1, 4)))))
    world.send(0, wire.Start(labels={}, to=uav.seal.proc))
    for node in (earlier, world):
        for key_expr, data in node.transport.sent:
            uav._arrive(key_expr, data)
    assert uav.stopped is None and uav.seal.run == world.seal.run
    assert uav.first("start", wire.WORLD, timeout=0).run == world.seal.run
    got = uav.wait("navigation", [wire.WORLD], 0, timeout=0)[wire.WORLD]
    assert got.run == world.seal.run and got.nav is not None  # this run's, not the earlier one's
    assert uav.seal.rejected == {"other_run": 3}


def test_random_bytes_are_never_evidence_of_another_key_and_a_steady_stream_of_one_identity_is():
    node = Node(_Held(), wire.Seal(wire.keygen(), 2, run=wire.new_run()), "s", wire.WORLD)
    hello_key = "swarmtrack/s/uav/1/hello"
    for _ in range(50):
        node._arrive(hello_key, os.urandom(100))
    assert node.evidence(1) is None and node.seal.rejected["forged"] == 50
    other = wire.Seal(wire.keygen(), 2)
    for _ in range(EVIDENCE):
        node._arrive(hello_key, other.seal(hello_key, wire.Hello(sender=1, pid=77, started=1, scenario="x")))
    assert node.evidence(1) is None  # three at once: not over a second
    for entry in node.failing[1].values():
        entry[0] -= 1.0  # as if the first came a second ago
    assert node.evidence(1).pid == 77


# --- live processes ----------------------------------------------------------------------------------------------


def _keyfile(tmp_path) -> Path:
    path = tmp_path / "swarm.key"
    assert CliRunner().invoke(main, ["keygen", str(path)]).exit_code == 0
    return path


def _start(*args, env=None) -> subprocess.Popen:
    return subprocess.Popen([*BASE, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "COLUMNS": "200", **(env or {})})


def _live(tmp_path, name: str, key_file, swarm: str, port: int, overrides: list[str], *extra: str):
    sets = [a for o in overrides for a in ("--set", o)]
    return _start("live", "l24-ct", "--key", str(key_file), "--swarm", swarm, "--listen", f"tcp/127.0.0.1:{port}",
                  "--no-plots", "--out", str(tmp_path / name), *sets, *extra)


def _end(*procs) -> None:
    for p in procs:
        if p is not None and p.poll() is None:
            p.kill()
            p.wait()


def _metrics(folder) -> dict:
    return json.loads((folder / "metrics.json").read_text())


@pytest.mark.slow
def test_an_outsiders_garbage_on_hello_and_world_keys_at_start_up_neither_aborts_nor_blames(tmp_path, peer):
    """From before the UAVs say hello to the end, a stranger (no key) puts random bytes, and unsealed messages that
    decode (a hello, a world heartbeat, a stop: each with an identity of its own), on every UAV's hello key and on
    the world's keys: the run completes, equal to ``swarmtrack run`` bit for bit, the messages counted."""
    key_file, port, swarm, overrides = _keyfile(tmp_path), free_port(), f"test-{uuid.uuid4().hex[:8]}", ["duration=4"]
    world = _live(tmp_path, "live", key_file, swarm, port, overrides)
    stranger, sent = None, 0
    try:
        stranger = peer.join(port)  # the world listens before it starts its UAVs' processes
        outsider, rng = wire.Seal(wire.keygen(), 3), np.random.default_rng()
        keys = [key(swarm, "uav", i, "hello") for i in range(3)]
        keys += [key(swarm, "world", to, ch) for to in ("all", 0, 1, 2) for ch in ("alive", "start", "stop",
                                                                                    "navigation", "roster")]
        while world.poll() is None:
            for k in keys:
                stranger.put(k, os.urandom(int(rng.integers(1, 300))))
                what = k.rsplit("/", 1)[1]
                msg = (wire.Hello(sender=int(k.split("/")[3]), pid=4242, started=1, scenario="x") if what == "hello"
                       else wire.Stop() if what == "stop" else wire.Alive(pid=4242))
                outsider.proc = int(rng.integers(1, 2**62))  # an identity of its own each time: never evidence
                stranger.put(k, outsider.seal(k, msg))
                sent += 2
            time.sleep(0.05)
        out, err = world.communicate(timeout=240)
    finally:
        _end(world)
        if stranger is not None:
            stranger.close()
    assert world.returncode == 0, err[-3000:]
    assert "fail the swarm key" not in err and "Traceback" not in err
    rejected = _metrics(tmp_path / "live")["live"]["rejected"]
    assert sent and rejected.get("forged", 0) > 0, rejected
    assert_same_recording(swarmtrack.load_run(tmp_path / "live"),
                          swarmtrack.simulate(swarmtrack.load_scenario("l24-ct", overrides)))


@pytest.mark.slow
def test_an_earlier_runs_stop_start_and_navigation_replayed_into_a_new_run_are_other_runs_and_change_nothing(
        tmp_path, peer):
    """Two runs of one swarm (same key, same name): everything the first run's world sent (its seed 1's navigation,
    its starts, its stop) is replayed into the second from before its UAVs say hello to its end: all of it dropped
    as ``other_run``, the second run equal to ``swarmtrack run`` bit for bit."""
    key_file, swarm = _keyfile(tmp_path), f"test-{uuid.uuid4().hex[:8]}"
    captured: list[tuple[str, bytes]] = []
    port = free_port()
    first = _live(tmp_path, "first", key_file, swarm, port, ["duration=2"], "--seed", "1")
    listener = None
    try:
        listener = peer.join(port)
        listener.subscribe(key(swarm, "world", "*", "*"), lambda k, data: captured.append((str(k), data)))
        _, err = first.communicate(timeout=240)
    finally:
        _end(first)
        if listener is not None:
            listener.close()
    assert first.returncode == 0, err[-3000:]
    old = [(k, d) for k, d in captured if k.rsplit("/", 1)[1] in ("navigation", "start", "stop")]
    assert {k.rsplit("/", 1)[1] for k, _ in old} == {"navigation", "start", "stop"}
    overrides, port = ["duration=4"], free_port()
    second = _live(tmp_path, "second", key_file, swarm, port, overrides)
    replayer, i = None, 0
    try:
        replayer = peer.join(port)
        stops = [(k, d) for k, d in old if not k.endswith("/navigation")]
        navigation = [(k, d) for k, d in old if k.endswith("/navigation")]
        while second.poll() is None:
            for k, d in stops + navigation[i:i + 12]:
                replayer.put(k, d)
            i = (i + 12) % len(navigation)
            time.sleep(0.05)
        _, err = second.communicate(timeout=240)
    finally:
        _end(second)
        if replayer is not None:
            replayer.close()
    assert second.returncode == 0, err[-3000:]
    rejected = _metrics(tmp_path / "second")["live"]["rejected"]
    assert rejected.get("other_run", 0) > 0 and "replayed" not in rejected, rejected
    assert_same_recording(swarmtrack.load_run(tmp_path / "second"),
                          swarmtrack.simulate(swarmtrack.load_scenario("l24-ct", overrides)))


@pytest.mark.slow
def test_a_second_process_for_a_uav_that_flies_is_refused_naming_it_and_the_run_is_unharmed(tmp_path, peer):
    """``swarmtrack agent --uav 1`` started again while UAV 1's process flies it: the newcomer is told by the world
    and exits 2 naming the process that flies it; the world names the newcomer (console and metrics.json); no UAV
    is lost and the numbers equal ``swarmtrack run``'s bit for bit."""
    key_file, port, swarm = _keyfile(tmp_path), free_port(), f"test-{uuid.uuid4().hex[:8]}"
    overrides = ["duration=20"]  # lockstep runs at a few times real time: the newcomer says hello while it flies
    second = _held_agent(1, port, swarm, key_file, overrides)
    world = _live(tmp_path, "live", key_file, swarm, port, overrides)
    try:
        assert peer.flown(port, swarm, 0, 20) >= 20
        _go(second)
        _, second_err = second.communicate(timeout=120)
        _, err = world.communicate(timeout=240)
    finally:
        _end(world, second)
    assert second.returncode == 2, second_err[-3000:]
    assert "UAV 1 is flown by process" in second_err and "a second one" in second_err, second_err[-2000:]
    assert world.returncode == 0, err[-3000:]
    assert f"UAV 1: process {second.pid} refused" in err, err[-3000:]
    live = _metrics(tmp_path / "live")["live"]
    assert [e["pid"] for e in live["refused"]] == [second.pid] and not live["lost"], live
    assert_same_recording(swarmtrack.load_run(tmp_path / "live"),
                          swarmtrack.simulate(swarmtrack.load_scenario("l24-ct", overrides)))


def _world(tmp_path, port: int, swarm: str, key_file, overrides: list[str], *extra: str) -> subprocess.Popen:
    sets = [a for o in overrides for a in ("--set", o)]
    return _start("world", "l24-ct", "--key", str(key_file), "--swarm", swarm, "--listen", f"tcp/127.0.0.1:{port}",
                  "--no-plots", "--out", str(tmp_path / "live"), *sets, *extra)


def _agent(uav: int, port: int, swarm: str, key_file, overrides: list[str], *extra: str) -> subprocess.Popen:
    sets = [a for o in overrides for a in ("--set", o)]
    return _start("agent", "l24-ct", "--uav", str(uav), "--key", str(key_file), "--swarm", swarm, "--connect",
                  f"tcp/127.0.0.1:{port}", *sets, *extra)


#: ``swarmtrack`` with the live agent's modules loaded, run once a line comes on its input.
HELD = ("import sys; import swarmtrack.live.agent; from swarmtrack.cli import main; sys.stdin.readline(); "
        "main(sys.argv[1:])")


def _held_agent(uav: int, port: int, swarm: str, key_file, overrides: list[str], *extra: str) -> subprocess.Popen:
    """``swarmtrack agent --uav UAV`` joining the world on ``port``, its modules loaded at once, started when told
    (:func:`_go`): on a busy machine one started from scratch mid-run may say hello only after the run's end."""
    sets = [a for o in overrides for a in ("--set", o)]
    return subprocess.Popen([sys.executable, "-c", HELD, "agent", "l24-ct", "--uav", str(uav), "--key", str(key_file),
                             "--swarm", swarm, "--connect", f"tcp/127.0.0.1:{port}", *sets, *extra],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _go(held: subprocess.Popen) -> None:
    held.stdin.write("go\n")
    held.stdin.flush()


@pytest.mark.slow
def test_agents_stop_waiting_when_the_world_refuses_the_run_and_says_why(tmp_path, peer):
    """UAV 2's process runs another seed: the world refuses the run naming it (exit 2), and tells every process whose
    hello it heard, bound to that hello: UAV 1's process, which had nothing wrong, exits 2 saying the world stopped
    the run and why, rather than waiting for a start that will not come (its 60 s)."""
    key_file, port, swarm, overrides = _keyfile(tmp_path), free_port(), f"test-{uuid.uuid4().hex[:8]}", \
        ["swarm.n_uavs=2", "duration=3"]
    world = _world(tmp_path, port, swarm, key_file, overrides)
    agents = []
    try:
        listener, heard = peer.join(port), []
        reader = wire.Seal(bytes.fromhex(key_file.read_text()), 2)
        listener.subscribe(key(swarm, "world", "all", "alive"),
                           lambda k, data: heard.extend(reader.open(str(k), data).heard))
        agents = [_agent(1, port, swarm, key_file, overrides)]
        deadline = time.monotonic() + 90
        while not heard and time.monotonic() < deadline:  # the world has heard UAV 1's process
            time.sleep(0.05)
        listener.close()
        agents.append(_agent(2, port, swarm, key_file, overrides, "--seed", "7"))
        _, err = world.communicate(timeout=120)
        errs = [a.communicate(timeout=120)[1] for a in agents]
    finally:
        _end(world, *agents)
    assert world.returncode == 2 and "UAVs [2]" in err and "another scenario" in err, err[-2000:]
    for a, e in zip(agents, errs, strict=True):
        assert a.returncode == 2, e[-2000:]
        assert "the world stopped the run" in e and "another scenario" in e and "Traceback" not in e, e[-2000:]
    assert not (tmp_path / "live").exists()


@pytest.mark.slow
def test_a_world_flying_through_mavlink_names_a_uav_started_without_autopilot_at_once(tmp_path, peer):
    """The hello says whether the UAV flies an autopilot: ``world --mavlink`` refuses the UAV started without
    ``--autopilot`` as soon as it says hello (exit 2 both sides, naming the flag), not after a wait."""
    key_file, port, swarm, overrides = _keyfile(tmp_path), free_port(), f"test-{uuid.uuid4().hex[:8]}", \
        ["swarm.n_uavs=1", "duration=3"]
    world = _world(tmp_path, port, swarm, key_file, overrides, "--mavlink", "--mavlink-port", str(_udp_port()))
    agent = None
    try:
        peer.join(port).close()
        agent = _agent(1, port, swarm, key_file, overrides)
        _, err = world.communicate(timeout=120)
        _, agent_err = agent.communicate(timeout=120)
    finally:
        _end(world, agent)
    assert world.returncode == 2 and "without --autopilot" in err and "UAVs [1]" in err, err[-2000:]
    assert agent.returncode == 2 and "without --autopilot" in agent_err, agent_err[-2000:]


def _udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_live_mavlink_names_an_autopilot_port_in_use_at_once(tmp_path):
    """Another process listens on UAV 2's autopilot port (with ``SO_REUSEADDR``, as pymavlink does, which would let
    a second link bind it and hear nothing): UAV 2's process refuses the port and says so in its hello, and the world
    stops the run naming UAV 2 and the port (exit 2), without waiting for its hello for 60 s."""
    while True:
        base = 20000 + int(np.random.default_rng().integers(0, 20000))
        holder = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        holder.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            holder.bind(("127.0.0.1", base + 1))
            break
        except OSError:
            holder.close()
    proc = None
    try:
        proc = _start("live", "l24-ct", "--insecure", "--mavlink", "--mavlink-port", str(base), "--no-plots",
                      "--swarm", f"test-{uuid.uuid4().hex[:8]}", "--out", str(tmp_path / "live"), "--set",
                      "duration=3")
        _, err = proc.communicate(timeout=120)
    finally:
        _end(proc)
        holder.close()
    assert proc.returncode == 2, err[-3000:]
    assert "UAVs [2]" in err and f"UDP port {base + 1} is in use" in err, err[-3000:]
    assert "within 60" not in err and not (tmp_path / "live").exists()


@pytest.mark.slow
def test_an_outsiders_stop_in_an_insecure_run_is_said_to_have_come_unsealed(tmp_path, peer):
    """With ``--insecure`` anyone can stop the UAVs (documented): a stranger reads the run's identity off the wire and
    puts a stop on the world's key. The UAVs obey it, each saying the stop came unsealed in an insecure run; the
    world, which did not send it, says so at once and in metrics.json, and flies them safely to the end."""
    port, swarm = free_port(), f"test-{uuid.uuid4().hex[:8]}"
    world = _start("live", "l24-ct", "--insecure", "--swarm", swarm, "--listen", f"tcp/127.0.0.1:{port}",
                   "--no-plots", "--out", str(tmp_path / "live"), "--set", "duration=60")
    stranger = None
    try:
        assert peer.flown(port, swarm, 0, 20) >= 20
        stranger, runs = peer.join(port), []
        reader = wire.Seal(None, 3)
        stranger.subscribe(key(swarm, "world", "all", "alive"),
                           lambda k, data: runs.append(reader.open(str(k), data).run))
        deadline = time.monotonic() + 30
        while not runs and time.monotonic() < deadline:
            time.sleep(0.05)
        stop_key = key(swarm, "world", "all", "stop")
        forger = wire.Seal(None, 3, run=runs[-1])
        stranger.put(stop_key, forger.seal(stop_key, wire.Stop()))
        out, err = world.communicate(timeout=240)
    finally:
        _end(world)
        if stranger is not None:
            stranger.close()
    assert world.returncode == 0, err[-3000:]
    assert "a stop came before the run's end, unsealed" in err and "a stop the world did not send" in err, err[-3000:]
    metrics = _metrics(tmp_path / "live")
    assert len(metrics["live"]["unsealed_stops"]) == 1 and metrics["live"]["lost"]
    assert any("unsealed" in w["message"] for w in metrics["warnings"])


@pytest.mark.slow
def test_a_process_started_with_rejoin_replaces_the_one_that_flies_its_uav(tmp_path, peer):
    """``swarmtrack agent --uav 2 --rejoin`` while UAV 2's process flies it (as docs/live.md says): the old process is
    told it is replaced (it stops, naming the newcomer), the UAV is lost and rejoins with the new process, and the
    run completes (exit 0), the newcomer's process with it."""
    key_file, port, swarm = _keyfile(tmp_path), free_port(), f"test-{uuid.uuid4().hex[:8]}"
    overrides = ["duration=20"]
    newcomer = _held_agent(2, port, swarm, key_file, overrides, "--rejoin")
    world = _live(tmp_path, "live", key_file, swarm, port, overrides)
    try:
        assert peer.flown(port, swarm, 1, 20) >= 20
        _go(newcomer)
        _, err = world.communicate(timeout=240)
        newcomer_out, newcomer_err = newcomer.communicate(timeout=60)
    finally:
        _end(world, newcomer)
    assert world.returncode == 0, err[-3000:]
    assert newcomer.returncode == 0, newcomer_err[-3000:]
    assert f"UAV 2: replaced by process {newcomer.pid} (--rejoin)" in err, err[-3000:]  # the old one, told
    live = _metrics(tmp_path / "live")["live"]
    assert [e["uav"] for e in live["lost"]] == [2] and [e["uav"] for e in live["rejoined"]] == [2], live
    assert not live["refused"]


@pytest.mark.slow
def test_a_waiting_uav_heard_by_a_world_that_dies_before_starting_it_stops_naming_it(tmp_path, peer):
    """The world heard UAV 1's hello (its heartbeat lists the process) and is killed (SIGKILL) before UAV 2 comes:
    UAV 1's process stops (exit 1) saying the world that heard it stopped answering, not after its 60 s."""
    key_file, port, swarm, overrides = _keyfile(tmp_path), free_port(), f"test-{uuid.uuid4().hex[:8]}", \
        ["swarm.n_uavs=2", "duration=3"]
    world = _world(tmp_path, port, swarm, key_file, overrides)
    agent = None
    try:
        listener, heard = peer.join(port), []
        reader = wire.Seal(bytes.fromhex(key_file.read_text()), 2)
        listener.subscribe(key(swarm, "world", "all", "alive"),
                           lambda k, data: heard.extend(reader.open(str(k), data).heard))
        agent = _agent(1, port, swarm, key_file, overrides)
        deadline = time.monotonic() + 90
        while not heard and time.monotonic() < deadline:
            time.sleep(0.05)
        listener.close()
        assert heard, "the world never heard UAV 1"
        world.kill()
        world.wait()
        _, err = agent.communicate(timeout=50)  # its own patience is 60 s
    finally:
        _end(world, agent)
    assert agent.returncode == 1, err[-2000:]
    assert f"the world (process {world.pid}) that heard this UAV stopped answering" in err, err[-2000:]
