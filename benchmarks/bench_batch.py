"""Many worlds per process: seeds run as batched worlds (:mod:`swarmtrack.sim.batch`) against one process per seed,
with one world at a time in one process as the same-run reference. Goals: 100 seeds as batched worlds ≥ 5× the
throughput of one process per seed, for ``l24-cv`` (issue 10: the information filter and flocking) and for
``w20-switching-ideal`` (issue 26: the clean camera and the multi-model EKF, 73.7 s at 30 Hz). One core; every
figure is runs per second including the metrics of each run (what a study keeps).

* one process per seed: a fresh interpreter per run (import, numba cache load, run, metrics), as a naive study
  script or a job array does; timed on a few seeds and taken per run;
* one world at a time: :func:`swarmtrack.analysis.runs.run_one` per seed in this process;
* batched: :func:`swarmtrack.analysis.runs.run_batch` in batches of at most ``BATCH_WORLDS`` worlds.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_batch.py [--json] [--quick] [--scenario NAME]`` (about
3 min; ``--quick`` runs 20 seeds of 30 s instead of 100 full ones). ``--json`` prints one flat JSON object, its
keys prefixed by the scenario (``w20-switching-ideal.batched_vs_per_process``).
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

from swarmtrack.analysis.runs import BATCH_WORLDS, batches, run_batch, run_one  # noqa: E402
from swarmtrack.scenarios import load_scenario  # noqa: E402

GOAL = 5.0
SCENARIOS = ("l24-cv", "w20-switching-ideal")  # the clean camera issue 26 measured (issue 27 added a budget)
_ONE = ("import sys; from swarmtrack.analysis.runs import run_one; from swarmtrack.scenarios import "
        "load_scenario; run_one(load_scenario(sys.argv[1], sys.argv[3:], seed=int(sys.argv[2])))")


def per_process(name: str, seeds: list[int], overrides: list[str]) -> float:
    """Runs per second with a fresh interpreter per seed."""
    t0 = time.perf_counter()
    for s in seeds:
        subprocess.run([sys.executable, "-c", _ONE, name, str(s), *overrides], check=True, env=os.environ.copy())
    return len(seeds) / (time.perf_counter() - t0)


def measure(name: str, quick: bool) -> dict:
    """The three throughputs of ``name``'s seeds and the goal's verdict."""
    runs, overrides = (20, ["duration=30"]) if quick else (100, [])
    scenarios = [load_scenario(name, overrides, seed=s) for s in range(1, runs + 1)]
    run_batch(scenarios[:2])  # numba caches loaded, as in a worker that has run before
    process = per_process(name, list(range(1, 4 if quick else 6)), overrides)
    alone_n = min(runs, 10)
    t0 = time.perf_counter()
    for s in scenarios[:alone_n]:
        run_one(s)
    alone = alone_n / (time.perf_counter() - t0)
    t0 = time.perf_counter()
    for group in batches(scenarios):
        run_batch([scenarios[k] for k in group])
    batched = runs / (time.perf_counter() - t0)
    return {"runs": runs, "simulated_s": scenarios[0].run_duration(), "batch_worlds": BATCH_WORLDS,
            "per_process_runs_per_s": process, "one_world_at_a_time_runs_per_s": alone,
            "batched_runs_per_s": batched, "batched_vs_per_process": batched / process,
            "batched_vs_one_at_a_time": batched / alone, "goal": GOAL, "met": batched / process >= GOAL}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--scenario", choices=SCENARIOS, action="append", help="only these (default: both)")
    args = parser.parse_args(argv)
    results = {name: measure(name, args.quick) for name in args.scenario or SCENARIOS}
    if args.json:
        print(json.dumps({f"{name}.{k}": v for name, out in results.items() for k, v in out.items()}))
        return
    for name, out in results.items():
        print(f"{name}, {out['runs']} seeds of {out['simulated_s']:g} s simulated, one core; runs/s including each "
              "run's metrics")
        print(f"  one process per seed         {out['per_process_runs_per_s']:7.2f} runs/s")
        print(f"  one world at a time          {out['one_world_at_a_time_runs_per_s']:7.2f} runs/s  (this process, "
              "the same-run reference)")
        print(f"  batched worlds (<= {BATCH_WORLDS} each) {out['batched_runs_per_s']:7.2f} runs/s  = "
              f"{out['batched_vs_per_process']:.1f}x one process per seed, {out['batched_vs_one_at_a_time']:.1f}x "
              "one world at a time")
        print(f"Goal: {name} batched >= {GOAL:g}x one process per seed: {'MET' if out['met'] else 'NOT MET'}")


if __name__ == "__main__":
    main()
