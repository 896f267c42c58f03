"""Speed of IB21's guaranteed search and track (set-membership estimator + SM-MPC), on one core.

Goals (issue 8, "Speed (benchmarks)"): one 400 s ``ib21-fleet-6`` mission (6 fixed-wing UAVs, 3 targets, 3 decoys)
≥ 20x faster than real time (≤ 20 s wall); the Fig. 8 study (5 fleet sizes × 30 runs) ≤ 30 min on 2 cores; the
control time per UAV growing at most linearly with fleet size. Issue 26 holds the polygon sets (the default) to the
same 20 s and adds ``ib21-large`` (10 UAVs, 10 targets, 10 decoys, 400 s) with its guarantee intact (0 violations),
≤ 60 s since issue 41 (issue 26 had asked 40 s): ``--large`` times it too (minutes), beside the same run's
references.

One mission, after a 2 s warm-up run (imports, numba caches), timed with ``time.perf_counter`` around
``simulate``. The split is measured by wrapping the components' methods for the timed run:

* ``estimator``: :class:`SetMembershipEstimator` ``share`` (prediction and correction of the sets), ``fuse``
  (fusion with the neighbours, Φ) and ``view`` (the aggregated set X^A, eq. 43; cached between updates);
* ``mpc``: :class:`SetMembershipMPC` ``command`` (eqs. 44-49 for every UAV in index order);
* ``rest``: the world, sensor, network, truth-side monitor and recorder (wall − the two).

Beside it: the set operations per estimation step (``polygons.OPS``, by kind; the MPC's included), the vertices of
a UAV's sets (the estimator's ``vertices`` probe: mean and maximum over UAVs and steps), the guarantee violations
(must be 0) and the final mean uncertainty Φ̄ (so a speed-up that changes behaviour shows).

References measured in the same run (machines here differ by up to 2x; no other library does this job):

* the other set representation (``--sets both``, the default): ``estimator.sets: polygons`` and ``raster`` on the
  same mission, one after the other;
* ``geos_cycle_ms``: a fixed GEOS workload, the polygon estimator's own kind of cycle on a fixed set (dilate by
  0.5 m, clip to X0, remove a footprint, intersect with a neighbour's copy), per cycle; each mission's wall in these
  cycles compares machines;
* ``mpc_exact_ms`` beside ``mpc_local_ms``: the SM-MPC's full-set reference path (``exact=True``) and the default
  local-window path on the same fleet plans, replayed from ``REPLAYED`` plans recorded during the mission.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_setmembership.py [--json] [--quick] [--duration S]
[--sets polygons|raster|both] [--large]``
(400 s simulated; ``--quick``: 30 s). ``--json`` prints one flat JSON object ``{name: value}`` instead of the table
(``ib21-large``'s entries prefixed ``large_``). Each goal line reads MET / NOT MET, with the same run's references
beside it: the other set representation on the same mission and the wall in GEOS cycles (``geos_cycle_ms``).
"""

from __future__ import annotations

import os

# One core: numba serial kernels, no threaded BLAS. Other environment settings are left as they are.
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
import shapely  # noqa: E402

from swarmtrack.control import sm_mpc  # noqa: E402
from swarmtrack.control.sm_mpc import SetMembershipMPC  # noqa: E402
from swarmtrack.estimation import polygons as pg  # noqa: E402
from swarmtrack.estimation.setmembership import SetMembershipEstimator  # noqa: E402
from swarmtrack.estimation.setmembership_raster import RasterSetMembershipEstimator  # noqa: E402
from swarmtrack.scenarios import load_scenario  # noqa: E402
from swarmtrack.sim.engine import simulate  # noqa: E402

SCENARIO, LARGE = "ib21-fleet-6", "ib21-large"
DURATION, QUICK_DURATION = 400.0, 30.0
GOALS_WALL_S = {SCENARIO: 20.0, LARGE: 60.0}  # the 400 s missions, with the default (polygon) sets (issues 26, 41)
GOAL_ISSUES = {SCENARIO: "issue 26", LARGE: "issue 41"}
GOAL_WALL_S = GOALS_WALL_S[SCENARIO]
TIE_M2 = 1e-6  # eq. 47 costs closer than this are a tie
REPLAYED = 40  # fleet plans recorded for the MPC reference (one every 10 control periods)


@contextlib.contextmanager
def timed(spent: dict[str, float], methods: dict[str, tuple[type, str]]):
    """Accumulate the wall time of each ``(class, method)`` into ``spent[name]`` while the block runs."""
    saved = []
    for name, (cls, attr) in methods.items():
        original = getattr(cls, attr)
        saved.append((cls, attr, original))

        def wrapper(self, *args, _f=original, _name=name, **kwargs):
            t0 = time.perf_counter()
            try:
                return _f(self, *args, **kwargs)
            finally:
                spent[_name] += time.perf_counter() - t0

        setattr(cls, attr, wrapper)
    try:
        yield spent
    finally:
        for cls, attr, original in saved:
            setattr(cls, attr, original)


def mission(duration: float, sets: str = "polygons", scenario: str = SCENARIO) -> dict[str, float]:
    """One mission of ``scenario`` with the sets held as ``sets`` (``estimator.sets``), timed and split."""
    simulate(load_scenario(scenario, ["duration=2", f"estimator.sets={sets}"]))  # warm-up (numba caches; the
    # raster planner loads its own kernels when it is built: sm_mpc_raster.warm)
    scn = load_scenario(scenario, [f"duration={duration:g}", f"estimator.sets={sets}"])
    kind = RasterSetMembershipEstimator if sets == "raster" else SetMembershipEstimator
    methods = {"share": (kind, "share"), "fuse": (kind, "fuse"), "view": (kind, "view"),
               "mpc": (SetMembershipMPC, "command")}
    spent = dict.fromkeys(methods, 0.0)
    pg.OPS.clear()
    recorded: list[tuple] = []  # the fleet plans, for the polygon planner's full-set reference only: kept plans
    # hold their sets alive (with raster sets, gigabytes of early X^A fields that would slow the timed run itself)
    with timed(spent, methods), recording(recorded) if sets == "polygons" else contextlib.nullcontext():
        t0 = time.perf_counter()
        rec = simulate(scn)
        wall = time.perf_counter() - t0
    ops = dict(pg.OPS)
    steps = round(duration * scn.rates.estimation)
    chunks = list(rec.chunks())
    vertices = np.concatenate([c.probes["vertices"] for c in chunks])
    violations = np.concatenate([c.probes["guarantee_violations"] for c in chunks])
    phi = chunks[-1].probes["phi"][-1]
    estimator = spent["share"] + spent["fuse"] + spent["view"]
    out = {"duration_s": duration, "wall_s": wall, "rtf": duration / wall, "estimator_s": estimator,
           "predict_correct_s": spent["share"], "fusion_s": spent["fuse"], "view_s": spent["view"],
           "mpc_s": spent["mpc"], "rest_s": wall - estimator - spent["mpc"],
           "mpc_ms_per_uav_plan": 1e3 * spent["mpc"] / (scn.swarm.n_uavs * duration / 0.5),
           "ops_per_step": sum(ops.values()) / steps, "vertices_mean": float(vertices.mean()),
           "vertices_max": float(vertices.max()), "guarantee_violations": float(violations.sum()),
           "phi_final_mean": float(phi.mean())}
    out.update({f"ops_{k}_per_step": v / steps for k, v in sorted(ops.items())})
    if sets == "polygons":  # the full-set reference exists for the polygon planner
        out.update(mpc_reference(recorded[:: max(1, len(recorded) // REPLAYED)][:REPLAYED]))
    return out


@contextlib.contextmanager
def recording(out: list):
    """Record the arguments of every fleet plan (``sm_mpc.plan_all``, which the controller calls) while the block
    runs."""
    original = sm_mpc.plan_all

    def plan_all(*args, **kwargs):
        out.append((args, kwargs))
        return original(*args, **kwargs)

    sm_mpc.plan_all = plan_all
    try:
        yield out
    finally:
        sm_mpc.plan_all = original


def mpc_reference(plans: list[tuple]) -> dict[str, float]:
    """The recorded fleet plans replayed through the local-window path and the full-set reference (``exact=True``),
    interleaved: ms per UAV and plan of each, and the share of UAVs whose local pick has the exact best cost (to
    ``TIE_M2``: a tie within round-off may be broken the other way, the tolerance of ``choose`` being relative)."""
    local = exact = 0.0
    same = uavs = 0
    for args, kwargs in plans:
        t0 = time.perf_counter()
        a = sm_mpc.plan_all(*args, **kwargs)
        t1 = time.perf_counter()
        b = sm_mpc.plan_all(*args, **{**kwargs, "exact": True})
        exact += time.perf_counter() - t1
        local += t1 - t0
        for ca, cb in zip(a.choices, b.choices, strict=True):  # the local pick costs what the exact best does
            same += int(cb.cost[ca.index] <= cb.cost[cb.index] + TIE_M2)
        uavs += len(a.plans)
    return {"mpc_local_ms": 1e3 * local / max(uavs, 1), "mpc_exact_ms": 1e3 * exact / max(uavs, 1),
            "mpc_same_plans": same / max(uavs, 1)}


def geos_cycle_ms(cycles: int = 200) -> float:
    """The machine's speed on the estimator's kind of work, same run: ms per cycle of dilate (0.5 m), clip to X0,
    remove a footprint and intersect with a neighbour's copy, on a fixed set (X0 minus 40 footprints along a seeded
    path, about 110 vertices). Best of 3."""
    area = shapely.box(0, 0, 400, 400)
    rng = np.random.default_rng(0)
    xy, psi = np.array([60.0, 60.0]), 0.0
    cut = []
    for _ in range(40):
        psi += rng.uniform(-0.4, 0.4)
        xy = np.clip(xy + 8.3 * np.array([np.cos(psi), np.sin(psi)]), 40, 360)
        cut.append(shapely.affinity.rotate(shapely.box(*(xy - 41.4), *(xy + 41.4)), psi, use_radians=True))
    start = shapely.difference(area, shapely.union_all(cut))
    other = shapely.affinity.translate(start, 0.3, -0.2)
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        a = start
        for k in range(cycles):
            a = shapely.buffer(a, 0.5, quad_segs=8)
            a = shapely.intersection(a, area)
            a = shapely.difference(a, cut[k % len(cut)])
            a = shapely.intersection(a, other)
        best = min(best, (time.perf_counter() - t0) / cycles)
    return 1e3 * best


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", action="store_true", help="print one flat JSON object {name: value} instead")
    parser.add_argument("--quick", action="store_true", help=f"a {QUICK_DURATION:g} s mission (smoke test)")
    parser.add_argument("--duration", type=float, default=None, help="simulated seconds (default 400)")
    parser.add_argument("--sets", choices=("polygons", "raster", "both"), default="both",
                        help="estimator.sets to time (default both: each the other's same-run reference)")
    parser.add_argument("--large", action="store_true",
                        help=f"also time {LARGE} (issue 41's goal: ≤ {GOALS_WALL_S[LARGE]:g} s with polygon sets)")
    args = parser.parse_args(argv)
    duration = args.duration or (QUICK_DURATION if args.quick else DURATION)
    kinds = ("polygons", "raster") if args.sets == "both" else (args.sets,)
    scenarios = (SCENARIO, LARGE) if args.large else (SCENARIO,)
    runs = {(scn, k): mission(duration, k, scn) for scn in scenarios for k in kinds}
    cycle = geos_cycle_ms()
    if args.json:
        flat = {"geos_cycle_ms": cycle}
        for (scn, k), r in runs.items():
            prefix = "" if scn == SCENARIO else "large_"
            flat.update({f"{prefix}{k}_{name}": v for name, v in r.items()})
        print(json.dumps({k: round(v, 4 if abs(v) < 100 else 1) for k, v in flat.items()}))
        return
    print(f"IB21, one core, shapely {shapely.__version__} / GEOS {shapely.geos_version_string}")
    for scn in scenarios:
        print(f"\n== {scn} ==")
        for k in kinds:
            report(k, runs[(scn, k)], duration, cycle)
    if duration == DURATION:
        print()
        for scn in scenarios:
            goal(scn, runs, cycle)


def goal(scenario: str, runs: dict, cycle: float) -> None:
    """The goal line for ``scenario`` (its 400 s mission with polygon sets; issue 26's goal, ``ib21-large``'s issue
    41's), with the same run's references: the raster sets' wall on the same mission (if timed) and the wall in GEOS
    cycles."""
    limit = GOALS_WALL_S[scenario]
    r = runs.get((scenario, "polygons"))
    if r is None:
        return
    refs = [f"{r['wall_s'] / (cycle / 1e3):,.0f} GEOS cycles of {cycle:.3f} ms"]
    if (scenario, "raster") in runs:
        refs.insert(0, f"raster sets {runs[(scenario, 'raster')]['wall_s']:.1f} s")
    guarantee = "" if r["guarantee_violations"] == 0 else f", {r['guarantee_violations']:.0f} guarantee violations"
    met = r["wall_s"] <= limit and r["guarantee_violations"] == 0
    print(f"Goal ({GOAL_ISSUES[scenario]}): {scenario} 400 s with polygon sets ≤ {limit:.0f} s wall: "
          f"{r['wall_s']:.1f} s ({'MET' if met else 'NOT MET'}{guarantee}; same run: {', '.join(refs)})")


def report(sets: str, r: dict[str, float], duration: float, cycle: float) -> None:
    print(f"\nestimator.sets={sets}: {r['duration_s']:.0f} s simulated in {r['wall_s']:.2f} s wall: "
          f"{r['rtf']:.1f}x real time ({r['wall_s'] / (cycle / 1e3):,.0f} GEOS cycles of {cycle:.3f} ms, a fixed "
          f"dilate-clip-remove-intersect measured in the same run)")
    header = f"{'part':<34} {'s':>8} {'share':>7}"
    print(header)
    print("-" * len(header))
    for name, key in (("estimator: predict + correct", "predict_correct_s"), ("estimator: fusion + Φ", "fusion_s"),
                      ("estimator: view (X^A)", "view_s"), ("SM-MPC (all UAVs)", "mpc_s"),
                      ("rest (world, sensor, monitor, ...)", "rest_s")):
        print(f"{name:<34} {r[key]:>8.2f} {100 * r[key] / r['wall_s']:>6.1f}%")
    print(f"   SM-MPC per UAV and plan: {r['mpc_ms_per_uav_plan']:.2f} ms")
    if "mpc_local_ms" in r:
        print(f"   SM-MPC on {REPLAYED} replayed fleet plans, ms per UAV and plan: local window "
              f"{r['mpc_local_ms']:.2f}, full-set reference {r['mpc_exact_ms']:.2f} "
              f"({r['mpc_exact_ms'] / r['mpc_local_ms']:.1f}x); the local pick has the exact best cost (to "
              f"{TIE_M2:g} m²) for {100 * r['mpc_same_plans']:.1f} % of UAVs")
    if sets == "polygons":
        kinds = ", ".join(f"{k[4:-9]} {v:.2f}" for k, v in r.items() if k.startswith("ops_") and k != "ops_per_step")
        print(f"set operations per estimation step: {r['ops_per_step']:.1f} ({kinds})")
        print(f"vertices per UAV (all its sets): mean {r['vertices_mean']:.0f}, max {r['vertices_max']:.0f}")
    else:
        print(f"cells stored per UAV (all its sets): mean {r['vertices_mean']:.0f}, max {r['vertices_max']:.0f}")
    print(f"guarantee violations: {r['guarantee_violations']:.0f}; final mean Φ: {r['phi_final_mean']:.0f} m²")


if __name__ == "__main__":
    main()
