"""``swarmtrack export RUN --format mcap|rosbag2|csv``: a finished run for the field's viewers."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import click

from swarmtrack.cli_support import UsageFailure
from swarmtrack.extras import require
from swarmtrack.outputs import OutputError, check_new_destination


@click.command("export")
@click.argument("run", type=click.Path(file_okay=False, path_type=Path))
@click.option("--format", "fmt", type=click.Choice(["mcap", "rosbag2", "foxglove", "csv"]), default="mcap",
              show_default=True, help=(
                  "mcap: a ROS 2 bag in MCAP storage; rosbag2: sqlite3 storage; foxglove: one MCAP file with the "
                  "live view's topics (--foxglove: the scene, errors, NEES); csv: the time series"))
@click.option("--out", type=click.Path(path_type=Path), default=None, help=(
    "the new bag (a folder), MCAP file or CSV folder (default: RUN.<format> beside RUN, RUN.foxglove.mcap); never "
    "replaced"))
def export_cmd(run: Path, fmt: str, out: Path | None) -> None:
    """Write the run in RUN (a swarmtrack run folder) as standard messages: the truth and every UAV's estimate with
    its covariance (docs/replay.md lists the topics)."""
    if fmt == "foxglove":
        require("foxglove", "swarmtrack export --format foxglove")
    elif fmt != "csv":  # a bag, written with rosbags
        require("logs", f"swarmtrack export --format {fmt}", ["rosbags"])
    from swarmtrack.replay.run_folder import open_run, reading
    from swarmtrack.replay.steps import LogError

    if not (run / "recording").is_dir():
        raise UsageFailure(f"{run}: not a swarmtrack run folder (it has no recording/)")
    out = (out or run.parent / f"{run.name}.{'foxglove.mcap' if fmt == 'foxglove' else fmt}").absolute()
    try:  # a dangling symbolic link too: a folder is never renamed onto it
        check_new_destination(out, rule="an export never replaces anything")
    except OutputError as exc:
        raise UsageFailure(str(exc)) from None
    try:
        rec = open_run(run)  # meta.json and the tables' footers checked: a damaged folder named before writing
    except LogError as exc:
        raise UsageFailure(str(exc)) from None
    try:
        staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".partial", dir=out.parent))
    except OSError as exc:
        raise UsageFailure(f"--out {out}: {exc.strerror or exc}") from None
    try:  # written whole in a staging folder beside it, then moved into place
        with reading(rec):  # a table damaged inside: one message naming the recording
            if fmt == "csv":
                rec.write_csv(staging / "export")
                counts = None
            elif fmt == "foxglove":
                from swarmtrack.streams.foxglove import write_mcap

                steps = write_mcap(rec, staging / "export")
                counts = None
            else:
                from swarmtrack.interop.ros import export_ros

                counts = export_ros(rec, staging / "export", fmt)
        if os.path.lexists(out):  # arrived meanwhile (a folder renamed onto an empty one would replace it)
            raise UsageFailure(f"--out {out}: something was put there meanwhile; nothing was written")
        os.rename(staging / "export", out)
    except LogError as exc:
        raise UsageFailure(str(exc)) from None
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    if fmt == "foxglove":
        click.echo(f"{steps} steps of the live view's topics written to {out} (open it in Foxglove: docs/field.md)")
    elif counts is None:
        click.echo(f"time series written to {out}")
    else:
        click.echo(f"{sum(counts.values())} messages on {len(counts)} topics written to {out}")
