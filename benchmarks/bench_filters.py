"""Throughput of one information-filter cycle for a bank of N = 1000 agents, on one core.

A cycle is recover → predict → own position-mode range-bearing contribution → add (the reference,
``swarmtrack.estimation.information``) or its compiled CV fast path (``swarmtrack.estimation.kernels``:
predicted position → contribution kernel → ``cv_cycle``, which carries ``x, P`` so it needs no separate
recover), and the 3-D CV cycle with the range-bearing-elevation update (``estimation.elevation`` against
``estimation.kernels_3d``; issue 28's goal ≥ 5 M/s). Figures are agent-updates per second (N × cycles / wall
time, ``time.perf_counter``, each case timed for ≥ 1 s after a warm-up that also absorbs numba compilation).

Run: ``.venv/bin/python benchmarks/bench_filters.py [--json] [--quick]`` (about 10-20 s; ``--quick`` times each
case for 0.2 s, about 5 s). ``--json`` prints one flat JSON object ``{name: value}`` instead of the table
(agent-updates/s; a compiled figure's numpy reference is ``<name>_numpy``).
"""

from __future__ import annotations

import os

# One core: numba serial kernels, no threaded BLAS. Other environment settings are left as they are.
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from swarmtrack.estimation.elevation import POSITION_3D, RangeBearingElevationUpdate  # noqa: E402
from swarmtrack.estimation.information import (  # noqa: E402
    RangeBearingUpdate,
    add_position_information,
    initial_information,
    predict,
    recover,
)
from swarmtrack.estimation.kernels import (  # noqa: E402
    cv_cycle,
    cv_position_contributions,
    cv_predicted_position,
    cv_recover,
    fs_cycle,
)
from swarmtrack.estimation.kernels_3d import (  # noqa: E402
    cv3d_cycle,
    cv3d_position_contributions,
    cv3d_predicted_position,
)
from swarmtrack.models import make_model  # noqa: E402

N = 1000
DT = 0.05
SIG = (0.08, 0.02)
MIN_RANGE = 0.05
MIN_SECONDS = 1.0

NUMPY_REFERENCE_POINT = 1.3e6  # the figure for the batched numpy reference (CV)
CV_GOAL = 5.0e6  # the goal for CV
CV_PRACTICAL_LIMIT = 16e6  # the hand-specialised compiled CV kernel
FS_GOAL = 1.0e6  # issue 10's goal for the compiled FS filter (about 0.08 M/s in numpy)
CV3D_GOAL = 5.0e6  # issue 28's goal for the compiled 3-D CV cycle with the range-bearing-elevation update
SIG3 = (0.08, 0.02, 0.02)


def _measurements(rng):
    """A static target per agent seen by its own sensor 1-10 m away (the same z every cycle)."""
    target = rng.uniform(-20.0, 20.0, (N, 2))
    r = rng.uniform(1.0, 10.0, N)
    ang = rng.uniform(-np.pi, np.pi, N)
    sensors = target - np.column_stack([r * np.cos(ang), r * np.sin(ang)])
    z = np.column_stack([r + SIG[0] * rng.standard_normal(N), ang + SIG[1] * rng.standard_normal(N)])
    return sensors, z


def _rate(step, min_seconds=MIN_SECONDS):
    """Agent-updates per second of ``step`` (one cycle of N agents), timed for at least ``min_seconds``."""
    for _ in range(3):  # warm-up (and numba compilation)
        step()
    reps = 0
    t0 = time.perf_counter()
    elapsed = 0.0
    while elapsed < min_seconds:
        for _ in range(10):
            step()
        reps += 10
        elapsed = time.perf_counter() - t0
    return N * reps / elapsed, reps, elapsed


def numpy_reference(model_name, sensors, z):
    model = make_model(model_name, DT)
    upd = RangeBearingUpdate(*SIG, mode="position", min_range=MIN_RANGE)
    state = list(initial_information(model, N))

    def step():
        x, P = recover(*state)
        Yp, yp, xp = predict(model, x, P)
        I, i = upd.contributions(xp[:, :2], sensors, z)
        state[:] = add_position_information(Yp, yp, I, i)

    return step, state


def numba_cv(sensors, z, with_contributions=True):
    model = make_model("cv", DT)
    q = np.ascontiguousarray(np.diag(model.Q))
    Y, y = initial_information(model, N)
    x, P, flags = cv_recover(Y, y)
    assert not flags.any()
    I0, i0 = cv_position_contributions(cv_predicted_position(x, DT), sensors, z, *SIG, MIN_RANGE)

    def step():
        if with_contributions:
            I, i = cv_position_contributions(cv_predicted_position(x, DT), sensors, z, *SIG, MIN_RANGE)
        else:
            I, i = I0, i0
        if cv_cycle(Y, y, x, P, DT, q, I, i).any():
            raise RuntimeError("CV kernel flagged a divergence")

    return step, (Y, y, x, P)


def numba_fs(sensors, z):
    """The compiled FS cycle (kernels.fs_cycle) with its contributions, L24's fake vz = 0 measurement included."""
    model = make_model("fs", DT)
    q = np.ascontiguousarray(np.diag(model.Q))
    Y, y = initial_information(model, N)
    x, P = recover(Y, y)
    w_vz = 1.0 / 0.05**2

    def step():
        I, i = cv_position_contributions(cv_predicted_position(x, DT), sensors, z, *SIG, MIN_RANGE)
        if fs_cycle(x, P, DT, q, I, i, model.mass, model.Ixx, model.Iyy, model.g, w_vz).any():
            raise RuntimeError("FS kernel flagged a divergence")

    return step, (Y, y, x, P)


def _measurements_3d(rng):
    """As :func:`_measurements`, in 3-D: each agent's sensor 1-10 m away at an elevation within ±60°."""
    target = rng.uniform(-20.0, 20.0, (N, 3))
    r = rng.uniform(1.0, 10.0, N)
    beta, eps = rng.uniform(-np.pi, np.pi, N), rng.uniform(-np.pi / 3, np.pi / 3, N)
    sensors = target - np.column_stack([r * np.cos(eps) * np.cos(beta), r * np.cos(eps) * np.sin(beta),
                                        r * np.sin(eps)])
    z = np.column_stack([r, beta, eps]) + np.asarray(SIG3) * rng.standard_normal((N, 3))
    return sensors, z


def numpy_reference_3d(sensors, z):
    model = make_model("cv3d", DT)
    upd = RangeBearingElevationUpdate(*SIG3, mode="position", min_range=MIN_RANGE)
    index = POSITION_3D
    state = list(initial_information(model, N))

    def step():
        x, P = recover(*state)
        Yp, yp, xp = predict(model, x, P)
        I, i = upd.contributions(xp[:, index], sensors, z)
        state[:] = add_position_information(Yp, yp, I, i, index)

    return step, state


def numba_cv3d(sensors, z):
    """The compiled 3-D CV cycle (kernels_3d.cv3d_cycle) with its range-bearing-elevation contributions."""
    model = make_model("cv3d", DT)
    q = np.ascontiguousarray(np.diag(model.Q))
    x, P = recover(*initial_information(model, N))

    def step():
        I, i = cv3d_position_contributions(cv3d_predicted_position(x, DT), sensors, z, *SIG3, MIN_RANGE)
        if cv3d_cycle(x, P, DT, q, I, i).any():
            raise RuntimeError("CV 3-D kernel flagged a divergence")

    return step, (x, P)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", action="store_true", help="print one flat JSON object {name: value} instead")
    parser.add_argument("--quick", action="store_true", help="time each case for 0.2 s instead of 1 s (smoke test)")
    args = parser.parse_args(argv)
    min_seconds = 0.2 if args.quick else MIN_SECONDS

    rng = np.random.default_rng(0)
    sensors, z = _measurements(rng)
    sensors_z_3d = _measurements_3d(rng)
    # (JSON name, table label, step, reference point, practical limit)
    cases = [
        ("cv_cycle_agent_updates_per_s_numpy", "numpy reference, CV (4 states)", numpy_reference("cv", sensors, z)[0],
         NUMPY_REFERENCE_POINT, None),
        ("fs_cycle_agent_updates_per_s_numpy", "numpy reference, FS (12 states)", numpy_reference("fs", sensors, z)[0],
         None, None),
        ("cv_cycle_agent_updates_per_s", "numba CV kernel, full cycle", numba_cv(sensors, z)[0], CV_GOAL,
         CV_PRACTICAL_LIMIT),
        ("cv_kernel_only_agent_updates_per_s", "numba CV kernel, cv_cycle only",
         numba_cv(sensors, z, with_contributions=False)[0], None, None),
        ("fs_cycle_agent_updates_per_s", "numba FS kernel, full cycle", numba_fs(sensors, z)[0], FS_GOAL, None),
        ("cv3d_cycle_agent_updates_per_s_numpy", "numpy reference, CV 3-D (6 states)",
         numpy_reference_3d(*sensors_z_3d)[0], None, None),
        ("cv3d_cycle_agent_updates_per_s", "numba CV 3-D kernel, full cycle", numba_cv3d(*sensors_z_3d)[0],
         CV3D_GOAL, None),
    ]
    results = {}
    rows = []
    for key, name, step, ref, limit in cases:
        rate, reps, elapsed = _rate(step, min_seconds)
        results[key] = rate
        note = ""
        if key in ("fs_cycle_agent_updates_per_s", "cv3d_cycle_agent_updates_per_s"):
            note = f"goal ≥ {ref / 1e6:.0f} M/s ({'MET' if rate >= ref else 'NOT MET'})"
        elif ref is not None and limit is None:
            note = f"issue: ~{ref / 1e6:.1f} M/s"
        elif ref is not None:
            verdict = "MET" if rate >= ref else "NOT MET"
            note = f"goal ≥ {ref / 1e6:.0f} M/s ({verdict}); practical limit ~{limit / 1e6:.0f} M/s"
        rows.append(f"{name:<34} {rate / 1e6:>14.2f} M {1e6 * elapsed / reps:>10.1f} {reps:>7d}   {note}")
    speedup = results["cv_cycle_agent_updates_per_s"] / results["cv_cycle_agent_updates_per_s_numpy"]
    fs_speedup = results["fs_cycle_agent_updates_per_s"] / results["fs_cycle_agent_updates_per_s_numpy"]
    cv3d_speedup = results["cv3d_cycle_agent_updates_per_s"] / results["cv3d_cycle_agent_updates_per_s_numpy"]
    if args.json:
        figures = {k: round(v, 1) for k, v in results.items()}
        print(json.dumps({**figures, "cv_cycle_speedup_over_numpy": round(speedup, 2),
                          "fs_cycle_speedup_over_numpy": round(fs_speedup, 2),
                          "cv3d_cycle_speedup_over_numpy": round(cv3d_speedup, 2)}))
        return
    print(f"Information-filter cycle, N = {N} agents, one core "
          f"(NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}), position-mode range-bearing update")
    header = f"{'case':<34} {'agent-updates/s':>16} {'µs/cycle':>10} {'cycles':>7}   reference point"
    print(header)
    print("-" * (len(header) + 24))
    print("\n".join(rows))
    print(f"\nspeed-up of the numba CV full cycle over the numpy CV reference: {speedup:.1f}x")
    print(f"speed-up of the numba FS full cycle over the numpy FS reference: {fs_speedup:.1f}x")
    print(f"speed-up of the numba CV 3-D full cycle over the numpy CV 3-D reference: {cv3d_speedup:.1f}x")


if __name__ == "__main__":
    main()
