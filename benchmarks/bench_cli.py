"""Command-line start-up: how fast ``swarmtrack --help`` answers, and whole ``swarmtrack run l24-cv --no-plots`` and
``swarmtrack run w20-switching-ideal --no-plots`` processes in times real time.

Goals (issues 26 and 41; the goal is printed beside each figure), each figure with references measured in the same run:

- ``swarmtrack --help`` <= 0.25 s wall (best of 10 fresh processes; ``--quick``: 3), beside the start-up of
  ``python -c pass`` and of ``python -c "import click"`` (what any click program pays);
- the whole ``swarmtrack run l24-cv --no-plots`` process >= 300x real time, and its start-up and teardown (the
  whole process's wall minus its simulation core's) <= 0.35 s; the whole ``swarmtrack run w20-switching-ideal
  --no-plots`` process >= 120x (the scenario's simulated duration / the process's wall time, best of 3;
  ``--quick``: 1), each beside its simulation core alone (``simulate`` timed inside a child process after a
  warm-up run): the difference is what the process spends starting and ending.

Python's bytecode cache: an installed package's modules are compiled once (``pip install`` writes their ``.pyc``,
and an editable install's are written on first import), so the measured processes run with a bytecode cache of
their own, in a temporary folder this benchmark makes and removes (``PYTHONPYCACHEPREFIX``; nothing is written
beside the sources), filled by a warm-up run. Beside each whole run, the same process without any bytecode cache
(``PYTHONDONTWRITEBYTECODE=1``: every swarmtrack module compiled from source at each start, as on a machine whose
environment sets it, this development machine's included) is printed as a reference.

The commands run as the ``swarmtrack`` console script does (``from swarmtrack.cli import main; main()``) on the
same sources as this process, on one core (the numba and BLAS thread settings below, as benchmarks/bench_sim.py).
``--importtime`` also prints where a whole ``swarmtrack run l24-cv --no-plots`` process spends its imports
(``python -X importtime``, self times summed by top-level package; the profiler's own cost inflates them).

Run: ``.venv/bin/python benchmarks/bench_cli.py [--json] [--quick] [--importtime]``; about 1 min (20 s with
``--quick``) on the 2-core development machine. ``--json`` keys of the W20 run are prefixed ``w20_switching_ideal_``
(the clean camera issue 26 measured); ``*_nopyc_*`` keys are the runs without a bytecode cache.
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
#: scenario → its whole run's goal, x real time (the l24-cv figures keep their unprefixed JSON keys; issue 41)
RUN_GOALS = {"l24-cv": 300.0, "w20-switching-ideal": 120.0}  # the clean camera issue 26 measured
#: the start-up and teardown of a whole l24-cv run (its wall minus its core's), s (issue 41)
STARTUP_GOAL_S = 0.35

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


def child_env(pycache: str | None) -> dict[str, str]:
    """This process's environment with the repository's sources first on PYTHONPATH, and Python's bytecode cached in
    the folder ``pycache`` (or, with None, not cached at all: every module compiled from source at each start)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(SRC), *filter(None, [env.get("PYTHONPATH")])])
    env.pop("PYTHONPYCACHEPREFIX", None)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if pycache is None:
        env["PYTHONDONTWRITEBYTECODE"] = "1"
    else:
        env["PYTHONPYCACHEPREFIX"] = pycache
    return env


def best_wall(cmd: list[str], repeat: int, env: dict[str, str]) -> float:
    """Best wall time (s) of ``repeat`` runs of ``cmd`` as a fresh process (its output discarded; it must succeed)."""
    walls = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        walls.append(time.perf_counter() - t0)
    return min(walls)


def measure(quick: bool, progress, pycache: str) -> dict:
    starts, runs = (3, 1) if quick else (10, 3)
    res = {}
    env = child_env(pycache)
    progress(f"start-up: python -c pass, python -c 'import click', swarmtrack --help (best of {starts} each)")
    for _ in range(2):  # warm the file cache: the first start of a process reads the files from disk
        best_wall(SWARMTRACK + ["--help"], 1, env)
    res["python_pass_s"] = best_wall([sys.executable, "-c", "pass"], starts, env)
    res["import_click_s"] = best_wall([sys.executable, "-c", "import click"], starts, env)
    res["help_s"] = best_wall(SWARMTRACK + ["--help"], starts, env)

    for scenario in RUN_GOALS:
        res.update(whole_run(scenario, runs, progress, pycache))
    return res


def _key(scenario: str) -> str:
    return "" if scenario == "l24-cv" else scenario.replace("-", "_") + "_"


def whole_run(scenario: str, runs: int, progress, pycache: str) -> dict:
    """The simulation core alone (in a child) and the whole ``swarmtrack run`` process of ``scenario``, with the
    bytecode cache ``pycache`` (after a warm-up run that fills it) and without any."""
    progress(f"simulation core of {scenario} in a child (warm-up, then best of {runs})")
    p = subprocess.run([sys.executable, "-c", _CORE_CHILD, json.dumps([scenario, runs])], check=True,
                       capture_output=True, text=True, env=child_env(pycache))
    core = json.loads(p.stdout.strip().splitlines()[-1])
    progress(f"whole swarmtrack run {scenario} --no-plots processes (warm-up, then best of {runs}; "
             "and as many without a bytecode cache)")
    out = Path(tempfile.mkdtemp(prefix="bench-cli-"))
    cmd = SWARMTRACK + ["run", scenario, "--no-plots", "--out", str(out / "r"), "--overwrite"]  # again into it
    try:
        best_wall(cmd, 1, child_env(pycache))
        wall = best_wall(cmd, runs, child_env(pycache))
        nopyc = best_wall(cmd, runs, child_env(None))
    finally:
        shutil.rmtree(out, ignore_errors=True)
    k = _key(scenario)
    return {f"{k}duration_s": core["duration"], f"{k}core_wall_s": core["wall"], f"{k}run_wall_s": wall,
            f"{k}run_realtime_factor": core["duration"] / wall,
            f"{k}core_realtime_factor": core["duration"] / core["wall"],
            f"{k}startup_teardown_s": wall - core["wall"], f"{k}run_nopyc_wall_s": nopyc,
            f"{k}startup_teardown_nopyc_s": nopyc - core["wall"]}


def import_profile(pycache: str, top: int = 12) -> list[tuple[str, float, int]]:
    """``python -X importtime`` of a whole ``swarmtrack run l24-cv --no-plots`` (bytecode cached): (top-level
    package, its modules' self import time in s, how many modules), largest first."""
    out = Path(tempfile.mkdtemp(prefix="bench-cli-"))
    try:
        p = subprocess.run([sys.executable, "-X", "importtime", *SWARMTRACK[1:], "run", "l24-cv", "--no-plots",
                            "--out", str(out / "r")], check=True, capture_output=True, text=True,
                           env=child_env(pycache))
    finally:
        shutil.rmtree(out, ignore_errors=True)
    packages: dict[str, list[float]] = {}
    for line in p.stderr.splitlines():
        parts = line.removeprefix("import time:").split("|")
        if len(parts) == 3 and parts[0].strip().isdigit():
            entry = packages.setdefault(parts[2].strip().split(".")[0], [0.0, 0])
            entry[0] += int(parts[0]) / 1e6
            entry[1] += 1
    return sorted(((name, t, int(n)) for name, (t, n) in packages.items()), key=lambda r: -r[1])[:top]


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
        startup = res[f"{k}startup_teardown_s"]
        startup_goal = f"<= {STARTUP_GOAL_S} s ({'MET' if startup <= STARTUP_GOAL_S else 'NOT MET'})" if not k else ""
        nopyc = res[f"{k}run_nopyc_wall_s"]
        rows += [
            (f"swarmtrack run {scenario} --no-plots, whole process",
             f"{res[f'{k}run_wall_s']:.2f} s = {res[f'{k}run_realtime_factor']:.1f}x real time",
             f">= {goal:g}x ({met})"),
            ("  simulation core alone (simulate)",
             f"{res[f'{k}core_wall_s']:.2f} s = {res[f'{k}core_realtime_factor']:.1f}x real time", "(reference)"),
            ("  start-up and teardown (the difference)", f"{startup:.2f} s", startup_goal),
            ("  whole process without a bytecode cache",
             f"{nopyc:.2f} s = {res[f'{k}duration_s'] / nopyc:.1f}x real time", "(reference)"),
            ("  its start-up and teardown", f"{res[f'{k}startup_teardown_nopyc_s']:.2f} s", "(reference)"),
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
    parser.add_argument("--importtime", action="store_true",
                        help="also print the imports of a whole l24-cv run by top-level package (python -X importtime)")
    args = parser.parse_args(argv)

    t0 = time.perf_counter()

    def progress(msg: str) -> None:  # on stderr, with the time since the start: how long each part takes
        print(f"[{time.perf_counter() - t0:6.0f} s] {msg}", file=sys.stderr, flush=True)

    load = os.getloadavg()[0]  # other work on the machine slows every figure: kept beside them
    pycache = tempfile.mkdtemp(prefix="bench-cli-pycache-")  # this benchmark's own bytecode cache, removed at the end
    try:
        res = measure(args.quick, progress, pycache)
        imports = import_profile(pycache) if args.importtime else []
    finally:
        shutil.rmtree(pycache, ignore_errors=True)
    progress("done")
    if args.json:
        met = {f"{_key(s)}run_goal_met": res[f"{_key(s)}run_realtime_factor"] >= goal for s, goal in RUN_GOALS.items()}
        print(json.dumps({**{k: round(v, 4) for k, v in res.items()}, "help_goal_met": res["help_s"] <= HELP_GOAL_S,
                          **met, "startup_goal_met": res["startup_teardown_s"] <= STARTUP_GOAL_S,
                          **{f"import_s_{name}": round(t, 4) for name, t, _ in imports},
                          "load_average_1min": round(load, 2)}))
    else:
        print(f"one core (NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}); 1-min load average at start "
              f"{load:.2f} on {os.cpu_count()} cores; l24-cv simulates {res['duration_s']:g} s, w20-switching-ideal "
              f"{res['w20_switching_ideal_duration_s']:g} s")
        print_table(res)
        if imports:
            print("\nimports of a whole swarmtrack run l24-cv --no-plots (python -X importtime, self time by package):")
            for name, t, n in imports:
                print(f"  {name:24s} {t * 1000:7.1f} ms  ({n} modules)")


if __name__ == "__main__":
    main()
