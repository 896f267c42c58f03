"""Confidentiality as an option (``--tls DIR``): Zenoh's mutual TLS between the world and its UAVs. A TLS lockstep run
records what the plain run records, bit for bit; nothing of the swarm travels readable (a relay between the UAVs and
the world sees the swarm's name in every plain message, never under TLS); a peer without a certificate of the
swarm's CA cannot join. The certificates are made as docs/live.md says, with the standard ``openssl`` tool.

Each test starts processes (``world``, ``agent``), bounds them in time and ends only those, by their ids.
"""

from __future__ import annotations

import importlib.util
import shutil
import socket
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

import pytest

import swarmtrack
from swarmtrack.live.transport import TransportError, ZenohTransport, free_port

pytestmark = [pytest.mark.xdist_group("live-2"),  # beside the "live" group (tests/live/test_lockstep.py)
              pytest.mark.skipif(shutil.which("openssl") is None, reason="the openssl tool makes the certificates")]

#: docs/live.md's recipe: a swarm CA, and a member's certificate (EC P-256) signed by it, naming the hosts.
RECIPE = """
openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 365 -subj "/CN=swarm CA" \
    -keyout ca.key -out ca.pem
openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -subj "/CN=swarm member" -keyout key.pem -out cert.csr
cat > cert.ext <<EOF
subjectAltName=DNS:localhost,IP:127.0.0.1
basicConstraints=critical,CA:FALSE
keyUsage=critical,digitalSignature
extendedKeyUsage=serverAuth,clientAuth
EOF
openssl x509 -req -in cert.csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 365 -extfile cert.ext -out cert.pem
chmod 600 ca.key key.pem
"""


def make_certificates(folder: Path) -> Path:
    folder.mkdir(parents=True)
    res = subprocess.run(["sh", "-e", "-c", RECIPE], cwd=folder, capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    return folder


def _sibling(name: str):
    spec = importlib.util.spec_from_file_location(f"_live_{name}", Path(__file__).with_name(f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


assert_same_recording = _sibling("test_lockstep").assert_same_recording


class Relay:
    """A TCP relay on loopback that keeps every byte it carries (both ways): what anyone on the wire could read."""

    def __init__(self, target: int):
        self.target, self.seen = target, bytearray()
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self._lock = threading.Lock()
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self.server.accept()
            except OSError:  # closed
                return
            try:
                upstream = socket.create_connection(("127.0.0.1", self.target))
            except OSError:
                client.close()
                continue
            for a, b in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pump, args=(a, b), daemon=True).start()

    def _pump(self, src: socket.socket, dst: socket.socket) -> None:
        try:
            while data := src.recv(65536):
                with self._lock:
                    self.seen += data
                dst.sendall(data)
        except OSError:
            pass
        finally:
            for s in (src, dst):
                try:
                    s.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass

    def close(self) -> None:
        self.server.close()


OVERRIDES = ["duration=3"]


def _run(tmp_path: Path, name: str, tls: Path | None) -> tuple[bytes, str, Path]:
    """A lockstep ``world`` and its 3 ``agent`` processes, the agents reaching the world through a :class:`Relay`;
    returns what the relay carried, the swarm's name and the run folder."""
    proto = "tcp" if tls is None else "tls"
    port, swarm, out = free_port(), f"test-{uuid.uuid4().hex[:8]}", tmp_path / f"run-{name}"
    common = ["l24-ct", "--insecure", "--swarm", swarm, *[a for o in OVERRIDES for a in ("--set", o)]]
    common += [] if tls is None else ["--tls", str(tls)]
    base = [sys.executable, "-m", "swarmtrack"]
    world = subprocess.Popen(base + ["world", *common, "--no-plots", "--out", str(out), "--listen",
                                     f"{proto}/127.0.0.1:{port}"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
    relay, agents = Relay(port), []
    try:
        _listening(port, world)
        for uav in (1, 2, 3):
            agents.append(subprocess.Popen(base + ["agent", *common, "--uav", str(uav), "--connect-timeout", "30",
                                                   "--connect", f"{proto}/127.0.0.1:{relay.port}"],
                                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True))
        _, err = world.communicate(timeout=240)  # bounds against a hang, not figures judged
        for agent in agents:
            agent.communicate(timeout=60)
    finally:
        for p in (world, *agents):
            if p.poll() is None:
                p.kill()
                p.wait()
        relay.close()
    assert world.returncode == 0, err[-3000:]
    assert all(agent.returncode == 0 for agent in agents), [a.returncode for a in agents]
    return bytes(relay.seen), swarm, out


@pytest.mark.slow
def test_a_tls_run_records_what_the_plain_run_records_and_nothing_of_it_is_readable_on_the_wire(tmp_path):
    tls = make_certificates(tmp_path / "tls")
    plain_bytes, plain_swarm, plain = _run(tmp_path, "plain", None)
    tls_bytes, tls_swarm, secret = _run(tmp_path, "tls", tls)
    assert plain_swarm.encode() in plain_bytes  # the relay does see what plain TCP carries: every key names the swarm
    assert len(tls_bytes) > 10_000  # the TLS run went through the relay too
    assert tls_swarm.encode() not in tls_bytes and b"swarmtrack/" not in tls_bytes and b"navigation" not in tls_bytes
    assert_same_recording(swarmtrack.load_run(secret), swarmtrack.load_run(plain))


@pytest.mark.slow
def test_a_peer_without_the_swarms_certificates_cannot_join(tmp_path):
    tls = make_certificates(tmp_path / "tls")
    other = make_certificates(tmp_path / "other")  # a certificate of another CA
    shutil.copy(tls / "ca.pem", other / "ca.pem")  # that trusts the swarm's CA: only the world's check can refuse it
    port = free_port()
    world = subprocess.Popen([sys.executable, "-m", "swarmtrack", "world", "l24-ct", "--insecure", "--tls", str(tls),
                              "--listen", f"tls/127.0.0.1:{port}", "--out", str(tmp_path / "x")],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        member = _join(f"tls/127.0.0.1:{port}", tls)  # the world listens, and takes a member
        member.close()
        for endpoint, folder in [(f"tcp/127.0.0.1:{port}", None), (f"tls/127.0.0.1:{port}", other)]:
            with pytest.raises(TransportError):
                ZenohTransport(connect=[endpoint], timeout=3.0, tls=folder)
    finally:
        world.kill()
        world.wait()


def _listening(port: int, world: subprocess.Popen) -> None:
    """Once the world listens on ``port`` (its scenario built; within 60 s)."""
    deadline = time.monotonic() + 60
    while world.poll() is None and time.monotonic() < deadline:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return
        except OSError:
            time.sleep(0.2)
    raise AssertionError(f"the world does not listen on {port}: {world.stderr.read()[-2000:]}")


def _join(endpoint: str, tls: Path) -> ZenohTransport:
    """A member joined to the world at ``endpoint`` once it listens (its scenario built), within 60 s."""
    deadline = time.monotonic() + 60
    while True:
        try:
            return ZenohTransport(connect=[endpoint], timeout=1.0, tls=tls)
        except TransportError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)


@pytest.mark.slow
def test_live_with_tls_and_a_key_starts_its_uavs_with_neither_path_on_their_command_lines(tmp_path):
    """``live --tls DIR --key FILE``: the run equals the simulator's bit for bit, and what ``ps`` shows of its UAV
    processes names neither the key file, nor the TLS folder, nor the swarm (they read them from their
    environment)."""
    from click.testing import CliRunner

    from swarmtrack.cli import main
    from swarmtrack.live.commands import swarm_processes

    tls, key = make_certificates(tmp_path / "tls"), tmp_path / "swarm.key"
    assert CliRunner().invoke(main, ["keygen", str(key)]).exit_code == 0
    swarm = f"test-{uuid.uuid4().hex[:8]}"
    proc = subprocess.Popen([sys.executable, "-m", "swarmtrack", "live", "l24-ct", "--key", str(key), "--tls", str(tls),
                             "--swarm", swarm, "--no-plots", "--out", str(tmp_path / "run"),
                             *[a for o in OVERRIDES for a in ("--set", o)]],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline, agents = time.monotonic() + 120, []  # bounds against a hang, not figures judged
        while len(agents) < 3 and proc.poll() is None and time.monotonic() < deadline:
            agents = [line for line in swarm_processes(swarm) if " agent " in line]
            time.sleep(0.05)
        _, err = proc.communicate(timeout=240)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err[-3000:]
    assert len(agents) == 3, agents
    for line in agents:
        assert str(key) not in line and str(tls) not in line and swarm not in line and "--key" not in line, line
    ran = swarmtrack.simulate(swarmtrack.load_scenario("l24-ct", OVERRIDES))
    assert_same_recording(swarmtrack.load_run(tmp_path / "run"), ran)
