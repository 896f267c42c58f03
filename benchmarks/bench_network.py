"""Imperfect networks and time (issue 11): what time-stamp handling costs the clean case, and what late data,
gating and delays cost when they are used. One core.

Goal: the ``l24-cv`` simulation core with no latency and no delay (the clean case) at most 10 % slower than before
time stamps existed. "Before" is the sources of a git revision (``--before``, default the last commit before issue
11's time stamps), exported into a temporary folder and timed in a child process; "after" is this checkout, timed
the same way. The two are interleaved (before, after, before, ...) and each reports its best of ``--repeat`` runs,
so a load on the machine hits both alike. The other figures are the costs of the new paths beside the clean one,
measured in the same run: ``l24-cv`` with its 0.15 s latency fused as current (the paper's filter) and at its time
stamps (re-filtering 3 steps), ``robust-5`` (5 UAVs, full topology) clean, with random network delays up to 0.5 s
(re-filtering up to 10 steps), and with the χ²-gate.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_network.py [--json] [--repeat N] [--before REV]``
(needs git for the "before"; about 1 min).
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
import tarfile  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: The last commit before issue 11's time stamps.
BEFORE = "db1101e"
CLEAN = ("l24-cv", ("sensor.latency=0",))
CHILD = """
import sys, time
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate
s = load_scenario(sys.argv[1], sys.argv[2:])
simulate(load_scenario(sys.argv[1], sys.argv[2:] + ["duration=2"]))  # compile and warm up
t0 = time.perf_counter()
simulate(s)
print(time.perf_counter() - t0, s.run_duration())
"""


def time_core(src: Path, name: str, overrides: tuple[str, ...]) -> tuple[float, float]:
    """(wall s, simulated s) of one ``simulate`` of the scenario with the sources under ``src``."""
    env = {**os.environ, "PYTHONPATH": str(src)}
    out = subprocess.run([sys.executable, "-c", CHILD, name, *overrides], env=env, capture_output=True, text=True,
                         check=True).stdout.split()
    return float(out[0]), float(out[1])


def export(rev: str, into: Path) -> Path:
    """The ``src`` folder of revision ``rev`` (``git archive``), unpacked into ``into``."""
    archive = into / "src.tar"
    subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", "-o", str(archive), rev, "src"], check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(into, filter="data")
    return into / "src"


def best(src: Path, name: str, overrides: tuple[str, ...], repeat: int) -> float:
    return min(time_core(src, name, overrides)[0] for _ in range(repeat))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--before", default=BEFORE, help="git revision of the 'before' sources")
    args = parser.parse_args()
    here = ROOT / "src"
    res: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        before_src = export(args.before, Path(tmp))
        before, after = [], []
        for _ in range(args.repeat):  # interleaved: a load hits both alike
            before.append(time_core(before_src, *CLEAN)[0])
            after.append(time_core(here, *CLEAN)[0])
    sim_s = time_core(here, *CLEAN)[1]
    res["clean_before_s"], res["clean_after_s"] = min(before), min(after)
    res["clean_slowdown"] = min(after) / min(before) - 1.0
    res["clean_real_time_after"] = sim_s / min(after)
    cases = {"l24-cv latency 0.15 s, as current": ("l24-cv", ()),
             "l24-cv latency 0.15 s, refilter": ("l24-cv", ("estimator.delayed_data=refilter",)),
             "robust-5 clean": ("robust-5", ()),
             "robust-5 delays up to 0.5 s, refilter": ("robust-5", ("network.delay_max=0.5",)),
             "robust-5 chi2 gate": ("robust-5", ("estimator.gating=chi2",)),
             "robust-5 liar, chi2 gate": ("robust-5", ("estimator.gating=chi2", "network.liar={uav: 3}"))}
    res["cases_real_time"] = {k: sim_s_ / best(here, name, ov, max(1, args.repeat // 2))
                              for k, (name, ov) in cases.items()
                              for sim_s_ in [time_core(here, name, ov)[1]]}
    if args.json:
        print(json.dumps(res, indent=2))
        return
    print(f"clean case (l24-cv, no latency), simulation core, best of {args.repeat}:")
    print(f"  before ({args.before}): {res['clean_before_s']:.3f} s   after: {res['clean_after_s']:.3f} s   "
          f"change {100 * res['clean_slowdown']:+.1f} % (goal <= +10 %)   after: "
          f"{res['clean_real_time_after']:.0f}x real time")
    print("new paths, real-time factor of the simulation core (same run):")
    for k, v in res["cases_real_time"].items():
        print(f"  {k:45s} {v:8.0f}x")


if __name__ == "__main__":
    t0 = time.perf_counter()
    main()
    print(f"({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
