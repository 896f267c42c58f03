"""Speed of W20 Ch. 5's distributed MPC (``swarmtrack.control.mpc``), on one core.

Goals (the issue's speed section): the median wall time of one MPC solve per UAV, Python overhead included,
≤ 100 µs at h = 5 and its 99th percentile ≤ 1 ms; ``w20-mpc-formation`` ≥ 100x real time; one MPC step of
1,000 UAVs in formation ≤ 100 ms. The issue measured OSQP alone on a 2-axis double integrator, warm-started:
about 20 µs solver time (40 µs wall) at h = 5 and 70-90 µs at h = 20.

1. **One solve per UAV**, at h = 5 and h = 20, on the project's identified quadrotor (``swarmtrack-quadrotor``,
   T = 0.2 s), default weights. An :class:`MPCController` plans ``PLANS`` times in a row; its "vehicles" are the
   identified model itself driven by the applied setpoint (plus 2 cm of position noise per period), its target
   flies a Lissajous-like path whose velocity keeps turning and its view names the model the W20 scenario would
   (cv, ca, ct in turn, 20 s each, with ``[ax, ay, ω]`` from the path), so every warm start is a realistic one.
   Case ``free``: one UAV, no neighbour. Case ``collision``: two UAVs whose formation places are 2 m apart
   (r_s = 5 m), so a separation term is active (``w = Q + Q_s``, the side-step point in r̄) in most plans; only
   plans where it is active are counted. Figures per UAV solve, median and 99th percentile:

   * ``plan``: wall time of ``plan()`` divided by the number of UAVs (all of the controller's Python: target
     propagation, free responses, separation terms, the solve loop);
   * ``solve``: the controller's own timer around ``FormationQP.solve`` (its ``solve_time`` probe: q, the OSQP
     update and solve, the result), the issue's "one MPC solve per UAV";
   * references, same run, the same sequence of problems replayed (recorded from an identical second run):
     ``osqp``: a bare OSQP problem set up like :class:`FormationQP`, timed around ``update(q) + solve()`` only
     (q precomputed; P's values also updated where w changed), and ``osqp_internal``: OSQP's own
     ``info.solve_time`` of those solves (no Python). ``formationqp``: the same solves through a fresh
     :class:`FormationQP` in a tight loop. The gap between ``formationqp`` and ``osqp`` is FormationQP's own
     Python (q, the call); ``solve`` is slower than ``formationqp`` on the very same problems because inside
     ``plan()`` each solve follows the rest of the plan's numpy work (cold caches: on the development machine
     one ``propagate_target`` call between replayed solves moves their median from 27 to 39 µs at h = 5).

2. **Real-time factor of** ``w20-mpc-formation`` (100 s simulated, 3 UAVs; the MPC plans from t = 20 s):
   simulated s / wall s of ``simulate``, the fastest of ``REPEATS`` runs (the least disturbed by other jobs on
   the machine) after a warm-up run (numba caches loaded).
   Beside it, the share of that wall time spent in ``MPCController.plan`` (timed by wrapping the method) and in
   the solves (the ``solve_time`` probe), and the factor the rest of the simulation alone would reach.

3. **One MPC step of N UAVs in formation**: one ``plan()`` call for a 40 × 25 grid of formation places 10 m apart
   around a moving target (N = 1,000), each UAV within ~0.5 m of its place, 12 UAVs displaced 7 m toward a
   neighbour's place so some separation terms are active, proximity links with r_comm = 30 m (CSR from 300 UAVs
   up, as the simulator builds them; built outside the timing), the UAVs then moved by the identified model
   between steps. Median over ``STEPS`` steps after 2 warm-up steps. References in the same run: N = 10 (5 × 2)
   and N = 100 (10 × 10), per UAV, to show the growth is linear. The controller's set-up (one OSQP problem per
   UAV) is reported too.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_mpc.py [--json] [--quick]`` (about 1 min; ``--quick``
about 5 s: fewer plans, one short scenario run, fewer steps). ``--json`` prints one flat JSON object
``{name: value}`` instead of the table (times in µs or ms as the key says).
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
import osqp  # noqa: E402
import scipy.sparse as sp  # noqa: E402

from swarmtrack.control.identification import NAMED_MODELS  # noqa: E402
from swarmtrack.control.mpc import FormationQP, MPCController, MPCSettings  # noqa: E402
from swarmtrack.estimation.base import TargetView  # noqa: E402
from swarmtrack.network.links import proximity_links  # noqa: E402
from swarmtrack.network.messages import Inbox  # noqa: E402
from swarmtrack.scenarios import load_scenario  # noqa: E402
from swarmtrack.sim.engine import simulate  # noqa: E402

MODEL = NAMED_MODELS["swarmtrack-quadrotor"]
HORIZONS = (5, 20)
PLANS = 5000  # plans per case (1,000 s of flight at T = 0.2 s)
REPEATS = 3  # timed w20-mpc-formation runs
STEPS = 20  # timed steps of the formation
R_COMM = 30.0
NAV_NOISE = 0.02  # m, position noise per period on the "vehicle"

GOAL_MEDIAN_US = 100.0  # h = 5, one solve per UAV
GOAL_P99_US = 1000.0
GOAL_RTF = 100.0
GOAL_STEP_MS = 100.0  # 1,000 UAVs


# --- the world the controller sees --------------------------------------------------------------------------
def phase_model(t: float) -> str:
    """The model the target's estimate follows at ``t``: cv, ca, ct in turn, 20 s each."""
    return ("cv", "ca", "ct")[int(t // 20.0) % 3]


def target_view(t: float, n: int) -> TargetView:
    """The target on a path whose velocity keeps turning, seen alike by all ``n`` UAVs: ``[x, y, vx, vy]``, the
    model the W20 scenario's estimate would follow in this 20 s phase (cv, ca, ct in turn) and ``[ax, ay, ω]``."""
    x = 12.0 * np.sin(0.1 * t) + 0.3 * t
    y = 8.0 * np.sin(0.17 * t)
    vx, vy = 1.2 * np.cos(0.1 * t) + 0.3, 1.36 * np.cos(0.17 * t)
    ax, ay = -0.12 * np.sin(0.1 * t), -0.2312 * np.sin(0.17 * t)
    omega = (vx * ay - vy * ax) / max(vx * vx + vy * vy, 1e-6)
    model = phase_model(t)
    return TargetView(np.tile([x, y, vx, vy], (n, 1)), np.full(n, model, dtype=object),
                      np.tile([ax, ay, omega], (n, 1)))


def inbox(nav: np.ndarray) -> Inbox:
    return Inbox(proximity_links(nav[:, :2], R_COMM), {"nav": nav})


def fly(nav: np.ndarray, setpoint: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The "vehicles": one period of the identified model driven by the applied setpoints, plus position noise."""
    out = nav @ MODEL.A.T + setpoint @ MODEL.B.T
    out[:, :2] += rng.normal(0.0, NAV_NOISE, (len(nav), 2))
    return out


def settings(h: int) -> MPCSettings:
    return MPCSettings(horizon=h, period=MODEL.T)


# --- 1. one solve per UAV ----------------------------------------------------------------------------------
def drive(h: int, offsets: np.ndarray, plans: int, record: bool = False):
    """Plan ``plans`` times in a row; per plan its wall time, each UAV's solve time (the controller's probe) and
    whether a separation term was active for it. With ``record``, the solves' arguments instead (untimed)."""
    ctl = MPCController(MODEL.A, MODEL.B, offsets, settings(h))
    n = len(offsets)
    rng = np.random.default_rng(1)
    view0 = target_view(0.0, n)
    nav = np.concatenate([view0.state[:, :2] + offsets, view0.state[:, 2:]], axis=1)
    ctl.setpoint = nav[:, :2].copy()
    calls = [[] for _ in range(n)]
    if record:
        for i, qp in enumerate(ctl.qps):
            def logged(f, r_bar, w, _solve=qp.solve, _log=calls[i]):
                _log.append((f.copy(), r_bar.copy(), w))
                return _solve(f, r_bar, w)
            qp.solve = logged
    plan_s = np.empty(plans)
    solve_s = np.empty((plans, n))
    active = np.empty((plans, n), dtype=bool)
    for k in range(plans):
        view, box = target_view(k * MODEL.T, n), inbox(nav)
        before = ctl.solve_time.copy()
        t0 = time.perf_counter()
        ctl.plan(nav, view, box)
        plan_s[k] = time.perf_counter() - t0
        solve_s[k] = ctl.solve_time - before
        active[k] = ctl.avoiding > 0
        nav = fly(nav, ctl.setpoint, rng)
    if ctl.fallbacks.any():
        raise RuntimeError(f"{int(ctl.fallbacks.sum())} solves fell back")
    return (calls, ctl.cond.G) if record else (plan_s / n, solve_s, active, ctl.iterations.sum() / ctl.solves.sum())


def replay(G: np.ndarray, calls: list, s: MPCSettings):
    """The recorded solves of one UAV again: through a fresh FormationQP, and on a bare OSQP problem (update q,
    and P's values where w changed, + solve). Seconds per solve for both, and OSQP's own solve times."""
    qp = FormationQP(G, s)
    formation = np.empty(len(calls))
    for k, (f, r_bar, w) in enumerate(calls):
        t0 = time.perf_counter()
        qp.solve(f, r_bar, w)
        formation[k] = time.perf_counter() - t0

    n = G.shape[1]
    GtG = G.T @ G

    def hessian(w):
        return sp.csc_matrix(np.triu(2.0 * (w * GtG + s.R * np.eye(n))))

    w0 = s.Q
    solver = osqp.OSQP()
    solver.setup(hessian(w0), np.zeros(n), sp.identity(n, format="csc"), np.full(n, -s.bound), np.full(n, s.bound),
                 verbose=False, eps_abs=s.eps, eps_rel=s.eps, max_iter=s.max_iter, polishing=False,
                 warm_starting=True)
    qs = [2.0 * w * (G.T @ (f - r_bar)) for f, r_bar, w in calls]
    bare, internal = np.empty(len(calls)), np.empty(len(calls))
    for k, (q, (_, _, w)) in enumerate(zip(qs, calls, strict=True)):
        Px = hessian(w).data if w != w0 else None
        t0 = time.perf_counter()
        if Px is not None:
            solver.update(Px=Px)
            w0 = w
        solver.update(q=q)
        res = solver.solve(raise_error=False)
        bare[k] = time.perf_counter() - t0
        internal[k] = res.info.solve_time
    return formation, bare, internal


def per_uav_case(h: int, case: str, plans: int) -> dict[str, float]:
    offsets = np.array([[0.0, 0.0]]) if case == "free" else np.array([[-1.0, 0.0], [1.0, 0.0]])
    plan_per_uav, solve_s, active, iters = drive(h, offsets, plans)
    calls, G = drive(h, offsets, plans, record=True)
    ref = [replay(G, c, settings(h)) for c in calls]
    formation, bare, internal = (np.concatenate([r[j] for r in ref]) for j in range(3))
    warm = slice(1, None)  # the first (cold) solve of each UAV is left out
    if case == "collision":
        keep_plans = active.all(axis=1)
        keep_plans[0] = False
        plan_sample, solve_sample = plan_per_uav[keep_plans], solve_s[keep_plans].ravel()
        keep_solves = np.concatenate([active[:, i] & (np.arange(plans) > 0) for i in range(len(offsets))])
        formation, bare, internal = formation[keep_solves], bare[keep_solves], internal[keep_solves]
    else:
        plan_sample, solve_sample = plan_per_uav[warm], solve_s[warm].ravel()
        formation, bare, internal = formation[warm], bare[warm], internal[warm]
    out = {"active_share": float(active.mean()), "mean_iterations": float(iters), "solves": int(solve_sample.size)}
    if case == "free":  # the fixed cost of a plan depends on the model propagating the target (ct the dearest)
        models = np.array([phase_model(k * MODEL.T) for k in range(plans)])
        for m in ("cv", "ca", "ct"):
            out[f"plan_{m}_median_us"] = 1e6 * float(np.median(plan_per_uav[warm][models[warm] == m]))
    for name, x in (("plan", plan_sample), ("solve", solve_sample), ("formationqp", formation), ("osqp", bare),
                    ("osqp_internal", internal)):
        out[f"{name}_median_us"] = 1e6 * float(np.median(x))
        out[f"{name}_p99_us"] = 1e6 * float(np.percentile(x, 99))
    return out


# --- 2. real-time factor of w20-mpc-formation --------------------------------------------------------------
def scenario_rtf(quick: bool) -> dict[str, float]:
    overrides = ["duration=30"] if quick else []
    simulate(load_scenario("w20-mpc-formation", ["duration=22"]))  # warm-up: numba caches and the MPC path
    spent = [0.0]
    plan = MPCController.plan

    def timed_plan(self, *args):
        t0 = time.perf_counter()
        plan(self, *args)
        spent[0] += time.perf_counter() - t0

    runs = []
    MPCController.plan = timed_plan
    try:
        for _ in range(1 if quick else REPEATS):
            scn = load_scenario("w20-mpc-formation", overrides)
            spent[0] = 0.0
            t0 = time.perf_counter()
            rec = simulate(scn)
            wall = time.perf_counter() - t0
            last = list(rec.chunks())[-1].probes
            runs.append((wall, spent[0], float(last["solve_time"][-1].sum()), float(last["solves"][-1].sum()),
                         scn.duration))
    finally:
        MPCController.plan = plan
    wall, plan_s, solve_s, solves, duration = min(runs)  # the fastest run
    return {"duration_s": duration, "wall_s": wall, "rtf": duration / wall, "plan_share": plan_s / wall,
            "solve_share": solve_s / wall, "rtf_without_plans": duration / (wall - plan_s), "plans_per_uav":
            solves / 3, "plan_ms": 1e3 * plan_s / max(solves / 3, 1)}


# --- 3. one MPC step of N UAVs in formation ----------------------------------------------------------------
def formation_step(cols: int, rows: int, steps: int) -> dict[str, float]:
    n = cols * rows
    gx, gy = np.meshgrid(10.0 * (np.arange(cols) - (cols - 1) / 2), 10.0 * (np.arange(rows) - (rows - 1) / 2))
    offsets = np.stack([gx.ravel(), gy.ravel()], axis=1)
    rng = np.random.default_rng(2)
    t0 = time.perf_counter()
    ctl = MPCController(MODEL.A, MODEL.B, offsets, settings(5))
    setup_s = time.perf_counter() - t0
    view = target_view(0.0, n)
    nav = np.concatenate([view.state[:, :2] + offsets + rng.normal(0.0, 0.5, (n, 2)), view.state[:, 2:]], axis=1)
    movers = rng.choice(np.flatnonzero(np.arange(n) % cols < cols - 1), size=min(12, n // 4), replace=False)
    nav[movers, 0] += 7.0  # toward the right neighbour's place: 3 m from it, inside r_s
    ctl.setpoint = nav[:, :2].copy()
    times, active = [], []
    for k in range(steps + 2):
        view, box = target_view(k * MODEL.T, n), inbox(nav)
        t0 = time.perf_counter()
        ctl.plan(nav, view, box)
        if k >= 2:
            times.append(time.perf_counter() - t0)
            active.append(int((ctl.avoiding > 0).sum()))
        nav = fly(nav, ctl.setpoint, rng)
    step = float(np.median(times))
    return {"n": n, "step_ms": 1e3 * step, "per_uav_us": 1e6 * step / n, "setup_ms": 1e3 * setup_s,
            "active_uavs": float(np.mean(active)), "links_per_uav": box.links.sum() / n}


def _verdict(ok: bool) -> str:
    return "MET" if ok else "NOT MET"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", action="store_true", help="print one flat JSON object {name: value} instead")
    parser.add_argument("--quick", action="store_true", help="fewer plans and steps, one short run (smoke test)")
    args = parser.parse_args(argv)
    plans = 300 if args.quick else PLANS
    steps = 5 if args.quick else STEPS

    per_uav = {(h, case): per_uav_case(h, case, plans) for h in HORIZONS for case in ("free", "collision")}
    rtf = scenario_rtf(args.quick)
    grids = {10: (5, 2), 100: (10, 10), 1000: (40, 25)}
    big = {n: formation_step(c, r, steps if n == 1000 else 3 * steps) for n, (c, r) in grids.items()}

    results: dict[str, float] = {}
    for (h, case), r in per_uav.items():
        results.update({f"solve_h{h}_{case}_{k}": v for k, v in r.items()})
    results.update({f"w20_mpc_formation_{k}": v for k, v in rtf.items()})
    for n, r in big.items():
        results.update({f"formation_n{n}_{k}": v for k, v in r.items() if k != "n"})
    if args.json:
        print(json.dumps({k: round(v, 4 if abs(v) < 100 else 1) for k, v in results.items()}))
        return

    print(f"W20 distributed MPC, one core (OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}), "
          f"osqp {osqp.__version__}, model swarmtrack-quadrotor (T = {MODEL.T} s)")
    print(f"\n1. One solve per UAV, {plans} plans per case (µs, median / p99; warm-started)")
    header = (f"{'h':>3} {'case':<10} {'plan()/UAV':>15} {'solve (probe)':>15} {'FormationQP':>15} "
              f"{'bare OSQP':>15} {'OSQP internal':>15} {'iter':>5} {'active':>7}")
    print(header)
    print("-" * len(header))
    for (h, case), r in per_uav.items():
        cells = " ".join(f"{r[f'{k}_median_us']:>7.1f} /{r[f'{k}_p99_us']:>6.0f}"
                         for k in ("plan", "solve", "formationqp", "osqp", "osqp_internal"))
        print(f"{h:>3} {case:<10} {cells} {r['mean_iterations']:>5.1f} {100 * r['active_share']:>6.0f}%")
    print("   plan()/UAV: plan() wall / UAVs; solve: the controller's timer around FormationQP.solve; FormationQP:")
    print("   the same solves replayed; bare OSQP: update(q) + solve() of the same problems (the reference);")
    print("   OSQP internal: OSQP's info.solve_time; active: share of UAV plans with a separation term")
    print("   (collision rows: only plans where it was active). The issue: OSQP ~20 µs solver (40 µs wall) at "
          "h = 5, 70-90 µs at h = 20.")
    for (h, case), r in per_uav.items():
        if case == "free":
            print(f"   h = {h:>2}, free: plan()/UAV median by the model propagating the target: " + ", ".join(
                f"{m} {r[f'plan_{m}_median_us']:.1f} µs" for m in ("cv", "ca", "ct")))

    print(f"\n2. w20-mpc-formation ({rtf['duration_s']:.0f} s simulated, 3 UAVs, fastest of "
          f"{1 if args.quick else REPEATS} runs): {rtf['rtf']:.1f}x real time ({rtf['wall_s']:.2f} s wall)")
    print(f"   MPCController.plan: {100 * rtf['plan_share']:.1f} % of the wall time ({rtf['plan_ms']:.2f} ms per "
          f"plan of 3 UAVs, {rtf['plans_per_uav']:.0f} plans), of which the solves {100 * rtf['solve_share']:.1f} %;")
    print(f"   the rest of the simulation alone (estimator, world, network, recorder): "
          f"{rtf['rtf_without_plans']:.1f}x real time")

    print(f"\n3. One MPC step (plan() for every UAV) in formation, h = 5, r_comm = {R_COMM:g} m, median of steps")
    header = f"{'N':>6} {'step, ms':>10} {'µs per UAV':>11} {'active UAVs':>12} {'links/UAV':>10} {'set-up, ms':>11}"
    print(header)
    print("-" * len(header))
    for n, r in big.items():
        print(f"{n:>6} {r['step_ms']:>10.2f} {r['per_uav_us']:>11.1f} {r['active_uavs']:>12.1f} "
              f"{r['links_per_uav']:>10.1f} {r['setup_ms']:>11.1f}")

    h5 = per_uav[(5, "free")], per_uav[(5, "collision")]
    print("\nGoals")
    for case, r in zip(("free", "collision"), h5, strict=True):
        for k, label in (("solve", "one solve per UAV"), ("plan", "plan() per UAV")):
            med, p99 = r[f"{k}_median_us"], r[f"{k}_p99_us"]
            print(f"  h = 5, {case:<9} {label:<18} median {med:7.1f} µs (≤ {GOAL_MEDIAN_US:.0f}: "
                  f"{_verdict(med <= GOAL_MEDIAN_US)}), p99 {p99:7.1f} µs (≤ {GOAL_P99_US:.0f}: "
                  f"{_verdict(p99 <= GOAL_P99_US)})")
    print(f"  w20-mpc-formation {rtf['rtf']:.1f}x real time (≥ {GOAL_RTF:.0f}x: {_verdict(rtf['rtf'] >= GOAL_RTF)})")
    step = big[1000]["step_ms"]
    print(f"  1,000-UAV MPC step {step:.1f} ms (≤ {GOAL_STEP_MS:.0f} ms: {_verdict(step <= GOAL_STEP_MS)})")


if __name__ == "__main__":
    main()
