"""Command-line start-up: how fast ``swarmtrack --help`` answers, and whole ``swarmtrack run l24-cv --no-plots`` and
``swarmtrack run w20-switching-ideal --no-plots`` processes in times real time.

Goals (issue 26; the goal is printed beside each figure), each figure with references measured in the same run:

- ``swarmtrack --help`` <= 0.25 s wall (best of 10 fresh processes; ``--quick``: 3), beside the start-up of
  ``python -c pass`` and of ``python -c "import click"`` (what any click program pays);
- the whole ``swarmtrack run l24-cv --no-plots`` process >= 150x real time and the whole ``swarmtrack run
  w20-switching-ideal --no-plots`` process >= 100x (the scenario's simulated duration / the process's wall time,
  best of 3; ``--quick``: 1), each beside its simulation core alone (``simulate`` timed inside a child process
  after a warm-up run): the difference is what the process spends starting and ending.

The commands run as the ``swarmtrack`` console script does (``from swarmtrack.cli import main; main()``) on the
same sources as this process, on one core (the numba and BLAS thread settings below, as benchmarks/bench_sim.py).

Run: ``.venv/bin/python benchmarks/bench_cli.py [--json] [--quick]``; about 1 min (20 s with ``--quick``) on the
2-core development machine. ``--json`` keys of the W20 run are prefixed ``w20_switching_ideal_`` (the clean
camera issue 26 measured).
"""

from __future__ import annotations

import os

# One core, as benchmarks/bench_sim.py (inherited by the child processes).
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

SRC = Path(__file__).resolve().parents[1] / "src"
HELP_GOAL_S = 0.25
#: scenario → its whole run's goal, x real time (the l24-cv figures keep their unprefixed JSON keys)
RUN_GOALS = {"l24-cv": 150.0, "w20-switching-ideal": 100.0}  # the clean camera issue 26 measured

#: The console script ``swarmtrack`` (``[project.scripts]``), as a command line of this interpreter.
SWARMTRACK = [sys.executable, "-c", "import sys; sys.argv[0] = 'swarmtrack'; from swarmtrack.cli import main; main()"]

# The simulation core alone, timed in a child after a warm-up run (numba's cache loaded): argv[1] = JSON
# [scenario, repeat]; prints one JSON line.
_CORE_CHILD = """\
import json, sys, time
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate
name, repeat = json.loads(sys.argv[1])
simulate(load_scenario(name, ["duration=1"]))
scn = load_scenario(name)
walls = []
for _ in range(repeat):
    t0 = time.perf_counter()
    simulate(scn)
    walls.append(time.perf_counter() - t0)
print(json.dumps({"wall": min(walls), "duration": scn.run_duration()}))
"""


def child_env() -> dict[str, str]:
    """This process's environment with the repository's sources first on PYTHONPATH."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), *filter(None, [env.get("PYTHONPATH")])])
    return env


def best_wall(cmd: list[str], repeat: int) -> float:
    """Best wall time (s) of ``repeat`` runs of ``cmd`` as a fresh process (its output discarded; it must succeed)."""
    walls = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=child_env())
        walls.append(time.perf_counter() - t0)
    return min(walls)


def measure(quick: bool, progress) -> dict:
    starts, runs = (3, 1) if quick else (10, 3)
    res = {}
    progress(f"start-up: python -c pass, python -c 'import click', swarmtrack --help (best of {starts} each)")
    for _ in range(2):  # warm the file cache: the first start of a process reads the files from disk
        best_wall(SWARMTRACK + ["--help"], 1)
    res["python_pass_s"] = best_wall([sys.executable, "-c", "pass"], starts)
    res["import_click_s"] = best_wall([sys.executable, "-c", "import click"], starts)
    res["help_s"] = best_wall(SWARMTRACK + ["--help"], starts)

    for scenario in RUN_GOALS:
        res.update(whole_run(scenario, runs, progress))
    return res


def _key(scenario: str) -> str:
    return "" if scenario == "l24-cv" else scenario.replace("-", "_") + "_"


def whole_run(scenario: str, runs: int, progress) -> dict:
    """The simulation core alone (in a child) and the whole ``swarmtrack run`` process of ``scenario``."""
    progress(f"simulation core of {scenario} in a child (warm-up, then best of {runs})")
    p = subprocess.run([sys.executable, "-c", _CORE_CHILD, json.dumps([scenario, runs])], check=True,
                       capture_output=True, text=True, env=child_env())
    core = json.loads(p.stdout.strip().splitlines()[-1])
    progress(f"whole swarmtrack run {scenario} --no-plots processes (best of {runs})")
    out = Path(tempfile.mkdtemp(prefix="bench-cli-"))
    try:
        wall = best_wall(SWARMTRACK + ["run", scenario, "--no-plots", "--out", str(out / "r"), "--overwrite"],
                         runs)  # again into the same folder
    finally:
        shutil.rmtree(out, ignore_errors=True)
    k = _key(scenario)
    return {f"{k}duration_s": core["duration"], f"{k}core_wall_s": core["wall"], f"{k}run_wall_s": wall,
            f"{k}run_realtime_factor": core["duration"] / wall,
            f"{k}core_realtime_factor": core["duration"] / core["wall"]}


def print_table(res: dict) -> None:
    help_met = "MET" if res["help_s"] <= HELP_GOAL_S else "NOT MET"
    rows = [
        ("swarmtrack --help", f"{res['help_s']:.3f} s", f"<= {HELP_GOAL_S} s ({help_met})"),
        ("  python -c pass", f"{res['python_pass_s']:.3f} s", "(reference)"),
        ("  python -c 'import click'", f"{res['import_click_s']:.3f} s", "(reference)"),
    ]
    for scenario, goal in RUN_GOALS.items():
        k = _key(scenario)
        met = "MET" if res[f"{k}run_realtime_factor"] >= goal else "NOT MET"
        rows += [
            (f"swarmtrack run {scenario} --no-plots, whole process",
             f"{res[f'{k}run_wall_s']:.2f} s = {res[f'{k}run_realtime_factor']:.1f}x real time",
             f">= {goal:g}x ({met})"),
            ("  simulation core alone (simulate)",
             f"{res[f'{k}core_wall_s']:.2f} s = {res[f'{k}core_realtime_factor']:.1f}x real time", "(reference)"),
            ("  start-up and teardown (the difference)", f"{res[f'{k}run_wall_s'] - res[f'{k}core_wall_s']:.2f} s", ""),
        ]
    width = max(len(r[0]) for r in rows)
    print(f"{'benchmark':{width}s}  {'figure':>32s}  goal")
    for label, figure, goal in rows:
        print(f"{label:{width}s}  {figure:>32s}  {goal}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--json", action="store_true", help="print one flat JSON object {name: value} instead")
    parser.add_argument("--quick", action="store_true", help="fewer repeats (3 starts, 1 run; a smoke test)")
    args = parser.parse_args(argv)

    t0 = time.perf_counter()

    def progress(msg: str) -> None:  # on stderr, with the time since the start: how long each part takes
        print(f"[{time.perf_counter() - t0:6.0f} s] {msg}", file=sys.stderr, flush=True)

    load = os.getloadavg()[0]  # other work on the machine slows every figure: kept beside them
    res = measure(args.quick, progress)
    progress("done")
    if args.json:
        met = {f"{_key(s)}run_goal_met": res[f"{_key(s)}run_realtime_factor"] >= goal for s, goal in RUN_GOALS.items()}
        print(json.dumps({**{k: round(v, 4) for k, v in res.items()}, "help_goal_met": res["help_s"] <= HELP_GOAL_S,
                          **met, "load_average_1min": round(load, 2)}))
    else:
        print(f"one core (NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}); 1-min load average at start "
              f"{load:.2f} on {os.cpu_count()} cores; l24-cv simulates {res['duration_s']:g} s, w20-switching-ideal "
              f"{res['w20_switching_ideal_duration_s']:g} s")
        print_table(res)


if __name__ == "__main__":
    main()
