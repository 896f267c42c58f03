"""What every live process's command checks and opens first (its scenario, key, endpoints, autopilot URL and
transport: the live swarm's and the field's), and how a command ends the processes it started."""

from __future__ import annotations

import dataclasses
import signal
import subprocess
import time
from pathlib import Path
from types import SimpleNamespace

import click

from swarmtrack.cli_support import UsageFailure, write_run
from swarmtrack.scenarios.loader import ScenarioError, load_scenario

#: Seconds the processes a run started get to end after SIGTERM before they are killed.
GRACE = 2.0

#: The environment variables the options below are read from when not given (``live`` starts its UAV processes so):
#: a command line is visible to every local user (``ps``), a process's environment to its owner only.
ENV = {"key": "SWARMTRACK_KEY_FILE", "swarm": "SWARMTRACK_SWARM", "tls": "SWARMTRACK_TLS"}


def scenario_options(f):
    f = click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
                     help="override a scenario key (repeatable); the same on every process of a swarm")(f)
    f = click.option("--seed", type=int, default=None, help="override the scenario's seed")(f)
    return click.argument("scenario", default="l24-ct")(f)


def security_options(f):
    f = click.option("--tls", "tls", type=click.Path(path_type=Path), default=None, envvar=ENV["tls"],
                     metavar="DIR", help=(
                         "encrypt every link with Zenoh's mutual TLS: DIR holds ca.pem, cert.pem and key.pem "
                         f"(docs/live.md, \"TLS\"); endpoints are then tls/HOST:PORT [env {ENV['tls']}]"))(f)
    f = click.option("--insecure", is_flag=True, help="run without a swarm key: messages are not authenticated")(f)
    f = click.option("--key", "key_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
                     envvar=ENV["key"], help=(
                         "the swarm key (swarmtrack keygen FILE): messages are sealed and checked with it "
                         f"[env {ENV['key']}]"))(f)
    return click.option("--swarm", default=None, envvar=ENV["swarm"],
                        help=f"the swarm's name in the key space (default: the scenario's) [env {ENV['swarm']}]")(f)


def peer_options(f):
    """Where a process joins the swarm: ``--connect``, ``--listen``, ``--connect-timeout`` (:func:`open_transport`)."""
    f = click.option("--connect-timeout", type=click.FloatRange(min=0, min_open=True), default=5.0,
                     show_default=True, metavar="SECONDS",
                     help="give up on a --connect peer that does not answer within this time")(f)
    f = click.option("--listen", multiple=True, metavar="ENDPOINT", help="listen there too (other peers may join)")(f)
    return click.option("--connect", multiple=True, metavar="ENDPOINT",
                        help="a peer to join, e.g. tcp/127.0.0.1:7447")(f)


def start_option(when: str = ""):
    """``--start``: a field swarm's t = 0 on the wall clock (``when``: the help's prefix, e.g. ``--field: ``)."""
    return click.option("--start", default="next:10", show_default=True, metavar="TIME", help=(
        f"{when}the swarm's t = 0 on the wall clock: Unix seconds, an ISO 8601 time with its zone, or next:S (the "
        "next multiple of S s); the same on every process of the swarm"))


def write_live(folder: Path, rec, scn, report, tables: dict, no_plots: bool) -> dict:
    """A live run's files besides its recording, into ``folder`` (staged): ``live/<table>.parquet`` (latencies,
    steps), then the run's own (:func:`~swarmtrack.cli_support.write_run`, ``report`` under ``live`` in
    ``metrics.json`` with its warnings); returns the metrics."""
    if tables:
        (folder / "live").mkdir()
        for name, table in tables.items():
            table.to_parquet(folder / "live" / f"{name}.parquet", index=False)
    return write_run(rec, scn, folder, no_plots=no_plots, extra={"live": dataclasses.asdict(report)},
                     warnings=report.warnings())


def check_wire(tls: Path | None, **endpoints) -> None:
    """Refuse, naming the flag, a TLS folder without its files and an endpoint Zenoh would not take
    (``endpoints``: each flag's name, without its dashes, and the endpoints given to it)."""
    from swarmtrack.live.transport import endpoint_problem, tls_problem

    if tls is not None and (problem := tls_problem(tls)):
        raise UsageFailure(f"--tls {problem}")
    for flag, given in endpoints.items():
        for endpoint in given:
            if problem := endpoint_problem(endpoint, tls is not None):
                raise UsageFailure(f"--{flag.replace('_', '-')} {problem}")


def check_autopilot(url: str | None) -> None:
    """Refuse, naming the flag, an ``--autopilot`` URL the link could not open as written."""
    if url is None:
        return
    from swarmtrack.autopilot.link import device_of

    try:
        device, baud = device_of(url)
    except ValueError as exc:
        raise UsageFailure(f"--autopilot {exc}") from None
    port = device.rpartition(":")[2] if url.startswith("udp://") else None
    if port is not None and not 0 < int(port) < 65536:
        raise UsageFailure(f"--autopilot {url}: port {port} is not a UDP port (1..65535)")
    if port is None and (not device or baud <= 0):
        raise UsageFailure(f"--autopilot {url}: expected serial://DEVICE[:BAUD] with a positive BAUD")


def agent_scenario(o: SimpleNamespace):
    """What every agent checks first (``o``: its options): its endpoints, its autopilot's URL, its scenario and its
    UAV's number; returns the scenario."""
    check_wire(o.tls, connect=o.connect, listen=o.listen)
    check_autopilot(o.autopilot)
    scn = load_live(o.scenario, o.overrides, o.seed)
    if not 1 <= o.uav <= scn.swarm.n_uavs:
        raise UsageFailure(f"--uav {o.uav}: the swarm of {scn.name} has UAVs 1..{scn.swarm.n_uavs}")
    return scn


def open_transport(o: SimpleNamespace):
    """The process's Zenoh transport (``o``: its ``--listen``, ``--connect``, ``--connect-timeout`` and ``--tls``);
    one that cannot start is a :class:`~swarmtrack.cli_support.UsageFailure` naming the cause."""
    from swarmtrack.live.transport import TransportError, ZenohTransport

    try:
        return ZenohTransport(listen=list(o.listen), connect=list(o.connect), timeout=o.connect_timeout, tls=o.tls)
    except TransportError as exc:
        raise UsageFailure(str(exc)) from None


def read_key(key_file: Path | None, insecure: bool) -> bytes | None:
    """The swarm key in ``key_file`` (hex), None with ``insecure``; refuses to run with neither."""
    if key_file is None:
        if not insecure:
            raise UsageFailure("no swarm key: give --key FILE (make one with swarmtrack keygen FILE), or --insecure "
                               "to run with unauthenticated messages")
        return None
    try:
        key = bytes.fromhex(key_file.read_text().strip())
    except OSError as exc:
        raise UsageFailure(f"--key {key_file}: {exc.strerror or exc}") from None
    except ValueError:
        raise UsageFailure(f"--key {key_file}: not a key written by swarmtrack keygen (hex)") from None
    if len(key) < 16:
        raise UsageFailure(f"--key {key_file}: a key of {len(key)} bytes is too short (at least 16)")
    return key


def load_live(scenario: str, overrides, seed):
    from swarmtrack.live.world import LiveError, check_live

    try:
        scn = load_scenario(scenario, list(overrides), seed)
        check_live(scn)
    except (ScenarioError, LiveError) as exc:
        raise UsageFailure(str(exc)) from None
    return scn


def stop_agents(procs: list) -> None:
    """End the processes by their ids: SIGTERM, then SIGKILL after :data:`GRACE` s."""
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
    deadline = time.monotonic() + GRACE
    for p in procs:
        try:
            p.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()
