"""No peer can block the swarm: a stranger that subscribes to everything and then stops reading (its process stopped
with SIGSTOP once the run is under way) leaves a lockstep run's numbers bit for bit those of a clean run, and the run
ends by itself with exit code 0. (With Zenoh's ``BLOCK`` congestion control, as before, the world's puts waited 5 s
for the stranger, the UAVs stopped hearing the world and every UAV was lost.)

Each test starts processes (``live`` and the stranger), bounds them in time and ends only those, by their ids.
"""

from __future__ import annotations

import importlib.util
import json
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

import swarmtrack
from swarmtrack.live.transport import free_port


def _sibling(name: str):
    spec = importlib.util.spec_from_file_location(f"_live_{name}", Path(__file__).with_name(f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_lockstep = _sibling("test_lockstep")  # its recording check and its finder of a swarm's UAV processes
assert_same_recording, _processes_of = _lockstep.assert_same_recording, _lockstep._processes_of

pytestmark = pytest.mark.xdist_group("live")

#: The stranger: a Zenoh peer of its own making (a receive buffer of 4 KiB, as a slow link's: the world's socket
#: towards it fills after a few messages) joins the world's endpoint (retrying until it listens), subscribes to
#: ``**``, counts the navigation messages it got into a file and says "subscribed" on stdout.
STRANGER = r"""
import json, sys, time
import zenoh
port, tally = int(sys.argv[1]), sys.argv[2]
conf = zenoh.Config()
for path, value in [("mode", '"peer"'), ("scouting/multicast/enabled", "false"),
                    ("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"])), ("connect/timeout_ms", "1000"),
                    ("connect/exit_on_failure", "true"), ("transport/link/tcp/so_rcvbuf", "4096")]:
    conf.insert_json5(path, value)
deadline = time.monotonic() + 60
while True:
    try:
        session = zenoh.open(conf)
        break
    except zenoh.ZError:
        if time.monotonic() > deadline:
            raise
        time.sleep(0.2)
got = [0]
def read(sample):
    if str(sample.key_expr).endswith("/navigation"):
        got[0] += 1
sub = session.declare_subscriber("**", read)
print("subscribed", flush=True)
while True:
    with open(tally, "w") as f:
        f.write(str(got[0]))
    time.sleep(0.2)
"""

OVERRIDES = ["duration=60", "swarm.n_uavs=5"]  # fills the stranger's socket buffers: it got 19 of 6,000 navigations


@pytest.mark.slow
def test_a_frozen_stranger_subscribed_to_everything_changes_no_number_and_blocks_no_one(tmp_path):
    port, swarm = free_port(), f"test-{uuid.uuid4().hex[:8]}"
    tally = tmp_path / "tally"
    stranger = subprocess.Popen([sys.executable, "-c", STRANGER, str(port), str(tally)],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc = subprocess.Popen([sys.executable, "-m", "swarmtrack", "live", "l24-ct", "--insecure", "--no-plots",
                             "--out", str(tmp_path / "live"), "--swarm", swarm, "--listen", f"tcp/127.0.0.1:{port}",
                             *[a for o in OVERRIDES for a in ("--set", o)]],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert stranger.stdout.readline().strip() == "subscribed", stranger.stderr.read()[-2000:]
        deadline = time.monotonic() + 120  # bounds against a hang, not figures judged
        while _count(tally) == 0 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert proc.poll() is None, "the run ended before the stranger heard it"
        stranger.send_signal(signal.SIGSTOP)  # the run is under way: nothing of the stranger runs from now on
        out, err = proc.communicate(timeout=300)
        stranger.send_signal(signal.SIGCONT)  # it reads what its sockets kept, and counts it
        got = _settled(tally)
    finally:
        for p in (proc, stranger):
            if p.poll() is None:
                p.kill()
                p.wait()
    assert proc.returncode == 0, err[-3000:]
    assert "Traceback" not in err and "timed out" not in err, err[-3000:]
    assert not _processes_of(swarm), "UAV processes left behind"
    live = json.loads((tmp_path / "live" / "metrics.json").read_text())["live"]
    assert not live["lost"], live  # every UAV heard the world, and the world every UAV, all along
    ran = swarmtrack.simulate(swarmtrack.load_scenario("l24-ct", OVERRIDES))
    assert_same_recording(swarmtrack.load_run(tmp_path / "live"), ran)
    # the stranger's link was congested (else this test proves nothing): what the world sent it beyond its queues
    # and sockets was dropped towards it alone (or its link closed), while every UAV got every message
    assert got < 5 * ran.meta["n_steps"], got


def _settled(tally: Path, quiet: float = 1.0, bound: float = 30.0) -> int:
    """The stranger's count once it has stopped changing for ``quiet`` s (at most ``bound`` s)."""
    last, since, deadline = None, time.monotonic(), time.monotonic() + bound
    while time.monotonic() < deadline:
        now = _count(tally)
        if now != last:
            last, since = now, time.monotonic()
        elif time.monotonic() - since > quiet:
            break
        time.sleep(0.1)
    return last


def _count(tally: Path) -> int:
    try:
        return int(tally.read_text() or 0)
    except (OSError, ValueError):  # not written yet, or being written
        return 0


#: A publisher's whole life beside a frozen stranger: it listens, waits for the stranger's subscription, publishes
#: 20 000 messages of 300 bytes (megabytes: beyond the stranger's queues and sockets) on a data and a heartbeat key,
#: closes its transport and says whether Zenoh's close timed out.
PUBLISHER = r"""
import sys, time
from swarmtrack.live.transport import ZenohTransport
port = int(sys.argv[1])
t = ZenohTransport(listen=[f"tcp/127.0.0.1:{port}"])
print("listening", flush=True)
sys.stdin.readline()  # the stranger is subscribed and stopped
for i in range(20000):
    t.put("swarmtrack/s/world/all/navigation" if i % 10 else "swarmtrack/s/world/all/alive", b"x" * 300)
t.close()
print("closed", t.close_timed_out, flush=True)
"""


@pytest.mark.slow
def test_a_process_beside_a_frozen_stranger_publishes_and_closes_and_exits_cleanly(tmp_path):
    port, tally = free_port(), tmp_path / "tally"
    publisher = subprocess.Popen([sys.executable, "-c", PUBLISHER, str(port)], stdin=subprocess.PIPE,
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    stranger = None
    try:
        assert publisher.stdout.readline().strip() == "listening", publisher.stderr.read()[-2000:]
        stranger = subprocess.Popen([sys.executable, "-c", STRANGER, str(port), str(tally)],
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert stranger.stdout.readline().strip() == "subscribed", stranger.stderr.read()[-2000:]
        stranger.send_signal(signal.SIGSTOP)
        out, err = publisher.communicate("go\n", timeout=120)  # a bound against a hang, not a time judged
    finally:
        for p in (publisher, stranger):
            if p is not None and p.poll() is None:
                p.kill()
                p.wait()
    assert publisher.returncode == 0 and "Traceback" not in err, err[-3000:]
    # the close returned: at once, or after Zenoh's 10 s when the frozen peer held its link (1 run in 3: noted as
    # close_timed_out, not raised; it crashed live at exit with "zenoh.ZError: close operation timed out")
    assert out.split()[-2] == "closed", out
