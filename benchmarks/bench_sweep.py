"""Sweep throughput: ``l24-cv`` runs per second through :func:`swarmtrack.analysis.sweep.sweep` with 1 and 2 local
worker processes, and the parallel efficiency (issue 10's goal: ≥ 85 % on 2 workers). Each case sweeps a fresh
store (seeds 1..RUNS of the built-in ``l24-cv``, 153 s simulated each), so the figure includes the worker start-up,
the per-run Parquet writes and the validation of every job before the runs; the Dask case starts its
LocalCluster (2 single-threaded worker processes) inside the timing too. Goal: Dask within 10 % of local processes.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_sweep.py [--json] [--quick]`` (about 1 min; ``--quick``
sweeps 4 runs instead of 12). ``--json`` prints one flat JSON object.
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

from swarmtrack.analysis.sweep import load_results, sweep  # noqa: E402
from swarmtrack.scenarios import load_scenario  # noqa: E402
from swarmtrack.sim.engine import simulate  # noqa: E402

EFFICIENCY_GOAL = 0.85


def rate(runs: int, workers: int, root: Path, cluster: str | None = None) -> float:
    out = root / f"w{workers}-{cluster}"
    t0 = time.perf_counter()
    sweep("l24-cv", {"network.topology": ["line"]}, runs, out, workers=workers, cluster=cluster)
    wall = time.perf_counter() - t0
    assert (load_results(out)["status"] == "ok").all()
    return runs / wall


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    runs = 4 if args.quick else 12
    simulate(load_scenario("l24-cv", ["duration=1"]))  # numba caches loaded in this process
    with tempfile.TemporaryDirectory(prefix="bench-sweep-") as tmp:
        one = rate(runs, 1, Path(tmp))
        two = rate(runs, 2, Path(tmp))
        dask = rate(runs, 2, Path(tmp), cluster="local")
    eff = two / (2 * one)
    if args.json:
        print(json.dumps({"sweep_runs_per_s_1_worker": round(one, 3), "sweep_runs_per_s_2_workers": round(two, 3),
                          "parallel_efficiency_2_workers": round(eff, 3),
                          "sweep_runs_per_s_dask_local_2_workers": round(dask, 3)}))
        return
    print(f"sweep of l24-cv, {runs} runs (153 s simulated each), local processes")
    print(f"  1 worker : {one:.2f} runs/s")
    print(f"  2 workers: {two:.2f} runs/s")
    print(f"  parallel efficiency on 2 workers: {100 * eff:.0f} % (goal >= {100 * EFFICIENCY_GOAL:.0f} %: "
          f"{'MET' if eff >= EFFICIENCY_GOAL else 'NOT MET'})")
    print(f"  Dask LocalCluster, 2 workers: {dask:.2f} runs/s, {100 * dask / two:.0f} % of local processes "
          f"(goal >= 90 %: {'MET' if dask >= 0.9 * two else 'NOT MET'})")


if __name__ == "__main__":
    main()
