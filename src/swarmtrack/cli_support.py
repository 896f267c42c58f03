"""What the commands that produce a run folder share (``swarmtrack run``, ``swarmtrack live``): the exit-2 error,
the progress bar, writing the run's files, and the lines printed about it."""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import click
import yaml


class UsageFailure(click.ClickException):
    """Bad input or a refused action: one message, exit code 2."""

    exit_code = 2


@contextmanager
def progress_bar(description: str) -> Iterator[Callable[[float], None]]:
    """A transient rich progress bar while stderr is a terminal; gives the function that sets the fraction done.
    Without a terminal nothing is shown and rich is not imported (a run's start-up does not pay for it)."""
    if not sys.stderr.isatty():
        yield lambda done: None
        return
    from rich.progress import Progress

    with Progress(transient=True) as bar:
        task = bar.add_task(description, total=1.0)
        yield lambda done: bar.update(task, completed=done)


def write_run(rec, scn, folder: Path, formats=("parquet",), no_plots: bool = False, extra: dict | None = None,
              warnings: list | None = None) -> dict:
    """A finished run's files besides its recording, into ``folder`` (staged): ``scenario.yaml`` (resolved),
    ``metrics.json`` (with the ``extra`` sections and ``warnings``), ``timeseries/*.csv`` when ``formats`` has csv,
    the figures unless ``no_plots``. Returns the metrics."""
    from swarmtrack.analysis.metrics import summary
    from swarmtrack.outputs import dump_json, version

    metrics = {**summary(rec), **(extra or {}), "written_by": version()}
    metrics["warnings"] = [*metrics["warnings"], *(warnings or [])]
    (folder / "scenario.yaml").write_text(f"# resolved by {version()}\n"
                                          + yaml.safe_dump(scn.model_dump(mode="json"), sort_keys=False))
    (folder / "metrics.json").write_text(dump_json(metrics))
    if "csv" in formats:
        rec.write_csv(folder / "timeseries")
    if not no_plots:
        from swarmtrack.analysis.plots import save_run_figures

        save_run_figures(rec, folder)
    return metrics


def report_run(metrics: dict, scn, out: Path) -> None:
    """The lines a finished run prints: the RMSE table and consistency (a Gaussian estimator following one target),
    then one line of facts and where the run was written."""
    from swarmtrack.analysis.report import format_rmse_table

    if "rmse" in metrics:  # a Gaussian estimator following one target (capability 1)
        click.echo(format_rmse_table(metrics["rmse"], f"{scn.name}: RMSE (mean over UAVs), cm and cm/s"))
        phases = metrics["consistency"].items()
        click.echo("NEES [x, y, vx, vy] per phase (95 % band of a consistent filter): " + ", ".join(
            f"{ph} {c['nees']:.2f} [{c['band'][0]:.2f}, {c['band'][1]:.2f}]" for ph, c in phases))
    if "altitude" in metrics:  # a 3-D run (docs/three-d.md)
        click.echo("altitude RMSE z / vz per phase, cm and cm/s, and NEES [x, y, vx, vy, z, vz] (95 % band): " +
                   ", ".join(f"{ph} {100 * a['z']:.2f} / {100 * a['vz']:.2f}, {a['nees']:.2f} [{a['band'][0]:.2f}, "
                             f"{a['band'][1]:.2f}]" for ph, a in metrics["altitude"].items()))
    facts = []
    if metrics.get("mean_error", {}).get("all") is not None:  # W20 eq. 4.41
        facts.append(f"mean error {100 * metrics['mean_error']['all']:.2f} cm")
    if "model_use" in metrics:
        facts.append(f"{metrics['model_use']['switches']:.0f} model switches per UAV")
    if "formation" in metrics:  # W20 Ch. 5
        facts.append("distance from each place " + ", ".join(f"{e:.2f}" for e in metrics["formation"]["tracking_error"])
                     + " m")
    if "set_membership" in metrics:  # IB21
        sm = metrics["set_membership"]
        checked = sm["guarantee_violations"]  # None: no truth-side check ran (a replay)
        facts.append(f"Φ̄ {sm['phi_bar_final']:.0f} m² at the end, " + (
            "the guarantee not checked" if checked is None else f"{checked:.0f} guarantee violations"))
    offset = metrics["inter_agent_distance"]["offset"]
    if offset is not None and math.isfinite(offset):
        facts.append(f"spacing offset {offset:.3f} m")
    click.echo(" | ".join([*facts, f"written to {out}"]))


def warn_run(metrics: dict, strict: bool) -> None:
    """The run's warnings on stderr; with ``strict``, exit 3 when there are any."""
    for w in metrics["warnings"]:
        click.echo(f"warning: {w['message']}", err=True)
    if strict and metrics["warnings"]:
        click.echo(f"--strict: {len(metrics['warnings'])} warning(s)", err=True)
        sys.exit(3)
