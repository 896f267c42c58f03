"""Sweep throughput: ``l24-cv`` runs per second through :func:`swarmtrack.analysis.sweep.sweep` with 1 and 2 local
worker processes, and with a 2-worker Dask LocalCluster, with and without its start-up.

Each case sweeps a fresh store (seeds 1..RUNS of the built-in ``l24-cv``, 153 s simulated each), so every figure
includes the validation of every job, the per-run Parquet writes on the client and the workers' warm-up run. The
cases (issue 10's goals: parallel efficiency ≥ 85 % on 2 workers; Dask within 10 % of local processes):

- ``local, 1 / 2 workers``: in this process / a process pool. The pool's workers are forked from this process,
  whose imports and compiled kernels are loaded before any timing, so they start warm.
- ``Dask, start-up included``: ``--cluster local`` as a user runs it: starting the LocalCluster (2 single-threaded
  worker processes, spawned: each imports swarmtrack and loads the compiled kernels afresh), the sweep, closing it.
- ``Dask, cluster running``: a LocalCluster started and warmed before the timing (as a long-lived scheduler is),
  the sweep reaching it by its address: like for like with the local pool's warm workers. Its start-up (start +
  warm-up) is printed beside.

The machine may be shared: the cases run in interleaved rounds and each reports its best round (``--repeat``).

Every case runs one world per job (the sweep's grouping of seeds into batched worlds is switched off here), so the
figures compare the execution backends; what batched worlds add is ``benchmarks/bench_batch.py``'s figure, and the
default sweep (batched) is printed last for reference.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_sweep.py [--json] [--quick] [--repeat R]`` (about 1-2 min;
``--quick`` sweeps 4 runs instead of 12, once). ``--json`` prints one flat JSON object.
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import swarmtrack.analysis.sweep as sw  # noqa: E402
from swarmtrack.analysis.sweep import load_results, sweep  # noqa: E402
from swarmtrack.scenarios import load_scenario  # noqa: E402
from swarmtrack.sim.engine import simulate  # noqa: E402

EFFICIENCY_GOAL = 0.85
DASK_GOAL = 0.90


def rate(runs: int, workers: int, out: Path, cluster: str | None = None) -> float:
    t0 = time.perf_counter()
    sweep("l24-cv", {"network.topology": ["line"]}, runs, out, workers=workers, cluster=cluster)
    wall = time.perf_counter() - t0
    assert (load_results(out)["status"] == "ok").all()
    return runs / wall


def _prewarm() -> None:
    """Imports and compiled kernels of an ``l24-cv`` run loaded in a worker (outside any timing)."""
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim.engine import simulate

    simulate(load_scenario("l24-cv", ["duration=1"]))


def running_cluster_rate(runs: int, out: Path) -> tuple[float, float]:
    """(runs/s of a sweep on a LocalCluster started and warmed before the timing, seconds that start-up took)."""
    from distributed import Client, LocalCluster

    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    client = Client(cluster)
    client.run(_prewarm)
    startup = time.perf_counter() - t0
    try:
        return rate(runs, 2, out, cluster=cluster.scheduler_address), startup
    finally:
        client.close()
        cluster.close()


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeat", type=int, default=3, help="interleaved rounds; each case reports its best")
    args = parser.parse_args(argv)
    runs, repeat = (4, 1) if args.quick else (12, max(1, args.repeat))
    simulate(load_scenario("l24-cv", ["duration=1"]))  # numba caches loaded in this process
    best: dict[str, float] = {}
    startups = []
    with tempfile.TemporaryDirectory(prefix="bench-sweep-") as tmp:
        best["batched"] = rate(runs, 1, Path(tmp) / "batched")  # the default: seeds as batched worlds, one worker
        batching = sw.batches
        sw.batches = lambda scenarios, workers=1: [[k] for k in range(len(scenarios))]  # one world per job
        for r in range(repeat):
            root = Path(tmp) / str(r)
            for name, workers, cluster in (("one", 1, None), ("two", 2, None), ("dask", 2, "local")):
                best[name] = max(best.get(name, 0.0), rate(runs, workers, root / name, cluster=cluster))
            warm_rate, startup = running_cluster_rate(runs, root / "dask-running")
            best["dask_running"] = max(best.get("dask_running", 0.0), warm_rate)
            startups.append(startup)
        sw.batches = batching
    one, two, dask, running = best["one"], best["two"], best["dask"], best["dask_running"]
    eff = two / (2 * one)
    startup = min(startups)
    if args.json:
        print(json.dumps({"sweep_runs_per_s_1_worker": round(one, 3), "sweep_runs_per_s_2_workers": round(two, 3),
                          "parallel_efficiency_2_workers": round(eff, 3),
                          "sweep_runs_per_s_dask_local_2_workers_with_startup": round(dask, 3),
                          "sweep_runs_per_s_dask_local_2_workers_running": round(running, 3),
                          "dask_local_startup_s": round(startup, 2), "runs": runs, "rounds": repeat,
                          "sweep_runs_per_s_batched_1_worker": round(best["batched"], 3)}))
        return

    def verdict(x: float) -> str:
        return f"{100 * x / two:.0f} % of local processes (goal >= {100 * DASK_GOAL:.0f} %: " + (
            "MET)" if x >= DASK_GOAL * two else "NOT MET)")

    print(f"sweep of l24-cv, {runs} runs (153 s simulated each), one world per job, best of {repeat} interleaved "
          "round(s)")
    print(f"  local, 1 worker : {one:.2f} runs/s")
    print(f"  local, 2 workers: {two:.2f} runs/s (workers forked from this warmed process)")
    print(f"  parallel efficiency on 2 workers: {100 * eff:.0f} % (goal >= {100 * EFFICIENCY_GOAL:.0f} %: "
          f"{'MET' if eff >= EFFICIENCY_GOAL else 'NOT MET'})")
    print(f"  Dask LocalCluster, 2 workers, start-up included (start, warm-up, close): {dask:.2f} runs/s, "
          + verdict(dask))
    print(f"  Dask LocalCluster, 2 workers, cluster already running and warmed: {running:.2f} runs/s, "
          + verdict(running))
    print(f"  (that cluster's start-up and warm-up, outside the timing: {startup:.2f} s)")
    print(f"  for reference, the default sweep (seeds as batched worlds), 1 worker: {best['batched']:.2f} runs/s")


if __name__ == "__main__":
    main()
