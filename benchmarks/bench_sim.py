"""Simulator speed and memory, on one core: real-time factors of the L24 scenarios, estimation steps per second
of 1,000- and 10,000-UAV swarms, peak memory of two big runs.

Goals (issue 2 and the big-swarm work; the goal is printed beside each figure), for the default
``kernels: auto`` (the compiled numba fast paths); every figure has its ``kernels=numpy`` reference beside it,
measured in the same run:

- ``l24-cv`` >= 500x and ``l24-fs`` >= 200x real time in the simulation core (``simulate``), and the whole
  ``swarmtrack run l24-cv --no-plots`` process >= 100x (no regression is the goal; benchmarks/bench_cli.py holds
  issue 41's 300x); ``w20-switching`` (W20's multi-model distributed EKF, 30 Hz; issue 41) >= 250x and
  ``l24-imm`` (information-form IMM over CV, CT, FS) >= 100x real time in the simulation core;
- 1,000 UAVs (proximity topology, CV information filter, tailored flocking, hovering target, 5 s):
  >= 300 estimation steps/s;
- ``--large`` only: 10,000 UAVs, same set-up at the same density (spawn half-width 60 * sqrt(10) ~ 190 m,
  3 s): >= 20 estimation steps/s; the whole ``swarmtrack run l24-cv --no-plots`` processes of 10,000 UAVs
  (proximity network, hovering target, spawn half-width 150 m: issue 26) of 10 s and of 60 s, their recording
  written to disk: wall <= 13 s and <= 75 s, peak memory (``ru_maxrss``) <= 2 GB each, each beside its own engine
  step loop (``step_loop``, timed inside the same process: the simulation with the recorder's work in the loop; the
  rest of the wall is start-up, the metrics, health checks and the files); peak memory of ``swarmtrack run l24-ct
  --set swarm.n_uavs=1000 --set network.topology=proximity --set swarm.spawn_half_width=20 --no-plots`` <= 2 GB.
  The whole runs have no numpy reference (a second 60 s 10,000-UAV run would double the time).

The ``--large`` cases run in child processes with a memory limit (``RLIMIT_AS``) and a time-out, so a case that
runs out of memory or time is reported as ``failed: <one line>`` / ``timed out`` (``null`` plus a
``<name>_error`` string with ``--json``) instead of stopping the benchmark or swapping the machine. The
10,000-UAV steps/s are timed inside their child around the ``simulate`` call only, after a warm-up run.
Peak memory is the child's ``resource.getrusage(RUSAGE_CHILDREN).ru_maxrss`` read by a fresh wrapper process
whose only child is the run; the run's wall is timed by that wrapper (Python's start-up included), its step loop
inside the run (``_TIMED_RUN``). GB = 1e9 bytes. The whole runs also print their CPU time (user + system, every
thread, from the same ``getrusage``) beside their step loop's thread's: on a machine shared with other jobs the wall
grows with the load (2-3x at a load of 8 on 2 cores) where the CPU time grows far less.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_sim.py [--json] [--quick] [--large]``; children run
``python -m swarmtrack.cli`` on the same sources as this process. Times on the 2-core development machine
(dense simulator core, before the big-swarm rewrite):

- default (L24 cores, the whole-process runs, 1,000 UAVs): about 1 min (2 on a busy machine); ``--quick`` about 30 s;
- ``--large`` adds about 13 min today: 10,000 UAVs steps/s, compiled about 4 min and numpy about 8 min
  (time-out 15 min each); the 10 s and 60 s 10,000-UAV runs 11.7 s and 66 s on the quiet 2-core machine (issue 41;
  step loops 9.1 s and 58 s, CPU 13.7 s and 79 s with the recorder's writer thread; 20 s and 147 s before it), 2-3x
  that when the machine is shared (time-outs 10 and 30 min; the swarm contracts around the hovering target to
  hundreds of neighbours within r_comm each and spreads again, 106 on average over the 60 s: its step loop is
  most of the wall); the 1,000-UAV l24-ct memory run fails in about 15 s (the spawn box of half-width 20 m cannot
  hold 1,000 UAVs 1 m apart).

The progress lines on stderr give the time since the start of each part.
"""

from __future__ import annotations

import os

# One core: numba serial kernels, no threaded BLAS (inherited by the child processes). Other environment
# settings are left as they are.
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import swarmtrack  # noqa: E402
from swarmtrack.scenarios import load_scenario  # noqa: E402
from swarmtrack.sim.engine import simulate  # noqa: E402

GB = 1e9
L24_SECONDS = 153.1  # simulated time of the L24 profile (linear + sinusoidal + circular)
RUN_MEMORY_LIMIT_GB = 4.0  # RLIMIT_AS of a memory run: twice its goal, far below the machine's 24 GiB
STEPS_MEMORY_LIMIT_GB = 8.0  # RLIMIT_AS of a 10,000-UAV steps/s child (the dense core needs ~3 GB today)
STEPS_TIMEOUT_S = 15 * 60
RUN_TIMEOUT_S = 20 * 60
WHOLE_RUN_TIMEOUT_S = {10: 10 * 60, 60: 30 * 60}
#: The whole runs' goals (issue 26): wall per simulated duration, peak memory.
WHOLE_RUN_WALL_GOAL_S = {10: 13.0, 60: 75.0}
WHOLE_RUN_PEAK_GOAL_GB = 2.0


def swarm_overrides(n: int, half_width: float, duration: float) -> list[str]:
    """The big-swarm set-up: proximity topology, CV information filter (l24-cv), tailored flocking, hovering target."""
    return [f"swarm.n_uavs={n}", f"swarm.spawn_half_width={half_width:g}", "swarm.spawn_center=[0, 0]",
            "network.topology=proximity", "target.profile=hover", f"duration={duration:g}", "sensor.latency=0"]


SWARM_1K = swarm_overrides(1000, 60, 5)
HALF_WIDTH_10K = round(60 * math.sqrt(10))  # same density as 1,000 UAVs in a half-width of 60 m
SWARM_10K_STEPS = swarm_overrides(10_000, HALF_WIDTH_10K, 3)
HALF_WIDTH_10K_RUN = 150  # the whole runs' set-up (issue 26): 10,000 UAVs a little denser than the steps/s case
SWARM_10K_RUN = {seconds: swarm_overrides(10_000, HALF_WIDTH_10K_RUN, seconds) for seconds in (10, 60)}
CT_1K_RUN = ["swarm.n_uavs=1000", "network.topology=proximity", "swarm.spawn_half_width=20"]


@dataclass
class Figure:
    """One measured figure and its reference (``kernels=numpy``), both ``None`` when not measured."""

    name: str  # JSON key, snake_case; the reference is ``<name>_<ref_key>``
    label: str
    unit: str  # printed after the value
    goal: str  # e.g. ">= 500x"
    value: float | None
    wall: str = ""
    error: str | None = None
    ref: float | None = None
    ref_wall: str = ""
    ref_error: str | None = None
    has_ref: bool = True
    met: bool | None = None
    ref_key: str = "numpy"  # the reference's JSON key suffix
    ref_label: str = "kernels=numpy"


def best_of(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def child_env() -> dict[str, str]:
    """This process's environment with the imported ``swarmtrack`` sources first on PYTHONPATH."""
    src = str(Path(swarmtrack.__file__).resolve().parents[1])
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([src, *filter(None, [env.get("PYTHONPATH")])])
    return env


def cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "swarmtrack.cli", *args]


def one_line(text: str, limit: int = 300) -> str:
    """The last non-empty line of a child's stderr (its exception or click error), shortened."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    line = lines[-1] if lines else "(no message)"
    return line if len(line) <= limit else line[: limit - 3] + "..."


# A fresh wrapper process whose only child is the command: its RUSAGE_CHILDREN maxrss is the command's peak, its
# user + system time the command's CPU time (all its threads). argv[1] = JSON [command, address-space limit in bytes,
# time-out in s]; prints one JSON line.
_MEMORY_WRAPPER = """\
import json, resource, subprocess, sys, time
cmd, limit, timeout = json.loads(sys.argv[1])
def limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
t0 = time.perf_counter()
try:
    p = subprocess.run(cmd, preexec_fn=limit_memory, capture_output=True, text=True, timeout=timeout)
    out = {"returncode": p.returncode, "stderr": p.stderr[-4000:], "timed_out": False}
except subprocess.TimeoutExpired:
    out = {"returncode": None, "stderr": "", "timed_out": True}
out["wall"] = time.perf_counter() - t0
usage = resource.getrusage(resource.RUSAGE_CHILDREN)
out["maxrss_kb"], out["cpu_s"] = usage.ru_maxrss, usage.ru_utime + usage.ru_stime
print(json.dumps(out))
"""


# ``swarmtrack run`` in this process with its engine's step loop timed: argv[1] = the JSON file the times go to,
# argv[2:] = the command line after ``swarmtrack``. The loop is timed around ``engine.step_loop`` (the simulation
# and the recorder's work in the loop; ``step_loop_cpu``: the CPU time of the thread that runs it, without the
# recorder's writer thread), ``process`` from this code's start to the end of the command.
_TIMED_RUN = """\
import json, sys, time
t0 = time.perf_counter()
out, argv = sys.argv[1], sys.argv[2:]
from swarmtrack.sim import engine
inner, spent = engine.step_loop, {}
def step_loop(*args, **kwargs):
    start, cpu = time.perf_counter(), time.thread_time()
    try:
        return inner(*args, **kwargs)
    finally:
        spent["step_loop"] = time.perf_counter() - start
        spent["step_loop_cpu"] = time.thread_time() - cpu
engine.step_loop = step_loop
from swarmtrack.cli import main
sys.argv = ["swarmtrack", *argv]
try:
    main()
finally:
    spent["process"] = time.perf_counter() - t0
    with open(out, "w") as f:
        json.dump(spent, f)
"""


def peak_memory(cmd: list[str], limit_gb: float, timeout: float,
                cpu: dict | None = None) -> tuple[float | None, float, str | None]:
    """Peak RSS (GB) of ``cmd`` run under an address-space limit and a time-out: (GB or None, wall s, error);
    ``cpu["cpu_s"]``, when a dict is given, the command's CPU time (user + system, every thread)."""
    try:
        p = subprocess.run([sys.executable, "-c", _MEMORY_WRAPPER, json.dumps([cmd, int(limit_gb * GB), timeout])],
                           capture_output=True, text=True, env=child_env(), timeout=timeout + 120)
        res = json.loads(p.stdout.strip().splitlines()[-1])
    except Exception as exc:  # the wrapper itself failed: report it, keep benchmarking
        return None, 0.0, f"failed: memory wrapper: {type(exc).__name__}: {exc}"[:300]
    peak = res["maxrss_kb"] * 1024 / GB
    if cpu is not None:
        cpu["cpu_s"] = res.get("cpu_s")
    if res["timed_out"]:
        return None, res["wall"], f"timed out after {timeout:.0f} s (peak {peak:.2f} GB so far)"
    if res["returncode"] != 0:
        return None, res["wall"], (f"failed (exit {res['returncode']}, limit {limit_gb:g} GB, peak {peak:.2f} GB): "
                                   f"{one_line(res['stderr'])}")
    return peak, res["wall"], None


# A child that times one simulate() call (after a small warm-up run that loads the compiled kernels) under an
# address-space limit. argv[1] = JSON [overrides, limit in bytes]; prints one JSON line.
_STEPS_CHILD = """\
import json, resource, sys, time
overrides, limit = json.loads(sys.argv[1])
resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate
warm = [o for o in overrides if not o.startswith(("swarm.n_uavs=", "duration="))]
simulate(load_scenario("l24-cv", [*warm, "swarm.n_uavs=20", "duration=0.5"]))
scn = load_scenario("l24-cv", overrides)
t0 = time.perf_counter()
simulate(scn)
wall = time.perf_counter() - t0
print(json.dumps({"wall": wall, "steps": round(scn.run_duration() * scn.rates.estimation)}))
"""


def steps_in_child(overrides: list[str], limit_gb: float, timeout: float) -> tuple[float | None, str, str | None]:
    """Estimation steps/s of l24-cv with ``overrides``, timed in a child: (steps/s or None, wall text, error)."""
    try:
        p = subprocess.run([sys.executable, "-c", _STEPS_CHILD, json.dumps([overrides, int(limit_gb * GB)])],
                           capture_output=True, text=True, env=child_env(), timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, "", f"timed out after {timeout:.0f} s"
    if p.returncode != 0:
        return None, "", f"failed (exit {p.returncode}, limit {limit_gb:g} GB): {one_line(p.stderr)}"
    res = json.loads(p.stdout.strip().splitlines()[-1])
    return res["steps"] / res["wall"], f"{res['wall']:.2f} s / {res['steps']} steps", None


def steps_in_process(overrides: list[str]) -> tuple[float, str]:
    scn = load_scenario("l24-cv", overrides)
    # warm-up: the first run of a process also loads scipy's KD-tree and the sparse kernels' numba cache (about
    # 2x the steady-state time at 1,000 UAVs), which is not the simulator's speed
    simulate(load_scenario("l24-cv", [*overrides, "duration=0.2"]))
    wall = best_of(lambda: simulate(scn), repeat=2)
    steps = round(scn.run_duration() * scn.rates.estimation)
    return steps / wall, f"{wall:.2f} s / {steps} steps"


def measure(large: bool, repeat: int, progress) -> list[Figure]:
    figs = []
    # w20-switching-ideal: the clean camera issue 26 measured (w20-switching has issue 27's error budget)
    for name, goal in (("l24-cv", 500), ("l24-fs", 200), ("w20-switching-ideal", 250), ("l24-imm", 100)):
        res = {}
        for kernels in ("auto", "numpy"):
            progress(f"{name} simulation core, kernels={kernels}")
            scn = load_scenario(name, [f"kernels={kernels}"])
            wall = best_of(lambda scn=scn: simulate(scn), repeat)
            res[kernels] = (scn.run_duration() / wall, f"{wall:.2f} s")
        figs.append(Figure(f"{name.replace('-', '_')}_core_realtime_factor", f"{name} simulation core",
                           "x real time", f">= {goal}x", res["auto"][0], res["auto"][1], ref=res["numpy"][0],
                           ref_wall=res["numpy"][1], met=res["auto"][0] >= goal))

    out = Path(tempfile.mkdtemp(prefix="bench-sim-"))
    try:
        res = {}
        for kernels in ("auto", "numpy"):
            progress(f"swarmtrack run l24-cv --no-plots, kernels={kernels}")
            cmd = cli("run", "l24-cv", "--set", f"kernels={kernels}", "--no-plots", "--out", str(out / "r"),
                      "--overwrite")  # best_of runs it again into the same folder
            wall = best_of(lambda cmd=cmd: subprocess.run(cmd, check=True, capture_output=True, env=child_env()),
                           repeat)
            res[kernels] = (L24_SECONDS / wall, f"{wall:.2f} s")
    finally:
        shutil.rmtree(out, ignore_errors=True)
    figs.append(Figure("l24_cv_run_realtime_factor", "swarmtrack run l24-cv --no-plots", "x real time", ">= 100x",
                       res["auto"][0], res["auto"][1], ref=res["numpy"][0], ref_wall=res["numpy"][1],
                       met=res["auto"][0] >= 100))

    res = {}
    for kernels in ("auto", "numpy"):
        progress(f"1,000 UAVs, kernels={kernels}")
        res[kernels] = steps_in_process([*SWARM_1K, f"kernels={kernels}"])
    figs.append(Figure("uav1000_steps_per_s", "1,000 UAVs, proximity, CV, flocking", "estimation steps/s",
                       ">= 300 steps/s", res["auto"][0], res["auto"][1], ref=res["numpy"][0],
                       ref_wall=res["numpy"][1], met=res["auto"][0] >= 300))
    if not large:
        return figs

    res = {}
    for kernels in ("auto", "numpy"):
        progress(f"10,000 UAVs, kernels={kernels} (child process, time-out {STEPS_TIMEOUT_S} s)")
        res[kernels] = steps_in_child([*SWARM_10K_STEPS, f"kernels={kernels}"], STEPS_MEMORY_LIMIT_GB,
                                      STEPS_TIMEOUT_S)
    (v, w, e), (rv, rw, re) = res["auto"], res["numpy"]
    figs.append(Figure("uav10000_steps_per_s", "10,000 UAVs, proximity, CV, flocking", "estimation steps/s",
                       ">= 20 steps/s", v, w, e, rv, rw, re, met=None if v is None else v >= 20))

    for seconds in (10, 60):
        figs += whole_run(seconds, progress)

    label = "swarmtrack run l24-ct, 1,000 UAVs, proximity"
    progress(f"{label} (memory limit {RUN_MEMORY_LIMIT_GB:g} GB, time-out {RUN_TIMEOUT_S} s)")
    out = Path(tempfile.mkdtemp(prefix="bench-sim-"))
    try:
        args = cli("run", "l24-ct", *[a for o in CT_1K_RUN for a in ("--set", o)], "--no-plots",
                   "--out", str(out / "r"))
        peak, wall, err = peak_memory(args, RUN_MEMORY_LIMIT_GB, RUN_TIMEOUT_S)
    finally:
        shutil.rmtree(out, ignore_errors=True)
    figs.append(Figure("l24_ct_uav1000_run_peak_rss_gb", label, "GB peak RSS", "<= 2 GB", peak, f"{wall:.1f} s", err,
                       has_ref=False, met=None if peak is None else peak <= 2.0))
    return figs


def whole_run(seconds: int, progress) -> list[Figure]:
    """The whole ``swarmtrack run l24-cv --no-plots`` process of 10,000 UAVs for ``seconds`` simulated seconds, its
    recording written to disk: its wall (with the step loop of the same run as reference), its peak memory, and its
    CPU time (user + system, the recorder's writer thread included; the step loop's thread's as reference), which a
    machine shared with other jobs inflates less than the wall: on a quiet machine the wall is about the CPU time
    of the main thread (the writer thread runs on the second core)."""
    label = f"10,000 UAVs, whole {seconds} s run"
    timeout = WHOLE_RUN_TIMEOUT_S[seconds]
    progress(f"{label} (memory limit {RUN_MEMORY_LIMIT_GB:g} GB, time-out {timeout} s)")
    out = Path(tempfile.mkdtemp(prefix="bench-sim-"))
    try:
        args = ["run", "l24-cv", *[a for o in SWARM_10K_RUN[seconds] for a in ("--set", o)], "--no-plots", "--out",
                str(out / "r")]
        cpu: dict = {}
        peak, wall, err = peak_memory([sys.executable, "-c", _TIMED_RUN, str(out / "times.json"), *args],
                                      RUN_MEMORY_LIMIT_GB, timeout, cpu)
        times = json.loads((out / "times.json").read_text()) if (out / "times.json").exists() else {}
    finally:
        shutil.rmtree(out, ignore_errors=True)
    loop = times.get("step_loop")
    wall_goal, name = WHOLE_RUN_WALL_GOAL_S[seconds], f"uav10000_run{seconds}"
    extra = "" if loop is None else f" ({wall - loop:.1f} s besides)"
    return [Figure(f"{name}_wall_s", f"{label}, wall", "s", f"<= {wall_goal:g} s", None if err else wall,
                   f"{wall:.1f} s{extra}", err, ref=loop, ref_wall="same run", ref_error=None if loop else "not timed",
                   met=None if err else wall <= wall_goal, ref_key="step_loop_s", ref_label="engine step loop"),
            Figure(f"{name}_peak_rss_gb", f"{label}, peak memory", "GB peak RSS", f"<= {WHOLE_RUN_PEAK_GOAL_GB:g} GB",
                   peak, f"{wall:.1f} s", err, has_ref=False,
                   met=None if peak is None else peak <= WHOLE_RUN_PEAK_GOAL_GB),
            Figure(f"{name}_cpu_s", f"{label}, CPU time", "s", "(no goal)", None if err else cpu.get("cpu_s"),
                   "all threads", err or (None if cpu.get("cpu_s") is not None else "not measured"),
                   ref=times.get("step_loop_cpu"), ref_wall="its thread",
                   ref_error=None if times.get("step_loop_cpu") is not None else "not timed",
                   ref_key="step_loop_s", ref_label="engine step loop")]


def as_json(figs: list[Figure]) -> dict:
    out = {}
    for f in figs:
        for key, value, error in ((f.name, f.value, f.error), (f"{f.name}_{f.ref_key}", f.ref, f.ref_error)):
            if key != f.name and not f.has_ref:
                continue
            out[key] = None if value is None else round(value, 4)
            if error is not None:
                out[f"{key}_error"] = error
    return out


def print_table(figs: list[Figure]) -> None:
    def shown(value, error, unit):
        if value is None:
            return error if len(error) <= 100 else error[:97] + "..."
        sep = "" if unit.startswith("x ") else " "
        return f"{value:.1f}{sep}{unit}" if value < 1000 else f"{value:.0f}{sep}{unit}"

    rows = []
    for f in figs:
        verdict = "" if f.met is None else (" (met)" if f.met else " (NOT MET)")
        rows.append((f.label, f.wall, shown(f.value, f.error, f.unit), f.goal + verdict))
        if f.has_ref:
            rows.append((f"  {f.ref_label.strip()}", f.ref_wall, shown(f.ref, f.ref_error, f.unit), "(reference)"))
    width = max(len(r[0]) for r in rows)
    print(f"{'benchmark':{width}s}  {'wall':>22s}  {'figure':>28s}  goal")
    for r in rows:
        print(f"{r[0]:{width}s}  {r[1]:>22s}  {r[2]:>28s}  {r[3]}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--json", action="store_true", help="print one flat JSON object {name: value} instead")
    parser.add_argument("--quick", action="store_true", help="one repeat instead of the best of 3 (smoke test)")
    parser.add_argument("--large", action="store_true",
                        help="add 10,000 UAVs and the two memory runs (minutes; see the module docstring)")
    args = parser.parse_args(argv)

    t0 = time.perf_counter()

    def progress(msg: str) -> None:  # on stderr, with the time since the start: how long each part takes
        print(f"[{time.perf_counter() - t0:6.0f} s] {msg}", file=sys.stderr, flush=True)

    load = os.getloadavg()[0]  # other work on the machine slows every figure: kept beside them
    figs = measure(args.large, 1 if args.quick else 3, progress)
    progress("done")
    if args.json:
        print(json.dumps({**as_json(figs), "load_average_1min": round(load, 2)}))
    else:
        print(f"one core (NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}); 1-min load average at start "
              f"{load:.2f} on {os.cpu_count()} cores")
        print_table(figs)


if __name__ == "__main__":
    main()
