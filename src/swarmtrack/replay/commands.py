"""``swarmtrack replay LOG... --scenario FILE|NAME [--map MAP.yaml] --out DIR``: a scenario's onboard stack on
recorded flights, written as a run folder."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from swarmtrack.cli_support import UsageFailure, report_run, warn_run, write_run


def _formats() -> list[str]:
    from swarmtrack import registry

    return sorted(registry.kinds(registry.READER))


@click.command("replay")
@click.argument("logs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--scenario", "scenario", default=None, metavar="FILE|NAME",
              help="the scenario whose onboard stack runs (default for a run folder: the run's own scenario)")
@click.option("--map", "map_file", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="which topic or field holds each UAV's navigation and detections, and the ground truth "
                   "(docs/replay.md)")
@click.option("--format", "fmt", default=None, metavar="NAME",
              help="the logs' reader (default: recognised from the first log); see docs/replay.md")
@click.option("--out", "out", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="output folder (default: runs/replay-<scenario>-seed<seed>)")
@click.option("--overwrite", is_flag=True, help="replace an earlier run in --out (only the files its manifest lists)")
@click.option("--seed", type=int, default=None, help="override the scenario's seed (the channel's draws)")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
              help="override a scenario key, e.g. --set estimator.model=cv (repeatable)")
@click.option("--no-plots", is_flag=True, help="skip the PNG figures")
@click.option("--strict", is_flag=True, help="exit with code 3 when the replay has warnings")
def replay_cmd(logs: tuple[Path, ...], scenario: str | None, map_file: Path | None, fmt: str | None,
               out: Path | None, overwrite: bool, seed: int | None, overrides: tuple[str, ...], no_plots: bool,
               strict: bool) -> None:
    """Run a scenario's onboard stack (its estimator; the controller is not run) on recorded navigation and
    detections instead of a simulated world: LOGS are a swarmtrack run folder, ROS bags (ROS 1, ROS 2 sqlite3 or
    MCAP), PX4 ULog files or CSV files. The messages between UAVs are computed by the scenario's channel, as the
    simulator computes them. Writes the same run folder as swarmtrack run (errors only where the logs hold ground
    truth)."""
    from rich.progress import Progress

    from swarmtrack.estimation.information import FilterDivergence
    from swarmtrack.outputs import OutputError, Terminated, run_folder
    from swarmtrack.replay.engine import replay
    from swarmtrack.replay.mapping import load_map
    from swarmtrack.replay.steps import LogError
    from swarmtrack.scenarios.loader import ScenarioError, load_scenario

    try:
        reader = _reader(fmt, logs)
        if scenario is None:
            if reader.name != "run" or not (logs[0] / "scenario.yaml").is_file():
                raise UsageFailure("--scenario FILE|NAME is needed (only a run folder brings its own)")
            scenario = str(logs[0] / "scenario.yaml")
        scn = load_scenario(scenario, list(overrides), seed)
        mapping = None if map_file is None else load_map(map_file, scn)
        if mapping is None and reader.needs_map:
            raise UsageFailure(f"--map MAP.yaml is needed to read {reader.name} logs (docs/replay.md)")
        counts: dict[str, int] = {}
        steps = reader.open(list(logs), scn, mapping, counts)
        out = out or Path("runs") / f"replay-{scn.name}-seed{scn.seed}"
        source = {"format": reader.name, "logs": [str(p) for p in logs],
                  "map": None if map_file is None else str(map_file)}
        with run_folder(out, overwrite) as tmp:
            with Progress(transient=True, disable=not sys.stderr.isatty()) as bar:
                task = bar.add_task(f"replaying {len(logs)} log(s) through {scn.name}", total=1.0)
                rec = replay(scn, steps, tmp / "recording", lambda done: bar.update(task, completed=done), source,
                             phases=reader.phases)
            metrics = write_run(rec, scn, tmp, no_plots=no_plots, extra={"replay": {**source, "skipped": counts}},
                                warnings=_warnings(counts))
    except (ScenarioError, LogError, FilterDivergence, OutputError) as exc:
        raise UsageFailure(str(exc)) from None
    except (KeyboardInterrupt, Terminated):
        click.echo("interrupted; nothing was written", err=True)
        sys.exit(130)
    report_run(metrics, scn, out)
    warn_run(metrics, strict)


def _reader(fmt: str | None, logs: tuple[Path, ...]):
    """The reader named by ``--format``, or the first registered one that recognises the first log."""
    from swarmtrack import registry

    for log in logs:
        if not log.exists():
            raise UsageFailure(f"{log}: no such file or folder")
    if fmt is not None:
        try:
            return registry.get(registry.READER, fmt)
        except registry.UnknownKind:
            raise UsageFailure(f"--format {fmt}: unknown; known: {', '.join(_formats())}") from None
    for reader in registry.kinds(registry.READER).values():
        if reader.recognises(logs[0]):
            return reader
    raise UsageFailure(f"{logs[0]}: not a log any reader recognises ({', '.join(_formats())}); name one with "
                       "--format")


def _warnings(counts: dict[str, int]) -> list[dict]:
    """One warning per kind of message skipped mid-log (they are counted, not fatal)."""
    return [{"kind": "replay_skipped", "t_start": None, "t_end": None,
             "message": f"replay: {n} message(s) skipped: {why}"} for why, n in sorted(counts.items()) if n]
