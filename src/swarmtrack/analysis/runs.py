"""Running resolved scenarios to their metrics, shared by ``swarmtrack reproduce`` (:mod:`.reproduce`) and
``swarmtrack sweep`` (:mod:`.sweep`): the key of what determines a run's result, one run, and batches of runs of one
scenario run as one batch of worlds (:mod:`swarmtrack.sim.batch`)."""

from __future__ import annotations

import hashlib
import json
import signal
from collections.abc import Sequence

from swarmtrack.analysis.metrics import summary
from swarmtrack.estimation.information import FilterDivergence
from swarmtrack.outputs import package_version
from swarmtrack.scenarios import Scenario
from swarmtrack.sim import batch, engine

#: Largest batch of worlds run as one (:mod:`swarmtrack.sim.batch`): UAVs over all its worlds, and worlds. Batches
#: are for small swarms (their links are dense), and a batch is lost whole when a study is interrupted.
BATCH_UAVS, BATCH_WORLDS = 256, 32


def run_key(scenario: Scenario, version: str | None = None) -> str:
    """sha256 (hex) of what determines a run's result: the resolved scenario, seed included, and the version."""
    payload = {"scenario": scenario.model_dump(mode="json"), "version": version or package_version()}
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return hashlib.sha256(text.encode()).hexdigest()


def run_one(scenario: Scenario) -> dict:
    """One resolved scenario's metrics, or the divergence message."""
    try:
        return summary(engine.simulate(scenario))
    except FilterDivergence as exc:
        return {"diverged": str(exc)}


def batches(scenarios: Sequence[Scenario], workers: int = 1) -> list[list[int]]:
    """Indices of ``scenarios`` grouped into the batches they run in: runs of one scenario (seeds apart) that
    :func:`~swarmtrack.sim.batch.unbatchable` accepts, at most :data:`BATCH_WORLDS` worlds and
    :data:`BATCH_UAVS` UAVs each, split so that ``workers`` processes all get work; the rest one by one."""
    groups: dict[str, list[int]] = {}
    for k, s in enumerate(scenarios):
        groups.setdefault(s.model_dump_json(exclude={"seed"}), []).append(k)
    out = []
    for members in groups.values():
        n = scenarios[members[0]].swarm.n_uavs
        if len(members) < 2 or n > BATCH_UAVS // 2 or batch.unbatchable([scenarios[k] for k in members[:2]]):
            out += [[k] for k in members]
            continue
        size = min(BATCH_WORLDS, BATCH_UAVS // n, -(-len(members) // max(1, workers)))
        out += [members[i:i + size] for i in range(0, len(members), size)]
    return out


def run_batch(scenarios: Sequence[Scenario]) -> list[dict]:
    """:func:`run_one` of each scenario, as one batch of worlds when there are several (same numbers); a batch that
    raises (a filter that diverged, anything else) is run again one world at a time, so each run gets its own
    result or error."""
    if len(scenarios) == 1:
        return [run_one(scenarios[0])]
    try:
        return [summary(rec) for rec in batch.simulate_batch(list(scenarios))]
    except Exception:  # noqa: BLE001 - each run's own outcome comes from running it alone
        return [run_one(s) for s in scenarios]


def worker_signals() -> None:
    """Workers leave Ctrl-C to the parent, which stops them at once (:func:`run_all`), and die quietly on the
    parent's SIGTERM (not with the handler a forked worker inherits)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
