"""Simulator speed: real-time factors of the L24 scenarios and steps per second of a 1000-UAV swarm.

Prints its figures; goals from issue 2: l24-cv >= 500x and l24-fs >= 200x real time in the simulation core,
the whole ``swarmtrack run l24-cv --no-plots`` process >= 100x, the 1000-UAV swarm (proximity topology, CV
information filter, tailored flocking) >= 20 estimation steps/s. The goals are for the default
``kernels: auto`` (the compiled numba fast paths); the ``kernels=numpy`` rows show the numpy reference.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate


def best_of(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    rows = []
    for name, goal in (("l24-cv", 500), ("l24-fs", 200)):
        for kernels in ("auto", "numpy"):
            scn = load_scenario(name, [f"kernels={kernels}"])
            sim_time = scn.duration or 153.1
            wall = best_of(lambda scn=scn: simulate(scn))
            label, target = (f"{name} simulation core", f">= {goal}x") if kernels == "auto" else (
                f"{name} simulation core, kernels=numpy", "(reference)")
            rows.append((label, f"{wall:.2f} s", f"{sim_time / wall:.0f}x real time", target))

    exe = Path(sys.executable).with_name("swarmtrack")
    out = Path(tempfile.mkdtemp())
    try:
        wall = best_of(lambda: subprocess.run([str(exe), "run", "l24-cv", "--no-plots", "--out", str(out / "r")],
                                              check=True, capture_output=True))
    finally:
        shutil.rmtree(out, ignore_errors=True)
    rows.append(("swarmtrack run l24-cv --no-plots", f"{wall:.2f} s", f"{153.1 / wall:.0f}x real time", ">= 100x"))

    big = ["swarm.n_uavs=1000", "swarm.spawn_half_width=60", "swarm.spawn_center=[0, 0]", "network.topology=proximity",
           "target.profile=hover", "duration=5", "sensor.latency=0"]
    for kernels in ("auto", "numpy"):
        scn = load_scenario("l24-cv", [*big, f"kernels={kernels}"])
        wall = best_of(lambda scn=scn: simulate(scn), repeat=1)
        steps = 5.0 * scn.rates.estimation
        label, target = ("1000 UAVs, proximity, CV, flocking", ">= 20 steps/s") if kernels == "auto" else (
            "1000 UAVs, ..., kernels=numpy", "(reference)")
        rows.append((label, f"{wall:.2f} s / 5 s", f"{steps / wall:.1f} estimation steps/s", target))

    width = max(len(r[0]) for r in rows)
    print(f"{'benchmark':{width}s}  {'wall':>14s}  {'figure':>28s}  goal")
    for r in rows:
        print(f"{r[0]:{width}s}  {r[1]:>14s}  {r[2]:>28s}  {r[3]}")


if __name__ == "__main__":
    main()
