"""Log reader ``run``: a swarmtrack run folder, replayed with the navigation and detections its onboard code was
handed (:mod:`swarmtrack.sim.inputs`), the UAVs' recorded truth for the channel's links, and the run's ground truth.

Replayed with the scenario that made it (the default of ``swarmtrack replay``), it gives the run's estimates bit
for bit: the same inputs, the same channel from the same seed, the same arithmetic. With another scenario
(another estimator, another topology) it answers "what would this estimator have made of that flight".
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from swarmtrack.onboard.context import layout
from swarmtrack.replay.steps import LogError, Planned, StepInputs
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.recorder import Recording

#: What a recording's ``meta.json`` must say for its tables to be read (:class:`~swarmtrack.sim.recorder.Recording`).
META_KEYS = ("format", "n_steps", "n_objects", "n_uavs", "dt", "groups", "probes")


def recording_folder(path: Path) -> Path:
    """The recording folder of a run folder (or the folder itself, when it is one)."""
    path = Path(path)
    return path / "recording" if (path / "recording").is_dir() else path


def accepts(path: Path) -> bool:
    """A recording (a folder with ``meta.json``) or a run folder (one with ``recording/``, damaged or not: it is
    refused by :func:`open_run` naming what is wrong rather than as a log no reader knows)."""
    path = Path(path)
    return path.is_dir() and ((path / "recording").is_dir() or (path / "meta.json").is_file())


def open_run(path: Path) -> Recording:
    """The recording of the run folder (or recording folder) ``path``, checked before anything is read from it:
    ``meta.json`` there, JSON, of this version's format and with the keys the tables are read by, and each Parquet
    table it names there with a footer whose row count is meta's (``n_steps`` × objects or UAVs). A missing,
    empty, truncated or foreign file is a :class:`LogError` naming it. Only the files' footers are read (a few kB:
    about a millisecond for a run of any length); a table damaged inside is named when it is read (:func:`reading`).
    """
    import json

    import pyarrow as pa
    import pyarrow.parquet as pq

    from swarmtrack.sim.inputs import DETECTIONS, NAVIGATION
    from swarmtrack.sim.recorder import FORMAT

    path = Path(path)
    folder = recording_folder(path)
    if not folder.is_dir():
        raise LogError(f"{path}: not a swarmtrack run folder (no such folder)")
    where = folder / "meta.json"
    try:
        meta = json.loads(where.read_text(encoding="utf-8"))
    except FileNotFoundError:
        inside = sorted(p.name for p in folder.iterdir())
        raise LogError(f"{where}: missing, so {path} is not a whole swarmtrack recording (a run writes meta.json "
                       f"last; {folder} holds {', '.join(inside) if inside else 'nothing'})") from None
    except OSError as exc:
        raise LogError(f"{where}: {exc.strerror or exc}") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise LogError(f"{where}: not a swarmtrack recording's meta.json (not JSON: {exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        got = meta.get("format") if isinstance(meta, dict) else type(meta).__name__
        raise LogError(f"{where}: recording format {got!r}; this version of swarmtrack reads format {FORMAT}")
    lacking = [k for k in META_KEYS if k not in meta]
    if lacking:
        raise LogError(f"{where}: no {lacking[0]!r} (not a whole swarmtrack recording)")
    rows = {"objects.parquet": meta["n_objects"], "uavs.parquet": meta["n_uavs"]} if meta["n_steps"] else {}
    if "inputs" in meta:
        rows.update({NAVIGATION: meta["n_uavs"], DETECTIONS: None})
    for name, per_step in rows.items():
        table = folder / name
        if not table.is_file():
            raise LogError(f"{table}: missing (meta.json says the recording has it)")
        try:
            got = pq.ParquetFile(table).metadata.num_rows
        except (pa.ArrowException, OSError) as exc:
            raise LogError(f"{table}: not a readable Parquet file, truncated or damaged ({exc})") from None
        if per_step is not None and got != meta["n_steps"] * per_step:
            raise LogError(f"{table}: {got} rows where meta.json says {meta['n_steps']} steps × {per_step} "
                           f"(= {meta['n_steps'] * per_step}): a table of another run, or cut short")
    return Recording(meta, path=folder)


@contextmanager
def reading(rec: Recording):
    """Errors of a recording's tables while they are read (a file damaged inside: :func:`open_run` reads only the
    footers) as one :class:`LogError` naming the recording."""
    import pyarrow as pa

    try:
        yield
    except LogError:
        raise
    except (pa.ArrowException, OSError, KeyError, ValueError) as exc:
        raise LogError(f"{rec.path}: a table of the recording (its .parquet files) cannot be read, damaged inside "
                       f"({type(exc).__name__}: {' '.join(str(exc).split())})") from None


def steps(paths: list[Path], scenario: Scenario, mapping, counts: dict) -> Iterator[StepInputs]:
    """The steps of one run folder (``paths``: one), checked against ``scenario`` (same swarm, objects and
    estimation period; a map file has nothing to say here)."""
    if len(paths) != 1:
        raise LogError(f"a run folder is replayed alone; got {len(paths)} logs")
    if mapping is not None:
        raise LogError("--map: a run folder needs no map file (its recording says which UAV each row is)")
    rec = open_run(paths[0])
    if "inputs" not in rec.meta:
        raise LogError(no_inputs(paths[0]))
    _check(rec.meta, scenario, paths[0])
    return Planned(_steps(rec), rec.meta["n_steps"])


def no_inputs(path: Path) -> str:
    """Why the run folder ``path`` cannot be replayed: its recording kept no inputs, and what wrote it (its
    ``metrics.json``'s sections say: a ``live`` run keeps none)."""
    import json

    path = Path(path)
    run = path.parent if path.name == "recording" and not (path / "recording").is_dir() else path
    try:
        metrics = json.loads((run / "metrics.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        metrics = {}
    metrics = metrics if isinstance(metrics, dict) else {}
    written = metrics.get("written_by", "an unknown version of swarmtrack")
    if "live" in metrics:
        return (f"{path}: written by swarmtrack live ({written}), which keeps no navigation and detections of its "
                "UAVs (only the truth and their estimates), so there is nothing to replay. Fly the same scenario "
                "with swarmtrack run (it keeps them) and replay that folder; swarmtrack export writes the live run's "
                "truth and estimates")
    return (f"{path}: its recording kept no navigation and detections (written by {written}: a recording made "
            "in memory, with simulate(..., inputs=False), or by a swarmtrack before 0.6), so there is nothing to "
            "replay. Run the scenario again with swarmtrack run, which keeps them")


def _check(meta: dict, scenario: Scenario, path: Path) -> None:
    n, dt = scenario.swarm.n_uavs, 1.0 / scenario.rates.estimation
    if meta["n_uavs"] != n:
        raise LogError(f"{path}: the run flew {meta['n_uavs']} UAVs, the scenario has swarm.n_uavs {n}")
    if abs(meta["dt"] - dt) > 1e-12 * dt:
        raise LogError(f"{path}: the run estimated every {meta['dt']:g} s, the scenario's rates.estimation gives "
                       f"{dt:g} s")
    groups = {name: [sl.start, sl.stop] for name, sl in layout(scenario).items()}
    if groups != meta["groups"]:
        raise LogError(f"{path}: the run's world objects {meta['groups']} are not the scenario's {groups} "
                       "(targets, decoys, UAVs)")


def _steps(rec: Recording) -> Iterator[StepInputs]:
    uavs = rec.uav_slice
    with reading(rec):
        inputs = rec.inputs()
        for chunk in rec.chunks(probes_wanted=False):
            for j in range(len(chunk.t)):
                k, t, nav, det = next(inputs)
                if k != chunk.k0 + j:
                    raise LogError(f"{rec.path}: the inputs' step {k} is not the recording's step {chunk.k0 + j}")
                truth = chunk.truth[j]
                yield StepInputs(k, t, nav, det, truth[uavs, :2], truth, chunk.phase[j])
