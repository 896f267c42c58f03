"""Malformed endpoints, URLs and TLS folders on ``live``, ``world`` and ``agent``: one message naming the flag, exit
code 2, no traceback, nothing started (each is refused before a scenario is loaded or a swarm started)."""

from __future__ import annotations

import os

import pytest
from click.testing import CliRunner

from swarmtrack.cli import main
from swarmtrack.live import commands, launch

RUNS = {"live": ["live", "l24-ct", "--insecure"], "world": ["world", "l24-ct", "--insecure"],
        "agent": ["agent", "l24-ct", "--uav", "1", "--insecure"]}


def _refused(tmp_path, monkeypatch, args: list[str], flag: str) -> str:
    def loaded(*_a, **_k):
        raise AssertionError("a scenario was loaded: the flag was not checked first")

    monkeypatch.setattr(commands, "load_live", loaded)  # the world's (live, world)
    monkeypatch.setattr(launch, "load_live", loaded)  # an agent's (agent_scenario)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, [*args, *(["--out", str(out)] if args[0] != "agent" else [])])
    assert res.exit_code == 2, res.output
    assert isinstance(res.exception, SystemExit) and "Traceback" not in res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"Error: {flag} "), res.output
    assert not out.exists()
    return res.output


@pytest.mark.parametrize("command, flag", [("live", "--listen"), ("world", "--listen"), ("agent", "--listen"),
                                           ("agent", "--connect")])
@pytest.mark.parametrize("endpoint", ["garbage", "tcp/127.0.0.1:99999", "tcp/127.0.0.1", "udp/127.0.0.1:7447"])
def test_a_malformed_endpoint_is_refused_naming_its_flag(tmp_path, monkeypatch, command, flag, endpoint):
    assert endpoint in _refused(tmp_path, monkeypatch, [*RUNS[command], flag, endpoint], flag)


@pytest.mark.parametrize("command", ["live", "world", "agent"])
def test_a_tls_endpoint_without_tls_and_a_plain_one_with_it_are_refused(tmp_path, monkeypatch, command):
    flag = "--connect" if command == "agent" else "--listen"
    assert "needs --tls" in _refused(tmp_path, monkeypatch, [*RUNS[command], flag, "tls/127.0.0.1:7447"], flag)
    tls = tmp_path / "tls"
    tls.mkdir()
    for name in ("ca.pem", "cert.pem", "key.pem"):
        (tls / name).write_text("")
    refused = _refused(tmp_path, monkeypatch, [*RUNS[command], "--tls", str(tls), flag, "tcp/127.0.0.1:7447"], flag)
    assert "with --tls every endpoint is tls/" in refused


@pytest.mark.parametrize("command", ["live", "world", "agent"])
def test_a_tls_folder_without_its_certificates_is_refused(tmp_path, monkeypatch, command):
    assert "not a folder" in _refused(tmp_path, monkeypatch, [*RUNS[command], "--tls", str(tmp_path / "none")],
                                      "--tls")
    (tmp_path / "tls").mkdir()
    (tmp_path / "tls" / "ca.pem").write_text("")
    refused = _refused(tmp_path, monkeypatch, [*RUNS[command], "--tls", str(tmp_path / "tls")], "--tls")
    assert "cert.pem, key.pem missing" in refused


def test_the_tls_folder_is_read_from_the_environment_too(tmp_path, monkeypatch):
    monkeypatch.setenv(commands.ENV["tls"], str(tmp_path / "none"))
    assert "not a folder" in _refused(tmp_path, monkeypatch, RUNS["world"], "--tls")


@pytest.mark.parametrize("url, cause", [
    ("udp://:99999", "udp://:99999"),  # the message names the URL and why (the port's range)
    ("udp://127.0.0.1:0", "udp://127.0.0.1:0"),
    ("udp://127.0.0.1", "expected udp://[HOST]:PORT"),
    ("tcp://127.0.0.1:5760", "expected udp://[HOST]:PORT or serial://DEVICE[:BAUD]"),
    ("serial://", "expected serial://DEVICE[:BAUD]"),
])
def test_a_malformed_autopilot_url_is_refused_naming_the_flag(tmp_path, monkeypatch, url, cause):
    assert cause in _refused(tmp_path, monkeypatch, [*RUNS["agent"], "--autopilot", url], "--autopilot")


def test_agents_started_by_live_get_the_key_path_swarm_and_tls_folder_in_their_environment(tmp_path, monkeypatch):
    """What ``ps`` shows of a UAV process names neither the key file, nor the swarm, nor the TLS folder."""
    started = []

    class Popen:
        def __init__(self, args, env=None, **_):
            started.append((args, env))

    monkeypatch.setattr(commands.subprocess, "Popen", Popen)
    scn = type("S", (), {"swarm": type("W", (), {"n_uavs": 2})()})()
    key, tls = tmp_path / "swarm.key", tmp_path / "tls"
    commands.start_agents(scn, "l24-ct", 7, ["duration=3"], ["tls/127.0.0.1:7447"], "secret-swarm", key, tls=tls)
    assert len(started) == 2
    for args, env in started:
        line = " ".join(args)
        assert "secret-swarm" not in line and str(key) not in line and str(tls) not in line, line
        assert "--key" not in args and "--swarm" not in args and "--tls" not in args
        assert env[commands.ENV["key"]] == str(key.absolute()) and env[commands.ENV["swarm"]] == "secret-swarm"
        assert env[commands.ENV["tls"]] == str(tls.absolute())


@pytest.mark.parametrize("command", ["live", "world"])
@pytest.mark.parametrize("taken", ["offboard", "ground-station"])
def test_a_vehicle_port_another_process_holds_is_refused_before_anything_starts(tmp_path, command, taken):
    """Another simulated vehicle (a second world --mavlink) or a PX4 SITL instance holds a port the vehicles bind:
    one message naming the port, exit 2, nothing written (nor an agent started)."""
    import socket

    from swarmtrack.autopilot.endpoint import gcs_local_port, offboard_ports

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as holder:
        # a port whose vehicles' base --mavlink-port accepts (the kernel's own choice may lie above: up to 60999)
        for port in range(20000 + 37 * (os.getpid() % 500), 60000):
            try:
                holder.bind(("127.0.0.1", port))
                break
            except OSError:
                continue
        base = port - 40 - 1 if taken == "offboard" else port - 4030 - 1  # UAV 2's
        assert (offboard_ports(base, 1)[0] if taken == "offboard" else gcs_local_port(base, 1)) == port
        out = tmp_path / "out"
        res = CliRunner().invoke(main, [*RUNS[command], "--mavlink", "--mavlink-port", str(base), "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert f"UDP port {port}" in res.output and f"UAV 2's autopilot's {taken}" in res.output, res.output
    assert "Traceback" not in res.output and len(res.output.strip().splitlines()) == 1 and not out.exists()
