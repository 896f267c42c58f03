"""Log reader ``run``: a swarmtrack run folder, replayed with the navigation and detections its onboard code was
handed (:mod:`swarmtrack.sim.inputs`), the UAVs' recorded truth for the channel's links, and the run's ground truth.

Replayed with the scenario that made it (the default of ``swarmtrack replay``), it gives the run's estimates bit
for bit: the same inputs, the same channel from the same seed, the same arithmetic. With another scenario
(another estimator, another topology) it answers "what would this estimator have made of that flight".
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

from swarmtrack.replay.steps import LogError, StepInputs, layout
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.recorder import Recording


def recording_folder(path: Path) -> Path:
    """The recording folder of a run folder (or the folder itself, when it is one)."""
    path = Path(path)
    return path / "recording" if (path / "recording").is_dir() else path


def accepts(path: Path) -> bool:
    return (recording_folder(path) / "meta.json").is_file()


def steps(paths: list[Path], scenario: Scenario, mapping, counts: dict) -> Iterator[StepInputs]:
    """The steps of one run folder (``paths``: one), checked against ``scenario`` (same swarm, objects and
    estimation period; a map file has nothing to say here)."""
    if len(paths) != 1:
        raise LogError(f"a run folder is replayed alone; got {len(paths)} logs")
    if mapping is not None:
        raise LogError("--map: a run folder needs no map file (its recording says which UAV each row is)")
    folder = recording_folder(paths[0])
    try:
        rec = Recording.load(folder)
    except (OSError, ValueError) as exc:
        raise LogError(f"{paths[0]}: not a readable swarmtrack recording ({exc})") from None
    if "inputs" not in rec.meta:
        raise LogError(f"{paths[0]}: the run kept no navigation and detections (runs before swarmtrack 0.6, or "
                       "recordings made in memory); run it again with swarmtrack run to replay it")
    _check(rec.meta, scenario, paths[0])
    return _steps(rec)


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
    inputs = rec.inputs()
    for chunk in rec.chunks(probes_wanted=False):
        for j in range(len(chunk.t)):
            k, t, nav, det = next(inputs)
            if k != chunk.k0 + j:
                raise LogError(f"{rec.path}: the inputs' step {k} is not the recording's step {chunk.k0 + j}")
            truth = chunk.truth[j]
            yield StepInputs(k, t, nav, det, truth[uavs, :2], truth, chunk.phase[j])
