"""The commands of ``swarmtrack run | reproduce | sweep | summarize | validate | schema | identify | scenarios``
(:mod:`swarmtrack.cli` lists them and imports this module when one of them is run or its help is asked).

Bad input (scenario, override, option) prints one message naming the field and exits with code 2; a run's
folder is staged and moved into place only when complete, and never replaces what the tool did not write
(:mod:`swarmtrack.outputs`).
"""

from __future__ import annotations

import functools
import sys
import time
from pathlib import Path

import click
import yaml

from swarmtrack import registry
from swarmtrack.cli_support import UsageFailure, progress_bar, report_run, warn_run, write_run
from swarmtrack.extras import require
from swarmtrack.scenarios.loader import ScenarioError, builtin_names, load_raw, load_scenario
from swarmtrack.streams.options import Outputs, output_options


@click.command("scenarios")
def scenarios_cmd() -> None:
    """List the built-in scenarios."""
    for name in builtin_names():
        desc = load_raw(name).get("description", "")
        click.echo(f"{name:24s} {desc}")


@click.command("run")
@click.argument("scenario", default="l24-ct")
@click.option("--out", "out", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="output folder (default: runs/<name>-seed<seed>-<hash of the resolved scenario>)")
@click.option("--overwrite", is_flag=True,
              help="replace an earlier run in --out (only the files its manifest.json lists), and the --animate file")
@click.option("--seed", type=int, default=None, help="override the scenario's seed")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
              help="override a scenario key, e.g. --set network.topology=full (repeatable)")
@click.option("--no-plots", is_flag=True, help="skip the PNG figures")
@click.option("--strict", is_flag=True, help="exit with code 3 when the run has warnings (lost target, ...)")
@click.option("--format", "formats", type=click.Choice(["parquet", "csv"]), multiple=True, default=("parquet",),
              show_default=True, help="time series formats: the Parquet recording always, csv adds timeseries/*.csv")
@click.option("--animate", type=click.Path(dir_okay=False, path_type=Path), default=None, metavar="FILE.gif|FILE.mp4",
              help="also write an animation of the sets, footprints, paths, targets and decoys (set-membership "
                   "scenarios; .mp4 needs ffmpeg); an existing file is replaced only with --overwrite")
@click.option("--animate-every", type=click.FloatRange(min=0, min_open=True), default=None, metavar="SECONDS",
              help="simulated time between frames  [default: 1]")
@click.option("--animate-uav", type=click.IntRange(min=1), default=None, metavar="N",
              help="show UAV N's own sets (default: the union of every UAV's sets)")
@output_options()
def run_cmd(scenario: str, out: Path | None, overwrite: bool, seed: int | None, overrides: tuple[str, ...],
            no_plots: bool, strict: bool, formats: tuple[str, ...], animate: Path | None,
            animate_every: float | None, animate_uav: int | None, outputs: Outputs) -> None:
    """Run one closed-loop simulation of SCENARIO (a built-in name or a YAML file).

    Writes scenario.yaml (resolved), metrics.json, recording/ (Parquet; load it with
    swarmtrack.sim.recorder.Recording.load), manifest.json and, unless --no-plots, PNG figures. An existing
    non-empty --out is refused unless it holds an earlier run and --overwrite is given; without --overwrite, an
    --out that another run fills while this one runs is not replaced either (exit 2, this run's files are not
    kept). With --animate, also the
    animation (a frame every --animate-every s of simulated time, played at 10 frames per second)."""
    from swarmtrack.analysis.runs import run_key
    from swarmtrack.estimation.information import FilterDivergence
    from swarmtrack.outputs import OutputError, Terminated, run_folder
    from swarmtrack.sim.engine import simulate

    refused: tuple[type[Exception], ...] = (ScenarioError, FilterDivergence, OutputError)
    if animate is not None:  # the animation's module (shapely, the set-membership estimator) only for --animate
        from swarmtrack.analysis.animation import AnimationError

        refused += (AnimationError,)
    try:
        scn = load_scenario(scenario, list(overrides), seed)
        _check_animation(scn, animate, animate_every, animate_uav, overwrite)
        taps = outputs.taps()
        out = out or Path("runs") / f"{scn.name}-seed{scn.seed}-{run_key(scn)[:8]}"
        with run_folder(out, overwrite) as tmp:
            with progress_bar(f"simulating {scn.name}") as advance:
                if animate is None:
                    rec = simulate(scn, progress=advance, record_to=tmp / "recording", taps=taps)
                else:
                    from swarmtrack.analysis.animation import simulate_animated

                    rec, capture = simulate_animated(scn, animate_every or 1.0, animate_uav, progress=advance,
                                                     record_to=tmp / "recording")
            metrics = write_run(rec, scn, tmp, formats, no_plots)
            if animate is not None:
                from swarmtrack.analysis.animation import render

                with progress_bar(f"animating {len(capture.frames)} frames") as advance:
                    render(capture, animate, f"{scn.name}, seed {scn.seed}", overwrite, progress=advance)
    except refused as exc:
        raise UsageFailure(str(exc)) from None
    except (KeyboardInterrupt, Terminated):
        click.echo("interrupted; nothing was written", err=True)
        sys.exit(130)
    report_run(metrics, scn, out)
    if animate is not None:
        click.echo(f"animation: {len(capture.frames)} frames written to {animate}")
    warn_run(metrics, strict)


def _check_animation(scn, animate: Path | None, every: float | None, uav: int | None, overwrite: bool) -> None:
    """Refuse, before anything runs, an animation that cannot be made: options without --animate, a scenario
    without set-membership estimator, a UAV it does not have, a destination that cannot be written
    (:func:`swarmtrack.analysis.animation.check_destination`)."""
    if animate is None:
        if every is not None or uav is not None:
            raise UsageFailure("--animate-every and --animate-uav need --animate FILE")
        return
    from swarmtrack.analysis.animation import check_destination

    if not registry.get("estimator", scn.estimator.kind).animated:
        animated = ", ".join(name for name, kind in registry.kinds("estimator").items() if kind.animated)
        raise UsageFailure(f"--animate: {scn.name} has estimator.kind {scn.estimator.kind}; the animation shows the "
                           f"sets of a set-membership estimator (estimator.kind: {animated}, e.g. ib21-fleet-6)")
    if uav is not None and uav > scn.swarm.n_uavs:
        raise UsageFailure(f"--animate-uav {uav}: {scn.name} has {scn.swarm.n_uavs} UAVs")
    check_destination(animate, overwrite)


def reproduce_command() -> click.Command:
    """``swarmtrack reproduce``, its paper choices, epilog and --figure help read from the registry
    :data:`~swarmtrack.analysis.papers.PAPERS` when the command is made (:mod:`swarmtrack.cli` makes it when it is
    run or its help is asked, so that the paper modules load only then)."""
    from swarmtrack.analysis.papers import PAPERS

    papers = sorted(PAPERS.items())
    groups = "; ".join(f"{k}: {', '.join(p.figure_groups)}" for k, p in papers if p.figure_groups)

    @click.command("reproduce", epilog="\b\nPapers:\n" + "\n".join(f"  {k}  {p.title}" for k, p in papers))
    @click.argument("paper", type=click.Choice(sorted(PAPERS)))
    @click.option("--out", "out", type=click.Path(file_okay=False, path_type=Path), default=None,
                  help="output folder (default: runs/reproduce-<paper>)")
    @click.option("--runs", type=click.IntRange(min=1), default=10, show_default=True, help="seeds per experiment")
    @click.option("--workers", type=click.IntRange(min=1), default=None, help="parallel processes (default: cores)")
    @click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
                  help="override a key of every experiment's scenario, e.g. --set sensor.latency=0 (repeatable)")
    @click.option("--no-figures", is_flag=True, help="skip the paper's figures")
    @click.option("--cluster", default=None, metavar="ADDRESS",
                  help="run on Dask: tcp://HOST:PORT of a running scheduler, or 'local' for a LocalCluster of "
                       "--workers")
    @click.option("--figure", default=None, metavar="NAME",
                  help=f"only one figure's experiments, figures and claims, for a paper that groups them ({groups})")
    def reproduce_cmd(paper: str, out: Path | None, runs: int, workers: int | None, overrides: tuple[str, ...],
                      no_figures: bool, cluster: str | None, figure: str | None) -> None:
        """Run a paper's experiments over several seeds and check its claims.

        Every finished run is kept in OUT/runs and reused next time (keyed by its resolved scenario and the
        swarmtrack version); Ctrl-C stops at once; the two reports are written together or not at all (with
        --figure N: reproduction-figN.json and .md)."""
        if cluster is not None:  # without it, a local process pool
            require("dask", "swarmtrack reproduce --cluster")
        from swarmtrack.analysis.reproduce import figure_experiments, reproduce
        from swarmtrack.outputs import Terminated, terminate_as_exception

        try:
            figure_experiments(paper, figure)
        except ValueError as exc:
            raise UsageFailure(str(exc)) from None
        out = out or Path("runs") / f"reproduce-{paper}"
        try:
            with terminate_as_exception():
                reproduce(paper, out, runs=runs, workers=workers, figures=not no_figures, overrides=overrides,
                          cluster=cluster, figure=figure)
        except ScenarioError as exc:
            raise UsageFailure(str(exc)) from None
        except (KeyboardInterrupt, Terminated):
            click.echo(f"interrupted; finished runs are kept in {out / 'runs'} and reused next time", err=True)
            sys.exit(130)

    return reproduce_cmd


@click.command("sweep")
@click.argument("scenario")
@click.option("--grid", "grid", multiple=True, metavar="KEY=V1,V2,...",
              help="a scenario key and its values; several --grid give their cross product (repeatable)")
@click.option("--runs", type=click.IntRange(min=1), default=10, show_default=True, help="seeds per setting")
@click.option("--workers", type=click.IntRange(min=1), default=None, help="parallel processes (default: cores)")
@click.option("--out", "out", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="the result store (a folder)")
@click.option("--resume", is_flag=True, help="run only the runs missing from an existing store")
@click.option("--cluster", default=None, metavar="ADDRESS",
              help="run on Dask: tcp://HOST:PORT of a running scheduler, or 'local' for a LocalCluster of --workers")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE", help="fix a key for every run (repeatable)")
def sweep_cmd(scenario: str, grid: tuple[str, ...], runs: int, workers: int | None, out: Path, resume: bool,
              cluster: str | None, overrides: tuple[str, ...]) -> None:
    """Run SCENARIO over the cross product of grid values x seeds 1..RUNS, in parallel.

    Each finished run's row (grid values, seed, status, error, wall time, version, metrics) is written to
    OUT/results at once, so an interrupted sweep loses only the runs in progress; --resume runs only what is
    missing. A run that fails is stored as failed and the sweep goes on. Read the store with
    swarmtrack.analysis.sweep.load_results(OUT)."""
    if cluster is not None:  # without it, a local process pool
        require("dask", "swarmtrack sweep --cluster")
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from swarmtrack.analysis.sweep import load_results, parse_grid, sweep
    from swarmtrack.outputs import Terminated, terminate_as_exception

    try:
        with terminate_as_exception(), Progress(TextColumn("sweep"), BarColumn(), MofNCompleteColumn(),
                                                TextColumn("{task.fields[rate]}"), TimeRemainingColumn(),
                                                transient=True) as progress:
            task = progress.add_task("sweep", total=None, rate="")
            start, resumed = time.perf_counter(), []

            def advance(done: int, total: int) -> None:  # the rate counts this session's runs, not resumed ones
                if not resumed:
                    resumed.append(done)
                fresh, wall = done - resumed[0], time.perf_counter() - start
                progress.update(task, completed=done, total=total,
                                rate=f"{fresh / wall:.2f} runs/s" if fresh and wall > 0 else "")

            sweep(scenario, parse_grid(grid), runs, out, workers=workers, resume=resume, overrides=overrides,
                  on_done=advance, cluster=cluster)
    except ScenarioError as exc:
        raise UsageFailure(str(exc)) from None
    except (KeyboardInterrupt, Terminated):
        click.echo(f"interrupted; finished runs are kept in {out / 'results'}; --resume runs the rest", err=True)
        sys.exit(130)
    table = load_results(out)
    counts = table["status"].value_counts().to_dict() if len(table) else {}
    click.echo(f"{len(table)} runs in {out}: " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items())))
    for _, row in table[table["status"] != "ok"].head(10).iterrows():
        click.echo(f"  seed {row['seed']} {row['status']}: {row['error']}", err=True)


@click.command("summarize")
@click.argument("out", type=click.Path(file_okay=False, path_type=Path))
@click.option("--no-figures", is_flag=True, help="skip the figures")
def summarize_cmd(out: Path, no_figures: bool) -> None:
    """Summarize a sweep's result store OUT: mean ± std and the 95 % interval of each metric per setting (printed,
    and written to OUT/summary.md and OUT/summary.json together), each metric against each grid key, and each time
    series (position error, NEES, formation tracking error) as mean lines with ±1 std bands over the seeds per
    setting, as figures in OUT/summary/ (listed in summary.md)."""
    from swarmtrack.analysis.sweep import plot_series, plot_summary, summarize
    from swarmtrack.outputs import dump_json, write_together

    if not (out / "sweep.json").is_file():
        raise UsageFailure(f"{out} is not a sweep's result store (no sweep.json)")
    try:
        md, numbers = summarize(out)
    except ScenarioError as exc:
        raise UsageFailure(str(exc)) from None
    paths = [] if no_figures else [*plot_summary(numbers, out / "summary"), *plot_series(numbers, out / "summary")]
    if paths:
        md += "\n\n## Figures\n\n" + "\n".join(f"- {p.relative_to(out)}" for p in paths)
    write_together({out / "summary.md": md + "\n", out / "summary.json": dump_json(numbers)})
    click.echo(md)
    if paths:
        click.echo(f"{len(paths)} figures in {out / 'summary'}")


@click.command("validate")
@click.argument("scenario")
@click.option("--seed", type=int, default=None, help="override the scenario's seed")
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
              help="override a scenario key, e.g. --set network.topology=full (repeatable)")
def validate_cmd(scenario: str, seed: int | None, overrides: tuple[str, ...]) -> None:
    """Check SCENARIO (a built-in name or a YAML file) and print it fully resolved, as run writes scenario.yaml."""
    try:
        scn = load_scenario(scenario, list(overrides), seed)
    except ScenarioError as exc:
        raise UsageFailure(str(exc)) from None
    click.echo(yaml.safe_dump(scn.model_dump(mode="json"), sort_keys=False), nl=False)


@click.command("schema")
@click.option("--format", "fmt", type=click.Choice(["text", "markdown"]), default="text", show_default=True)
def schema_cmd(fmt: str) -> None:
    """Every scenario key: dotted path, type, default, allowed values and unit (docs/scenarios.md)."""
    from swarmtrack.scenarios import reference

    click.echo(reference.markdown() if fmt == "markdown" else reference.text(), nl=False)


def _matrix_lines(name: str, M) -> list[str]:
    rows = [" ".join(f"{v:>11.6g}" for v in row) for row in M]
    return [f"{name} = [" + rows[0]] + ["     " + r for r in rows[1:-1]] + ["     " + rows[-1] + " ]"]


def _free_destination(path: Path, option: str, overwrite: bool) -> None:
    """Refuse a --out / --save-log that cannot receive the file (:func:`swarmtrack.outputs.check_file_destination`)."""
    from swarmtrack.outputs import OutputError, check_file_destination

    try:
        check_file_destination(path, option, overwrite)
    except OutputError as exc:
        raise UsageFailure(str(exc)) from None


@click.command("identify")
@click.argument("log", required=False, type=click.Path(dir_okay=True, path_type=Path))
@click.option("--simulator", is_flag=True,
              help="fly the simulator's own quadrotor through setpoint steps and identify that, instead of a LOG")
@click.option("--save-log", type=click.Path(path_type=Path), default=None,
              help="with --simulator: also write the generated log as CSV")
@click.option("--out", "out", type=click.Path(path_type=Path), default=None,
              help="write the model as YAML (default: print it)")
@click.option("--overwrite", is_flag=True, help="replace existing --out / --save-log files")
def identify_cmd(log: Path | None, simulator: bool, save_log: Path | None, out: Path | None,
                 overwrite: bool) -> None:
    """Identify the UAV's position-controlled dynamics (W20 eqs. 2.30-2.36, 5.32) from LOG.csv (columns
    t,x,y,vx,vy,ux,uy at a fixed period; u is the position setpoint), or from the simulator's own quadrotor with
    --simulator. Prints A, B and the fit on position per axis; the model goes, as YAML for a scenario's
    controller.model, to --out or to stdout (the summary then goes to stderr). Existing files are not replaced
    unless --overwrite is given."""
    from swarmtrack.control import identification as ident
    from swarmtrack.outputs import write_together

    if simulator == (log is not None):
        raise UsageFailure("give either a LOG file or --simulator (not both)" if simulator
                           else "give a LOG file to identify, or --simulator")
    if save_log is not None and not simulator:
        raise UsageFailure("--save-log is for --simulator (a LOG file is already saved)")
    for path, option in ((out, "--out"), (save_log, "--save-log")):
        if path is not None:
            _free_destination(path, option, overwrite)
    if out is not None and save_log is not None and out.absolute() == save_log.absolute():
        raise UsageFailure(f"--out and --save-log are the same file {out}")
    try:
        if simulator:
            data, source = ident.step_response_log(), "the simulator's quadrotor"
        else:
            data, source = ident.read_log_csv(log), str(log)
        result = ident.identify(data)
        A, B = ident.rounded_model(result)
        text = ident.model_yaml(result, source)
    except ValueError as exc:
        raise UsageFailure(str(exc)) from None
    say = functools.partial(click.echo, err=out is None)  # without --out, stdout carries only the YAML
    say(f"identified from {source}: {result.n_samples} samples, T = {result.T:.6g} s")
    say(f"fit on position (free run, %): x {result.fits['x']:.2f}, y {result.fits['y']:.2f}")
    say("state [x, y, vx, vy], input [ux, uy] (position setpoint):")
    for line in [*_matrix_lines("A", A), *_matrix_lines("B", B)]:
        say("  " + line)
    files = {}
    if out is not None:
        files[out] = text
    if save_log is not None:
        files[save_log] = ident.log_csv_text(data)
    if files:
        try:
            write_together(files)
        except OSError as exc:
            raise UsageFailure(f"cannot write {', '.join(str(p) for p in files)}: {exc.strerror or exc}") from None
        say("written: " + ", ".join(str(p) for p in files))
    else:
        click.echo(text, nl=False)
