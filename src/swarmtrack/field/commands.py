"""``swarmtrack agent --field | monitor | stand-in``: the swarm without a world (:mod:`swarmtrack.field`).

Every process of a field swarm is given the same scenario, seed and overrides, the same key and the same ``--start``
(the swarm's t = 0): together they name the run (:func:`~swarmtrack.field.exchange.field_run`), so a process of
another scenario or start is not heard (its messages are dropped as ``other_run``).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import click
import numpy as np

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

#: Seconds between the stand-in's start and the swarm's t = 0 (its agents and monitor start, warm up and subscribe).
LEAD = 10.0


def _start(text: str) -> float:
    from swarmtrack.field.agent import start_time

    try:
        return start_time(text)
    except ValueError as exc:
        raise UsageFailure(f"--start {exc}") from None


def _node(scn, o: SimpleNamespace, me: int, epoch: float):
    """The process's node on the swarm, without a world: its transport (``--listen``, ``--connect``), its seal
    (the key; the run named by scenario and start)."""
    from swarmtrack.field.exchange import field_run
    from swarmtrack.live.agent import scenario_hash
    from swarmtrack.live.node import Node
    from swarmtrack.live.wire import Seal

    key = read_key(o.key_file, o.insecure)
    seal = Seal(key, scn.swarm.n_uavs, run=field_run(scenario_hash(scn), epoch))
    return Node(open_transport(o), seal, o.swarm or scn.name, me, world=False)


def _source(option: str, url: str | None, detection: bool = False):
    """A map source for ``url`` given to ``option`` (None: none), its URL checked."""
    if url is None:
        return None
    from swarmtrack.field.sources import SourceError, parse
    from swarmtrack.replay.mapping import DetectionSource, Source

    try:
        parse(url)
    except SourceError as exc:
        raise UsageFailure(f"{option} {exc}") from None
    return (DetectionSource if detection else Source)(topic=url)


def run_field_agent(o: SimpleNamespace) -> None:
    """``swarmtrack agent --field``: UAV ``o.uav``'s stack with its sources (``--navigation``, ``--detections`` or
    ``--map``), its autopilot and its peers (module docstring)."""
    require("field", "swarmtrack agent --field")
    from swarmtrack.autopilot.link import AutopilotError, AutopilotRefused
    from swarmtrack.field.agent import FieldAgent
    from swarmtrack.field.sources import SourceError
    from swarmtrack.replay.grid import followed_measurement
    from swarmtrack.replay.steps import LogError

    scn = agent_scenario(o)
    epoch = _start(o.start)
    navigation, detections, window = _source("--navigation", o.navigation), \
        _source("--detections", o.detections, detection=True), None
    if o.map is not None:
        from swarmtrack.replay.mapping import load_map

        try:
            mapping = load_map(o.map, scn)
        except LogError as exc:
            raise UsageFailure(str(exc)) from None
        entry = mapping.uavs.get(o.uav)
        if entry is None:
            raise UsageFailure(f"--map {o.map}: no uavs.{o.uav} (the map names UAVs "
                               f"{', '.join(map(str, mapping.uavs))})")
        if navigation is None:
            _source(f"--map {o.map}: uavs.{o.uav}.navigation", entry.navigation.topic)
            navigation = entry.navigation
        if detections is None and entry.detections is not None:
            _source(f"--map {o.map}: uavs.{o.uav}.detections", entry.detections.topic)
            detections = entry.detections
        window = mapping.window
    if navigation is None and o.autopilot is None:
        raise UsageFailure("--field: no navigation: give --autopilot URL, --navigation URL, or a --map naming it")
    if detections is None:
        raise UsageFailure("--field: no detections: give --detections URL, or a --map naming them")
    try:  # its sensor's measurements made from a relative position, of the one target its estimator follows
        followed_measurement(scn, "the field", "as replay does")
    except LogError as exc:
        raise UsageFailure(f"--field: {exc}") from None
    taps = o.outputs.taps(stamp_epoch=epoch)
    node = _node(scn, o, o.uav - 1, epoch)
    agent = FieldAgent(scn, o.uav - 1, node, epoch, navigation, detections, window or 1.0, o.autopilot, o.reengage,
                       o.wait, taps)
    try:
        agent.run()
    except (SourceError, AutopilotError) as exc:
        raise UsageFailure(f"UAV {o.uav}: {exc}") from None
    except AutopilotRefused as exc:
        click.echo(f"{exc}{'' if agent.flying else '; no setpoint was flown'}", err=True)
        sys.exit(3)
    except KeyboardInterrupt:
        sys.exit(130)
    finally:
        for source in agent.opened:
            source.close()
        for tap in taps:
            tap.close()
        if agent.link is not None:
            agent.link.close()
        node.close()


@click.command("monitor")
@scenario_options
@start_option()
@peer_options
@click.option("--truth", metavar="URL", default=None, help=(
    "the followed target's ground truth (motion capture, a simulator's topic): zenoh://KEY or ros2:///TOPIC, a pose "
    "type (docs/field.md); without it, no errors are computed"))
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), required=True, help="the run folder")
@click.option("--overwrite", is_flag=True, help="replace an earlier run in --out")
@click.option("--no-plots", is_flag=True, help="skip the PNG figures")
@output_options()
@security_options
def monitor_cmd(**options) -> None:
    """Join SCENARIO's field swarm read-only and record what its agents publish (their probes, commands and counts,
    and the truth when --truth is given) into the run folder --out; Ctrl-C keeps the steps recorded."""
    require("field", "swarmtrack monitor")
    from swarmtrack.field.inputs import FieldInputs
    from swarmtrack.field.monitor import MONITOR, Monitor
    from swarmtrack.field.sources import SourceError
    from swarmtrack.outputs import OutputError, Terminated, check_destination, run_folder
    from swarmtrack.replay.rosbag import Topics

    o = SimpleNamespace(**options)
    check_wire(o.tls, connect=o.connect, listen=o.listen)
    epoch = _start(o.start)
    scn = load_live(o.scenario, o.overrides, o.seed)
    truth = _source("--truth", o.truth)
    try:
        check_destination(o.out.absolute(), o.overwrite)
    except OutputError as exc:
        raise UsageFailure(str(exc)) from None
    taps = o.outputs.taps(stamp_epoch=epoch)
    node = _node(scn, o, MONITOR, epoch)
    inputs = source = None
    try:
        if truth is not None:
            inputs = FieldInputs(scn, None, epoch)
            source = _open_truth(truth, node, inputs, Topics())
        with run_folder(o.out, o.overwrite) as tmp:
            monitor = Monitor(scn, node, epoch, inputs, record_to=tmp / "recording", taps=taps)
            previous = signal.signal(signal.SIGINT, lambda *_: setattr(monitor, "stop", True))
            try:
                rec, report, tables = monitor.run()
            finally:
                signal.signal(signal.SIGINT, previous)
            if not rec.meta["n_steps"]:
                raise UsageFailure("monitor: stopped before its first step; nothing was written")
            metrics = write_live(tmp, rec, scn, report, tables, o.no_plots)
    except (OutputError, SourceError) as exc:
        raise UsageFailure(str(exc)) from None
    except (KeyboardInterrupt, Terminated):
        click.echo("interrupted; nothing was written", err=True)
        sys.exit(130)
    finally:
        if source is not None:
            source.close()
        for tap in taps:
            tap.close()
        node.close()
    report_run(metrics, scn, o.out)
    warn_run(metrics, strict=False)
    if report.interrupted is not None:
        click.echo(f"interrupted at t = {report.interrupted:.2f} s; the steps recorded were written to {o.out}",
                   err=True)
        sys.exit(130)


def _open_truth(truth, node, inputs, topics):
    """The monitor's truth source, subscribed (a ROS 2 topic waits up to 10 s for its publisher); what it says
    goes into ``inputs``."""
    from swarmtrack.field.sources import open_source, parse

    topics.add("truth", None, truth)

    def on_message(msgtype, msg, received):
        for item in topics.read(truth.topic, msgtype, msg, int(received * 1e9), inputs.counts):
            inputs.put(item)

    return open_source(parse(truth.topic), node.transport, on_message, lambda cause: inputs.skip(cause, truth.topic),
                       10.0)


@click.command("stand-in")
@scenario_options
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="the monitor's run folder")
@click.option("--overwrite", is_flag=True, help="replace an earlier run in --out")
@click.option("--no-plots", is_flag=True, help="skip the PNG figures")
@click.option("--lead", type=click.FloatRange(min=1.0), default=LEAD, show_default=True, metavar="SECONDS",
              help="seconds from now to the swarm's t = 0 (its processes start, warm up and subscribe meanwhile)")
@click.option("--kill", "kills", multiple=True, metavar="UAV@T",
              help="kill UAV's agent (SIGKILL) at run time T s, as a companion computer that dies (repeatable)")
@click.option("--mavlink-port", type=click.IntRange(1, 65535 - 4030 - 1024), default=14540, show_default=True,
              metavar="PORT", help="UAV i's vehicle sends to 127.0.0.1:PORT + i - 1 (as PX4 SITL instance i - 1)")
def standin_cmd(**options) -> None:
    """Run SCENARIO as a field deployment on this machine, with nothing a real one lacks: each UAV's vehicle over
    MAVLink, its camera on its own Zenoh topic, its agent (swarmtrack agent --field) hearing the others directly,
    and a monitor recording into --out; no world process plays the radio."""
    require("field", "swarmtrack stand-in")
    from swarmtrack.autopilot.fleet import VehicleError, check_ports
    from swarmtrack.field.camera import CameraWorld, detections_key, truth_key
    from swarmtrack.field.monitor import MONITOR
    from swarmtrack.live.transport import free_port
    from swarmtrack.live.wire import keygen
    from swarmtrack.outputs import OutputError, check_destination

    o = SimpleNamespace(**options)
    scn = load_live(o.scenario, o.overrides, o.seed)
    kills = {}
    for text in o.kills:
        uav, _, at = text.partition("@")
        try:
            kills[int(uav)] = float(at)
        except ValueError:
            raise UsageFailure(f"--kill {text!r}: expected UAV@T, e.g. 2@30") from None
        if not 1 <= int(uav) <= scn.swarm.n_uavs:
            raise UsageFailure(f"--kill {text}: the swarm of {scn.name} has UAVs 1..{scn.swarm.n_uavs}")
    try:
        check_destination(o.out.absolute(), o.overwrite)
        check_ports(scn.swarm.n_uavs, o.mavlink_port)
    except (OutputError, VehicleError) as exc:
        raise UsageFailure(str(exc)) from None
    swarm = f"{scn.name}-{os.getpid()}"
    epoch = time.time() + o.lead
    with tempfile.TemporaryDirectory(prefix="swarmtrack-stand-in-") as keys:  # its own key, removed with it
        key_file = Path(keys) / "swarm.key"
        key_file.write_text(keygen().hex() + "\n")
        key_file.chmod(0o600)
        world_port = free_port()
        opts = SimpleNamespace(key_file=key_file, insecure=False, listen=[f"tcp/127.0.0.1:{world_port}"], connect=[],
                               connect_timeout=5.0, tls=None, swarm=swarm)
        node = _node(scn, opts, MONITOR, epoch)
        env = {**{k: v for k, v in os.environ.items() if k not in ENV.values()}, ENV["swarm"]: swarm,
               ENV["key"]: str(key_file)}
        common = [o.scenario, "--start", repr(epoch), "--connect", f"tcp/127.0.0.1:{world_port}"]
        common += ["--seed", str(o.seed)] if o.seed is not None else []
        for override in o.overrides:
            common += ["--set", override]
        procs: dict[str, subprocess.Popen] = {}
        camera = None
        try:
            camera = CameraWorld(scn, node, epoch, swarm, o.mavlink_port)
            procs["monitor"] = subprocess.Popen(
                [sys.executable, "-m", "swarmtrack", "monitor", *common, "--listen", f"tcp/127.0.0.1:{free_port()}",
                 "--truth", f"zenoh://{truth_key(swarm)}", "--out", str(o.out),
                 *(["--overwrite"] if o.overwrite else []), *(["--no-plots"] if o.no_plots else [])], env=env)
            for i in range(1, scn.swarm.n_uavs + 1):
                procs[str(i)] = subprocess.Popen(
                    [sys.executable, "-m", "swarmtrack", "agent", "--field", "--uav", str(i), *common,
                     "--listen", f"tcp/127.0.0.1:{free_port()}",
                     "--autopilot", f"udp://127.0.0.1:{o.mavlink_port + i - 1}",
                     "--detections", f"zenoh://{detections_key(swarm, i)}", "--wait", str(o.lead + 10)], env=env)
            _run_camera(camera, kills, procs, epoch)
            code = procs["monitor"].wait(timeout=60)
        except KeyboardInterrupt:
            if camera is not None:
                camera.stop = True
            code = 130
        finally:
            if "monitor" in procs and procs["monitor"].poll() is None:
                procs["monitor"].send_signal(signal.SIGINT)  # it writes the steps recorded
                try:
                    procs["monitor"].wait(timeout=60)
                except subprocess.TimeoutExpired:
                    pass
            stop_agents(list(procs.values()))
            if camera is not None:
                camera.close()
            node.close()
    sys.exit(code)


def _run_camera(camera, kills: dict[int, float], procs: dict, epoch: float) -> None:
    """The camera world's steps in this thread; the kills at their times from another."""
    import threading

    def killer() -> None:
        for uav, at in sorted(kills.items(), key=lambda item: item[1]):
            while time.time() < epoch + at and not camera.stop:
                time.sleep(0.05)
            proc = procs.get(str(uav))
            if proc is not None and proc.poll() is None:
                click.echo(f"stand-in: killing UAV {uav}'s agent (process {proc.pid}) at t = {at:g} s", err=True)
                proc.kill()

    thread = threading.Thread(target=killer, daemon=True)
    thread.start()
    camera.run()
    camera.stop = True
    thread.join(1.0)
    e2e = 1e3 * camera.end_to_end()
    if len(e2e):
        click.echo(f"stand-in: a detection's publication to its fused estimate heard on the network: median "
                   f"{np.median(e2e):.2f} ms, p99 {np.percentile(e2e, 99):.2f} ms ({len(e2e)} steps)", err=True)
