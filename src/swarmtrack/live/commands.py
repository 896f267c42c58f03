"""``swarmtrack live | world | agent | keygen``: the live swarm's commands.

``live`` is the world process (truth, physics, sensors, the simulated radio, the recorder) and starts one
``swarmtrack agent --uav I`` process per UAV; ``world`` is the same without starting them (agents join from elsewhere);
``agent`` is one UAV's onboard stack; ``keygen`` writes a swarm key. Every process of a swarm must be given the same
scenario, seed and overrides (the world refuses a UAV whose resolved scenario differs) and the same key.

What ``ps`` must not show is taken from the environment too (:data:`ENV`): ``live`` gives its UAV processes the key
file, the swarm's name and the TLS folder that way, never on their command lines.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import click

from swarmtrack.cli_support import UsageFailure, report_run, warn_run
from swarmtrack.extras import require
from swarmtrack.live.launch import (
    ENV,
    agent_scenario,
    check_wire,
    load_live,
    open_transport,
    peer_options,
    read_key,
    scenario_options,
    security_options,
    start_option,
    stop_agents,
    write_live,
)
from swarmtrack.streams.options import output_options


@click.command("keygen")
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
def keygen_cmd(file: Path) -> None:
    """Write a new swarm key to FILE (readable by its owner only); an existing FILE is never replaced."""
    require("live", "swarmtrack keygen", ["msgspec"])  # the wire module makes the key
    from swarmtrack.live.wire import keygen

    try:
        fd = os.open(file, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:
        raise UsageFailure(f"{file}: a file is already there (a key is never replaced)") from None
    except OSError as exc:
        raise UsageFailure(f"{file}: {exc.strerror or exc}") from None
    with os.fdopen(fd, "w") as f:
        f.write(keygen().hex() + "\n")
    click.echo(f"swarm key written to {file}")


@click.command("agent")
@scenario_options
@click.option("--uav", type=int, required=True, help="which UAV this process is (1..N)")
@peer_options
@click.option("--rejoin", is_flag=True, help="this UAV's earlier process was lost: start afresh where the swarm is")
@click.option("--autopilot", metavar="URL", default=None, help=(
    "fly through this UAV's autopilot over MAVLink: udp://[HOST]:PORT (listen there, as PX4 SITL's 14540 + i) or "
    "serial://DEVICE[:BAUD]; its navigation comes from it and its commands go to it as setpoints"))
@click.option("--reengage-after-link-loss", "reengage", is_flag=True, help=(
    "DANGEROUS, opt-in: engage the vehicle again by itself after the autopilot's offboard-loss failsafe that followed "
    "a silence of this link (never after a mode change while the link was heard, never a disarmed or landed vehicle): "
    "a pilot who took the vehicle while the link was down loses it again (docs/autopilot.md)"))
@click.option("--field", is_flag=True, help=(
    "no world: navigation from --autopilot or --navigation, detections from --detections (or a --map), the "
    "neighbours heard directly over Zenoh, steps on this machine's clock from --start (docs/field.md)"))
@start_option("--field: ")
@click.option("--navigation", metavar="URL", default=None,
              help="--field: its navigation's source, zenoh://KEY or ros2:///TOPIC (default: its autopilot's)")
@click.option("--detections", metavar="URL", default=None,
              help="--field: its detections' source, zenoh://KEY or ros2:///TOPIC (docs/field.md)")
@click.option("--map", "map", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="--field: a map file naming its sources (the format of swarmtrack replay --map)")
@click.option("--wait", type=click.FloatRange(min=0, min_open=True), default=10.0, show_default=True,
              metavar="SECONDS", help="--field: give up on a source whose first message does not come within this time")
@output_options(foxglove=False)
@security_options
def agent_cmd(**options) -> None:
    """Run UAV --uav's onboard stack (estimator, controller) of SCENARIO, as on its companion computer: its
    navigation, detections and radio from the world (or its navigation from its autopilot, --autopilot), its
    neighbours' messages over Zenoh; with --field, no world: its own sensor's topic and the real network."""
    if options["field"]:
        from swarmtrack.field.commands import run_field_agent

        run_field_agent(SimpleNamespace(**options))
        return
    if options["outputs"].ros2:
        raise UsageFailure("--ros2 on an agent needs --field (a live world publishes its whole swarm: swarmtrack live "
                           "--ros2)")
    require("live", "swarmtrack agent")
    if (options["autopilot"] or "").startswith("serial://"):
        require("autopilot", "swarmtrack agent --autopilot serial://", ["pyserial"])
    from swarmtrack.autopilot.link import AutopilotError, AutopilotRefused
    from swarmtrack.live.agent import Agent
    from swarmtrack.live.node import Mismatch, Node, Stopped
    from swarmtrack.live.wire import Seal

    o = SimpleNamespace(**options)
    uav = o.uav
    scn = agent_scenario(o)
    key = read_key(o.key_file, o.insecure)
    node = Node(open_transport(o), Seal(key, scn.swarm.n_uavs), o.swarm or scn.name, uav - 1)
    agent = Agent(scn, uav - 1, node, o.autopilot, o.reengage)
    try:
        agent.run(o.rejoin)
    except Stopped as exc:
        if str(exc) != "done":
            click.echo(f"UAV {uav}: {exc}; stopping", err=True)
            sys.exit(1)
    except (Mismatch, AutopilotError) as exc:
        raise UsageFailure(str(exc) if str(exc).startswith("UAV") else f"UAV {uav}: {exc}") from None
    except AutopilotRefused as exc:
        click.echo(f"{exc}{'' if agent.flying else '; no setpoint was flown'}", err=True)
        sys.exit(3)
    except KeyboardInterrupt:  # Ctrl-C reaches the whole process group: the world writes what was completed
        sys.exit(130)
    except TimeoutError as exc:
        click.echo(f"UAV {uav}: {exc}; stopping", err=True)
        sys.exit(1)
    finally:
        if agent.link is not None:
            agent.link.close()
        node.close()  # its heartbeat stopped and joined, then the transport: nothing of Zenoh runs at exit


@click.command("engage")
@click.option("--uav", type=click.IntRange(min=1, max=254), required=True,
              help="which UAV (1..N: its vehicle's MAVLink system id)")
@click.option("--to", "to", required=True, metavar="HOST:PORT", help=(
    "the autopilot's ground-station link, sent to over UDP (UAV i's simulated vehicle: 127.0.0.1:PORT + 4030 + i - 1 "
    "with world --mavlink-port PORT, 18570 + i - 1 by default; PX4 SITL instance i: 18570 + i)"))
@click.option("--release", is_flag=True, help="hand the vehicle back to its autopilot instead (Hold)")
@click.option("--timeout", type=click.FloatRange(min=0, min_open=True), default=5.0, show_default=True,
              metavar="SECONDS", help="wait this long for the answer")
def engage_cmd(**options) -> None:
    """Ask UAV --uav's swarmtrack agent to fly its vehicle again after a handover to the operator (or, with
    --release, to hand it back), through the autopilot's ground-station link at --to. Exit 0: done; 3: refused
    (the reason is printed); 1: no answer."""
    require("autopilot", "swarmtrack engage", ["pymavlink"])  # over UDP: no serial link
    from pymavlink.dialects.v20 import common as mavlink

    from swarmtrack.autopilot import px4
    from swarmtrack.autopilot.engage import request

    o = SimpleNamespace(**options)
    host, _, port = o.to.rpartition(":")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise UsageFailure(f"--to {o.to}: expected HOST:PORT, PORT 1..65535")
    what = "hand its vehicle back" if o.release else "engage"
    result, said = request(o.to, o.uav - 1, not o.release, o.timeout)
    reason = f" ({'; '.join(said)})" if said else ""
    if result is None:
        click.echo(f"UAV {o.uav}: no answer to the request to {what} within {o.timeout:g} s through {o.to} (is its "
                   "agent running with --autopilot, and does its autopilot forward to it: PX4's MAV_x_FORWARD?)",
                   err=True)
        sys.exit(1)
    if result != mavlink.MAV_RESULT_ACCEPTED:
        click.echo(f"UAV {o.uav}: its agent refused to {what}: {px4.result_name(result)}{reason}", err=True)
        sys.exit(3)
    click.echo(f"UAV {o.uav}: {'handed back' if o.release else 'engaged'}{reason}")


def _live_options(f):
    f = output_options()(f)
    f = click.option("--mavlink-gcs", type=click.IntRange(1, 65535), default=None, metavar="PORT", help=(
        "with --mavlink, the vehicles' ground-station links send to 127.0.0.1:PORT (as PX4 SITL's to 14550, where "
        "QGroundControl listens); without it, a ground station claims UAV i's by sending to its port, "
        "--mavlink-port + 4030 + i - 1 (18570 + i - 1 by default)"))(f)
    f = click.option("--mavlink-port", type=click.IntRange(1, 65535 - 4030 - 1024), default=14540, show_default=True,
                     metavar="PORT", help=(
                         "with --mavlink, UAV i's autopilot sends to 127.0.0.1:PORT + i - 1 from its port PORT + 40 + "
                         "i - 1, as PX4 SITL instance i - 1 (a port another vehicle holds is refused)"))(f)
    f = click.option("--mavlink", is_flag=True, help=(
        "fly every UAV through a simulated PX4-like autopilot it talks MAVLink to (swarmtrack agent --autopilot)"))(f)
    f = click.option("--realtime", is_flag=True, help=(
        "run at wall-clock rate: messages arrive when they arrive, late ones are fused at their time stamps within "
        "network.delay_max (default: lockstep, the numbers of swarmtrack run)"))(f)
    f = click.option("--listen", multiple=True, metavar="ENDPOINT",
                     help="where the world listens (default: a free port on 127.0.0.1)")(f)
    f = click.option("--no-plots", is_flag=True, help="skip the PNG figures")(f)
    f = click.option("--strict", is_flag=True, help="exit with code 3 when the run has warnings")(f)
    f = click.option("--overwrite", is_flag=True, help="replace an earlier run in --out")(f)
    return click.option("--out", "out", type=click.Path(file_okay=False, path_type=Path), default=None,
                        help="output folder (default: runs/<name>-seed<seed>-<hash>-live)")(f)


@click.command("live")
@scenario_options
@_live_options
@security_options
def live_cmd(**options) -> None:
    """Run SCENARIO with every UAV's onboard stack in its own process (swarmtrack agent --uav I), talking over
    Eclipse Zenoh on loopback with this world process: in lockstep (the run folder of swarmtrack run, with the same
    numbers) or at wall-clock rate (--realtime)."""
    require("live", "swarmtrack live")
    _serve(SimpleNamespace(**options), spawn=True)


@click.command("world")
@scenario_options
@_live_options
@security_options
def world_cmd(**options) -> None:
    """Run the truth side of SCENARIO alone (world, sensors, simulated radio, recorder) and wait for its UAVs'
    processes (swarmtrack agent --uav I --connect ENDPOINT) to join."""
    require("live", "swarmtrack world")
    _serve(SimpleNamespace(**options), spawn=False)


def _serve(o: SimpleNamespace, spawn: bool) -> None:
    """The world process of a live run: ``o`` the command's options; ``spawn``: start the UAVs' processes."""
    from swarmtrack.analysis.runs import run_key
    from swarmtrack.autopilot.fleet import VehicleError, check_ports
    from swarmtrack.live.node import Node
    from swarmtrack.live.session import run_live
    from swarmtrack.live.transport import TransportError, ZenohTransport, free_port
    from swarmtrack.live.wire import WORLD, Seal
    from swarmtrack.live.world import LiveError
    from swarmtrack.onboard.context import command_width
    from swarmtrack.outputs import OutputError, Terminated, check_destination, run_folder, terminate_as_exception

    check_wire(o.tls, listen=o.listen)
    try:
        with terminate_as_exception():  # Ctrl-C or SIGTERM while it starts: one message, exit 130
            scn = load_live(o.scenario, o.overrides, o.seed)
            if o.mavlink and command_width(scn) != 2:
                raise UsageFailure(f"--mavlink flies planar acceleration setpoints: swarm.vehicle "
                                   f"{scn.swarm.vehicle} is commanded otherwise")
            key = read_key(o.key_file, o.insecure)
            taps = o.outputs.taps()
            if o.mavlink:
                try:
                    check_ports(scn.swarm.n_uavs, o.mavlink_port)
                except VehicleError as exc:
                    raise UsageFailure(f"--mavlink: {exc}") from None
            out = o.out or Path("runs") / f"{scn.name}-seed{scn.seed}-{run_key(scn)[:8]}-live"
            try:
                check_destination(out.absolute(), o.overwrite)
            except OutputError as exc:
                raise UsageFailure(str(exc)) from None
            endpoints = list(o.listen) or [f"{'tcp' if o.tls is None else 'tls'}/127.0.0.1:{free_port()}"]
            try:
                transport = ZenohTransport(listen=endpoints, tls=o.tls)
            except TransportError as exc:
                raise UsageFailure(str(exc)) from None
    except (KeyboardInterrupt, Terminated):
        click.echo("interrupted; nothing was written", err=True)
        sys.exit(130)
    swarm = o.swarm or (f"{scn.name}-{os.getpid()}" if spawn else scn.name)
    node = Node(transport, Seal(key, scn.swarm.n_uavs), swarm, WORLD)
    procs: list[subprocess.Popen] = []
    try:
        with run_folder(out, o.overwrite) as tmp:
            if spawn:
                procs = start_agents(scn, o.scenario, o.seed, o.overrides, endpoints, swarm, o.key_file,
                                     o.mavlink_port if o.mavlink else None, tls=o.tls)
            else:
                click.echo(f"world of {scn.name} listening on {', '.join(endpoints)} (swarm {swarm}); waiting for "
                           f"UAVs 1..{scn.swarm.n_uavs}", err=True)
            children = {p.pid: p for p in procs}
            rec, live, tables = run_live(scn, node, record_to=tmp / "recording", realtime=o.realtime,
                                         mavlink=(o.mavlink_port, "127.0.0.1", o.mavlink_gcs) if o.mavlink else None,
                                         running=lambda pid: pid in children and children[pid].poll() is None,
                                         taps=taps)
            stop_agents(procs)  # within GRACE s of the end (or of Ctrl-C), before the files are written
            if live.interrupted is not None and not rec.meta["n_steps"]:
                raise _NothingRecorded()  # stopped before its first step: there is no run to write
            metrics = write_live(tmp, rec, scn, live, tables, o.no_plots)
    except (OutputError, LiveError, VehicleError) as exc:
        raise UsageFailure(str(exc)) from None
    except TimeoutError as exc:
        raise UsageFailure(f"the live run stopped: {exc}") from None
    except (KeyboardInterrupt, Terminated, _NothingRecorded) as exc:
        when = " before the first step" if isinstance(exc, _NothingRecorded) else ""
        click.echo(f"interrupted{when}; nothing was written", err=True)
        sys.exit(130)
    finally:
        stop_agents(procs)
        node.close()  # its heartbeat stopped and joined, then the transport: nothing of Zenoh runs at exit
    report_run(metrics, scn, out)
    rejected = metrics["live"]["rejected"]
    click.echo(f"live ({scn.swarm.n_uavs} UAV processes, {live.mode}): " + _facts(live) + (
        "messages dropped: " + ", ".join(f"{n} {cause}" for cause, n in sorted(rejected.items()))
        if rejected else "no message dropped"))
    if live.interrupted is not None:
        warn_run(metrics, strict=False)
        click.echo(f"interrupted at t = {live.interrupted:.2f} s; the steps completed were written to {out}", err=True)
        sys.exit(130)
    warn_run(metrics, o.strict)


class _NothingRecorded(Exception):
    """Ctrl-C or SIGTERM stopped the live run before its first step was recorded."""


def _facts(live) -> str:
    """The live run's figures in a few words: CPU per step, in real time latency and lateness."""
    out = []
    if live.cpu_per_step_ms is not None:
        out.append(f"CPU per UAV step {live.cpu_per_step_ms['median']:.2f} ms (median)")
    if live.step_lateness is not None:
        share = live.latency_ms.get("share")
        if share is not None:
            out.append(f"share latency {share['median']:.2f} ms (p99 {share['p99']:.2f})")
        out.append(f"steps done {live.step_lateness['p99']:.2f} periods late at the 99th percentile")
        missed = {ch: n for ch, n in live.late.items() if n and ch != "share_fused_late"}
        if missed:
            out.append("missed deadlines: " + ", ".join(f"{n} {ch}" for ch, n in sorted(missed.items())))
    return "; ".join(out) + "; " if out else ""


def start_agents(scn, scenario: str, seed, overrides, endpoints: list[str], swarm: str, key_file,
                 mavlink_port: int | None = None, tls: Path | None = None) -> list:
    """One ``swarmtrack agent --uav I`` process per UAV, connecting to the world's first endpoint (and with
    ``mavlink_port``, to its autopilot at ``udp://127.0.0.1:mavlink_port + I - 1``). The key file, the swarm's name
    and the TLS folder go in their environment (:data:`ENV`), not on their command lines."""
    connect = endpoints[0].replace("0.0.0.0", "127.0.0.1")
    common = [scenario, "--connect", connect]
    common += ["--seed", str(seed)] if seed is not None else []
    for o in overrides:
        common += ["--set", o]
    common += [] if key_file is not None else ["--insecure"]
    env = {name: value for name, value in os.environ.items() if name not in ENV.values()}
    env[ENV["swarm"]] = swarm
    if key_file is not None:
        env[ENV["key"]] = str(Path(key_file).absolute())
    if tls is not None:
        env[ENV["tls"]] = str(Path(tls).absolute())

    def autopilot(i: int) -> list[str]:
        return [] if mavlink_port is None else ["--autopilot", f"udp://127.0.0.1:{mavlink_port + i}"]

    return [subprocess.Popen([sys.executable, "-m", "swarmtrack", "agent", "--uav", str(i + 1), *common, *autopilot(i)],
                             env=env) for i in range(scn.swarm.n_uavs)]


def swarm_processes(swarm: str) -> list[str]:
    """``"PID ARGS"`` of this user's processes of ``swarm`` (Linux): those given ``--swarm SWARM`` on their command
    line or ``SWARMTRACK_SWARM=SWARM`` in their environment (the UAV processes ``live`` started)."""
    out = []
    for proc in Path("/proc").glob("[0-9]*"):
        try:
            args = proc.joinpath("cmdline").read_bytes().decode(errors="replace").split("\0")[:-1]
            env = proc.joinpath("environ").read_bytes().decode(errors="replace").split("\0")
        except OSError:  # another user's, or gone
            continue
        flagged = any(a == "--swarm" and b == swarm for a, b in zip(args, args[1:], strict=False))
        if flagged or f"{ENV['swarm']}={swarm}" in env:
            out.append(f"{proc.name} {' '.join(args)}")
    return out
