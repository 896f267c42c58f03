"""``swarmtrack replay LOG... --scenario FILE|NAME [--map MAP.yaml] --out DIR``: a scenario's onboard stack on
recorded flights, written as a run folder."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from swarmtrack.cli_support import UsageFailure, report_run, warn_run, write_run
from swarmtrack.streams.options import Outputs, output_options


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
@output_options()
def replay_cmd(logs: tuple[Path, ...], scenario: str | None, map_file: Path | None, fmt: str | None,
               out: Path | None, overwrite: bool, seed: int | None, overrides: tuple[str, ...], no_plots: bool,
               strict: bool, outputs: Outputs) -> None:
    """Run a scenario's onboard stack (its estimator; the controller is not run) on recorded navigation and
    detections instead of a simulated world: LOGS are a swarmtrack run folder, ROS bags (ROS 1, ROS 2 sqlite3 or
    MCAP), PX4 ULog files or CSV files. The messages between UAVs are computed by the scenario's channel, as the
    simulator computes them. Writes the same run folder as swarmtrack run (errors only where the logs hold ground
    truth)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from swarmtrack.estimation.information import FilterDivergence
    from swarmtrack.extras import require_readers
    from swarmtrack.outputs import OutputError, Terminated, run_folder
    from swarmtrack.replay.engine import replay_logs
    from swarmtrack.replay.formats import reader_for
    from swarmtrack.replay.steps import LogError
    from swarmtrack.scenarios.loader import ScenarioError, load_scenario

    try:
        reader = reader_for(fmt, logs)
        require_readers(_readers(reader, logs))  # a bag's or a ULog's library: before anything is read
        if scenario is None:
            if reader.name != "run" or not (logs[0] / "scenario.yaml").is_file():
                raise UsageFailure("--scenario FILE|NAME is needed (only a run folder brings its own)")
            scenario = str(logs[0] / "scenario.yaml")
        scn = load_scenario(scenario, list(overrides), seed)
        taps = outputs.taps()
        out = out or Path("runs") / f"replay-{scn.name}-seed{scn.seed}"
        with run_folder(out, overwrite) as tmp:
            columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn())
            with Progress(*columns, transient=True, disable=not sys.stderr.isatty()) as bar:
                task = bar.add_task(f"reading {len(logs)} log(s)", total=None)
                steps = [1]

                def planned(n: int) -> None:  # the number of steps, known before the first (replay.grid.plan)
                    steps[0] = n
                    bar.update(task, total=n, description=f"replaying {n / scn.rates.estimation:g} s of log "
                                                          f"through {scn.name}: steps")

                rec = replay_logs(logs, scn, map_file, fmt, tmp / "recording",
                                  lambda done: bar.update(task, completed=round(done * steps[0])), planned, taps)
            source = rec.meta["replay"]
            metrics = write_run(rec, scn, tmp, no_plots=no_plots, extra={"replay": source},
                                warnings=_warnings(source["skipped"]))
    except (ScenarioError, LogError, FilterDivergence, OutputError) as exc:
        raise UsageFailure(str(exc)) from None
    except (KeyboardInterrupt, Terminated):
        click.echo("interrupted; nothing was written", err=True)
        sys.exit(130)
    report_run(metrics, scn, out)
    warn_run(metrics, strict)


def _readers(reader, logs) -> set[str]:
    """The names of the readers of ``logs`` given the one recognised or named (``reader``): a time-stamped reader's
    logs are any mix of the time-stamped readers' (bags, ULogs, CSVs), each read by its own
    (:func:`swarmtrack.replay.timestamped.group`)."""
    if reader.stamped is None:
        return {reader.name}
    from swarmtrack.replay.timestamped import group

    return {name for name, paths in group(logs).items() if paths}


def _warnings(counts: dict[str, int]) -> list[dict]:
    """One warning per kind of message skipped mid-log (they are counted, not fatal), with what the user can do
    about it (:data:`swarmtrack.replay.grid.SKIPS`)."""
    from swarmtrack.replay.grid import skipped_lines

    return [{"kind": "replay_skipped", "t_start": None, "t_end": None, "message": f"replay: {line}"}
            for line in skipped_lines(counts)]
