"""IB21 (Ibenthal et al., Automatica 2021): guaranteed search and track of targets among decoys, Sec. 6 and Figs. 8-11.

The paper's results are curves over 30 runs of 400 s; its statements are qualitative (who clears the unexplored set,
what slows the decrease of the uncertainty Φ̄). Each claim below is one statement with the paper's wording, checked on
the runs' ``set_membership`` metrics (:mod:`swarmtrack.analysis.metrics`): whether X̄ was cleared, the time-mean of
Φ̄ and of its parts (from the runs' series), guarantee violations and empty-set alarms, the MPC's solve time. The
mismatch values of Fig. 10 and the ranges of Fig. 11 are ours (the legends are lost; docs/set-membership.md).
Four statements are read on the curves themselves (:func:`band`: the mean and std over the runs per time bin):
the variance of Φ̄ largest for 4 UAVs (Fig. 8 left), φ(Xᵁ) growing faster than φ(X) at first (Fig. 8 right), the
±20 m curve above the ±5 m one for t ⩾ 100 s (Fig. 10), and Fig. 11 right's control time (its own set-up,
:data:`COMPUTE`: 1-3 UAVs, 3 targets, no decoys) almost constant over time, with 2 and 3 UAVs at about 3× and 5×
one UAV's. The readings that make "about", "initial" and "almost constant" checkable are ours and stated with each
constant below. A full study is 19 settings × 30 runs of 400 s: use ``--runs`` and ``--set duration=…`` for a
shorter one.

The figures (:data:`FIGURES`) are Figs. 8-11 drawn from the same runs: per setting the mean line and ±1 std band over
the runs of each run's ``series`` (Φ̄, its parts, the fleet's solve time per plan), the std of Φ̄ over the runs on
its own (Fig. 8 left's statement), and each UAV's control time in decision order (Fig. 11 right).
``reproduce ib21 --figure 8`` runs only the experiments one figure needs (:data:`FIGURE_GROUPS`) and checks only the
claims on them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from swarmtrack.analysis.papers.base import Claim, Paper, converged, mean_std_ci
from swarmtrack.analysis.report import markdown_table
from swarmtrack.analysis.statistics import binned_band

FLEET = {f"ib21-fleet-{n}": n for n in (2, 3, 4, 5, 6)}  # Fig. 8: 3 targets, 3 decoys, 1 m/s
SPEED = {"ib21-speed-1.6": 1.6, "ib21-speed-1.8": 1.8}  # Fig. 9 left: 6 UAVs
DECOYS = {"ib21-decoys-0": 0, "ib21-fleet-4": 3, "ib21-decoys-6": 6}  # Fig. 9 right: 4 UAVs
NOISE = {"ib21-noise-5": "±5 / ±5", "ib21-noise-20": "±20 / ±20", "ib21-noise-over": "±5 / ±20",
         "ib21-noise-under": "±20 / ±5"}  # Fig. 10: 5 UAVs, no decoys; true / assumed bound (m)
COMM = {"ib21-comm-50": 50, "ib21-comm-100": 100, "ib21-fleet-6": 200, "ib21-comm-600": 600}  # Fig. 11 left
COMPUTE = {f"ib21-compute-{n}": n for n in (1, 2, 3)}  # Fig. 11 right: 1-3 UAVs, 3 targets, no decoys, 1 m/s
EXPERIMENTS = tuple(dict.fromkeys([*FLEET, *SPEED, *DECOYS, *NOISE, *COMM, *COMPUTE]))
#: The runs whose true noise bound lies inside the assumed one: the guarantee must hold in every one.
MATCHED = tuple(e for e in EXPERIMENTS if e != "ib21-noise-under")
#: IB21 Fig. 11 right: 2 and 3 UAVs take about 3 and 5 times one UAV's control time.
PAPER_TIME_RATIOS = {2: 3.0, 3: 5.0}
#: The same ratios if the fleet's time grew linearly (each UAV's time independent of the others'). "About 3× and 5×"
#: is read as: nearer the paper's ratio than the linear one, on either side (2.5-3.5 and 4-6; ours).
LINEAR_TIME_RATIOS = {2: 2.0, 3: 3.0}
#: IB21 Fig. 8 right's "initial growth" of φ(Xᵁ) and φ(X): the first tenth of a run (40 s of 400 s; ours), over which
#: both parts start from ∅ (IB21 Sec. 6: initially L = X = Xᵁ = ∅), so the part that grows faster lies above.
INITIAL_FRACTION = 0.1
#: IB21 Fig. 10: "when t ⩾ 100 s" (bins that start at or after it).
LATE_T = 100.0
#: IB21 Fig. 11 right's "almost constant with time": the mean fleet time per plan of each quarter of the mission
#: within ±25 % of the mission's mean (ours).
QUARTERS, CONSTANT_TOLERANCE = 4, 0.25


#: The experiments each claim of :func:`analyse` reads (the guarantee: whichever ran, so always kept).
CLAIM_NEEDS = {"ib21-fig8-three-or-fewer": ("ib21-fleet-2", "ib21-fleet-3"), "ib21-fig8-four-some": ("ib21-fleet-4",),
               "ib21-fig8-five-or-more": ("ib21-fleet-5", "ib21-fleet-6"), "ib21-fig9-speed": tuple(SPEED),
               "ib21-fig9-decoys": tuple(DECOYS), "ib21-fig10-over-slowest": tuple(NOISE),
               "ib21-fig10-under-lost": ("ib21-noise-under",), "ib21-guarantee": (), "ib21-fig11-range": tuple(COMM),
               "ib21-fig11-compute": tuple(FLEET),
               "ib21-fig8-variance-four": tuple(FLEET), "ib21-fig8-unidentified-first": tuple(FLEET),
               "ib21-fig10-twenty-above-five": ("ib21-noise-5", "ib21-noise-20"),
               "ib21-fig11-right-constant": tuple(COMPUTE), "ib21-fig11-right-ratios": tuple(COMPUTE)}


def _sm(runs: list[dict]) -> list[dict]:
    return [r["set_membership"] for r in converged(runs) if "set_membership" in r]


def cleared(runs: list[dict]) -> tuple[int, int]:
    """(runs whose unexplored set was cleared, runs)."""
    sm = _sm(runs)
    return sum(s["time_unexplored_cleared"] is not None for s in sm), len(sm)


def time_mean(runs: list[dict], name: str) -> float | None:
    """The mean over runs of each run's time-mean of the series ``name`` (``phi_bar`` or a part)."""
    values = []
    for r in converged(runs):
        series = [v for v in r.get("series", {}).get(name, []) if v is not None]
        if series:
            values.append(float(np.mean(series)))
    return float(np.mean(values)) if values else None


def _fraction(ok: int, n: int) -> str:
    return f"{ok}/{n}"


def _values(series: dict, name: str) -> np.ndarray | None:
    """One run's series ``name`` as floats (an empty bin: NaN); None if the run has none."""
    v = series.get(name)
    if not v:
        return None
    return np.array([np.nan if x is None else x for x in v], dtype=float)


def band(runs: list[dict], name: str) -> dict | None:
    """IB21's line and shaded area: per time bin the mean and std over the finished runs of their series ``name``
    (:func:`~swarmtrack.analysis.statistics.binned_band`: arrays ``t``, ``mean``, ``std``, ``n``, and ``bin_s``,
    ``runs``). None: no run has the series."""
    have = [r["series"] for r in converged(runs) if _values(r.get("series") or {}, name) is not None]
    return binned_band([s[name] for s in have], [s["bin_s"] for s in have])


def spread(runs: list[dict]) -> dict | None:
    """IB21 Fig. 8 left's shaded area, summed up: the time-mean and the largest of the std over the runs of Φ̄_k
    (:func:`band`, bins with at least 2 runs), and the std over the runs of each run's time-mean Φ̄. None: fewer
    than 2 finished runs."""
    b = band(runs, "phi_bar")
    ok = None if b is None else b["n"] >= 2
    if ok is None or not ok.any():
        return None
    means = [float(np.nanmean(v)) for r in converged(runs) if (v := _values(r.get("series") or {}, "phi_bar"))
             is not None]
    return {"band_std_time_mean": float(np.mean(b["std"][ok])), "band_std_max": float(np.max(b["std"][ok])),
            "std_of_time_means": float(np.std(means)), "runs": b["runs"]}


def _initial_mean(series: dict, name: str, fraction: float = INITIAL_FRACTION) -> float | None:
    """The mean of one run's series ``name`` over its first ``fraction`` of the run (whole bins)."""
    v = _values(series, name)
    if v is None:
        return None
    k = max(1, int(np.floor(fraction * len(v) + 1e-9)))  # whole bins: 10 of a 400 s run's 100 bins of 4 s
    window = v[:k]
    return float(np.nanmean(window)) if np.isfinite(window).any() else None


def initial_growth(runs: list[dict]) -> dict | None:
    """IB21 Fig. 8 right's initial growth of φ(Xᵁ) against φ(X): each part's mean over the first
    :data:`INITIAL_FRACTION` of a run (both start from ∅, so the faster-growing part lies above), the mean over the
    runs of each, and the runs in which φ(Xᵁ)'s exceeds φ(X)'s. None: no run has both parts."""
    pairs = []
    for r in converged(runs):
        s = r.get("series") or {}
        u, x = _initial_mean(s, "phi_unidentified"), _initial_mean(s, "phi_identified")
        if u is not None and x is not None:
            pairs.append((u, x))
    if not pairs:
        return None
    u, x = np.array(pairs).T
    return {"unidentified": float(u.mean()), "identified": float(x.mean()), "faster_runs": int((u > x).sum()),
            "runs": len(pairs)}


def _late(b: dict, t0: float = LATE_T) -> np.ndarray:
    """The bins of a :func:`band` (or a run's series) that start at or after ``t0``."""
    return b["t"] - b["bin_s"] / 2 >= t0 - 1e-9


def above_after(high: list[dict], low: list[dict], t0: float = LATE_T) -> dict | None:
    """IB21 Fig. 10: whether the mean curve of Φ̄ over the runs ``high`` lies above that of ``low`` at t ⩾ ``t0``:
    the bins (with data in both) where it does, their number, each curve's mean over them, and the seeds (runs
    paired in order) whose own Φ̄ averaged over t ⩾ ``t0`` is higher in ``high``. None: no common late bin."""
    bh, bl = band(high, "phi_bar"), band(low, "phi_bar")
    if bh is None or bl is None or bh["bin_s"] != bl["bin_s"]:
        return None
    m = min(len(bh["t"]), len(bl["t"]))
    h, lo = bh["mean"][:m], bl["mean"][:m]
    sel = _late({"t": bh["t"][:m], "bin_s": bh["bin_s"]}, t0) & np.isfinite(h) & np.isfinite(lo)
    if not sel.any():
        return None
    seeds = 0
    paired = 0
    for rh, rl in zip(high, low, strict=False):
        if "diverged" in rh or "diverged" in rl:
            continue
        vh, vl = _values(rh.get("series") or {}, "phi_bar"), _values(rl.get("series") or {}, "phi_bar")
        if vh is None or vl is None:
            continue
        k = min(len(vh), len(vl))
        late = _late({"t": (np.arange(k) + 0.5) * bh["bin_s"], "bin_s": bh["bin_s"]}, t0)
        if late.any():
            paired += 1
            seeds += int(np.nanmean(vh[:k][late]) > np.nanmean(vl[:k][late]))
    return {"bins_above": int((h[sel] > lo[sel]).sum()), "bins": int(sel.sum()), "high": float(h[sel].mean()),
            "low": float(lo[sel].mean()), "seeds_above": seeds, "seeds": paired}


def quarters(runs: list[dict], name: str = "solve_time", parts: int = QUARTERS) -> list[float] | None:
    """The mean over each of ``parts`` equal spans of the mission of the runs' mean curve of ``name``
    (:func:`band`; IB21 Fig. 11 right: the fleet's control time per plan). None: no data in some span."""
    b = band(runs, name)
    if b is None:
        return None
    ok = np.isfinite(b["mean"])
    end = len(b["t"]) * b["bin_s"]
    which = np.minimum((b["t"] / end * parts).astype(int), parts - 1)
    out = [b["mean"][ok & (which == q)] for q in range(parts)]
    return None if any(len(v) == 0 for v in out) else [float(v.mean()) for v in out]


def fleet_time(runs: list[dict]) -> list[float | None]:
    """Each run's mean over its plans of the fleet's control time per plan (s; None: no plan, or diverged)."""
    return [None if "diverged" in r else ((r.get("set_membership") or {}).get("solve_time") or {}).get("fleet_mean")
            for r in runs]


def per_uav_time(runs: list[dict]) -> list[float] | None:
    """Per UAV, in decision order, the mean over the runs of its mean control time per plan (s)."""
    rows = [s["solve_time"]["per_uav_mean"] for s in _sm(runs) if (s.get("solve_time") or {}).get("per_uav_mean")]
    return np.mean(np.array(rows, dtype=float), axis=0).tolist() if rows else None


def analyse(by_scenario: dict[str, list[dict]]) -> tuple[list[Claim], str, dict]:
    """The statements of Sec. 6 on Figs. 8-11 beside the project's numbers. Given only some experiments (one figure
    group: ``reproduce --figure``), only the claims whose experiments all ran (:data:`CLAIM_NEEDS`) and their rows."""
    ran = [e for e in EXPERIMENTS if e in by_scenario]
    by_scenario = {e: by_scenario.get(e, []) for e in EXPERIMENTS}
    clear = {e: cleared(by_scenario[e]) for e in EXPERIMENTS}
    phi = {e: time_mean(by_scenario[e], "phi_bar") for e in EXPERIMENTS}
    claims = []

    def none_clear(names):
        return all(clear[n][0] == 0 and clear[n][1] > 0 for n in names)

    def some_clear(name):
        ok, n = clear[name]
        return 0 < ok < n

    def all_clear(names):
        return all(clear[n][1] > 0 and clear[n][0] == clear[n][1] for n in names)

    cleared_of = {FLEET[n]: _fraction(*clear[n]) for n in FLEET}
    claims.append(Claim("ib21-fig8-three-or-fewer", "Fig. 8: with 3 UAVs or fewer the unexplored set X̄ is never "
                        "cleared within the run (\"too fast to allow 3 UAVs or less to fully eliminate it\")",
                        "never, 2 and 3 UAVs", cleared_of, none_clear(["ib21-fleet-2", "ib21-fleet-3"])))
    claims.append(Claim("ib21-fig8-four-some", "Fig. 8: with 4 UAVs X̄ is cleared in some runs only (\"may or may "
                        "not converge to 0 depending on the simulations\")", "some runs", cleared_of,
                        some_clear("ib21-fleet-4")))
    claims.append(Claim("ib21-fig8-five-or-more", "Fig. 8: with 5 UAVs or more X̄ is cleared in every run (the mean "
                        "reaches 0: \"at least 5 UAVs are necessary\")", "every run, 5 and 6 UAVs", cleared_of,
                        all_clear(["ib21-fleet-5", "ib21-fleet-6"])))
    claims.append(Claim("ib21-fig9-speed", "Fig. 9 left: at 1.8 m/s X̄ is cleared in no run, at 1.6 m/s in some "
                        "runs only", "1.8: none; 1.6: some", {SPEED[n]: _fraction(*clear[n]) for n in SPEED},
                        none_clear(["ib21-speed-1.8"]) and some_clear("ib21-speed-1.6")))
    parts = {e: {p: time_mean(by_scenario[e], f"phi_{p}") for p in ("unexplored", "unidentified", "identified")}
             for e in DECOYS}
    ordered = all(phi[e] is not None for e in DECOYS) and phi["ib21-decoys-0"] < phi["ib21-fleet-4"] \
        < phi["ib21-decoys-6"]
    growth = {p: None if None in (parts["ib21-decoys-6"][p], parts["ib21-decoys-0"][p]) else
              parts["ib21-decoys-6"][p] - parts["ib21-decoys-0"][p] for p in ("unexplored", "unidentified",
                                                                              "identified")}
    mainly = None not in growth.values() and growth["unidentified"] > max(growth["unexplored"], growth["identified"])
    claims.append(Claim("ib21-fig9-decoys", "Fig. 9 right: more decoys slow the decrease of Φ̄ (time-mean Φ̄ ordered "
                        "0 < 3 < 6 decoys), mainly through φ(Xᵁ) (its increase from 0 to 6 decoys exceeds those of "
                        "φ(X̄) and φ(X))", "slower with more decoys, mainly φ(Xᵁ)",
                        {"time-mean Φ̄ (m²)": {DECOYS[e]: phi[e] for e in DECOYS}, "increase 0 → 6 (m²)": growth},
                        ordered and mainly))
    over = phi["ib21-noise-over"]
    slowest = over is not None and all(phi[e] is not None and over > phi[e]
                                       for e in ("ib21-noise-5", "ib21-noise-20"))
    claims.append(Claim("ib21-fig10-over-slowest", "Fig. 10: an over-estimated noise bound gives the slowest decrease "
                        "of Φ̄ among the runs whose bound holds", "slowest",
                        {NOISE[e]: phi[e] for e in NOISE if e != "ib21-noise-under"}, slowest))
    under = _sm(by_scenario["ib21-noise-under"])
    lost = sum(s["guarantee_violations"] > 0 or s["empty_set_alarms"] > 0 for s in under)
    claims.append(Claim("ib21-fig10-under-lost", "Fig. 10: with an under-estimated bound the targets are lost (\"all "
                        "targets are lost at some time instant\": an empty-set alarm, or a guarantee violation)",
                        "all runs", {"runs with a violation or an alarm": _fraction(lost, len(under))},
                        bool(under) and lost == len(under)))
    violations = {e: sum(s["guarantee_violations"] for s in _sm(by_scenario[e])) for e in MATCHED}
    claims.append(Claim("ib21-guarantee", "While the true noise bound lies in the assumed one, no true target is ever "
                        "outside the sets that must hold it (every run, every step, every UAV)", "never",
                        {"violations": int(sum(violations.values())), "runs": sum(len(_sm(by_scenario[e]))
                                                                                  for e in MATCHED)},
                        all(v == 0 for v in violations.values()) and any(_sm(by_scenario[e]) for e in MATCHED)))
    comm = [phi[e] for e in COMM]
    claims.append(Claim("ib21-fig11-range", "Fig. 11 left: a shorter communication range slows the decrease of Φ̄ "
                        "(time-mean Φ̄ decreasing with d^c)", "slower when shorter", {COMM[e]: phi[e] for e in COMM},
                        None not in comm and all(a > b for a, b in zip(comm, comm[1:], strict=False))))
    solve = {FLEET[e]: mean_std_ci([s["solve_time"]["fleet_mean"] for s in _sm(by_scenario[e])
                                    if s.get("solve_time")])["mean"] for e in FLEET}
    per_uav = {n: None if v is None else v / n for n, v in solve.items()}
    linear = None not in per_uav.values() and per_uav[6] <= 3.0 * per_uav[2]
    claims.append(Claim("ib21-fig11-compute", "Fig. 11 right, on Fig. 8's fleets (2-6 UAVs, 3 decoys): the fleet's "
                        "control time grows with the fleet; per UAV at most linearly with the fleet size (the issue's "
                        "goal; the paper reports 2 and 3 UAVs at about 3× and 5× one UAV's time: claim "
                        "ib21-fig11-right-ratios)", PAPER_TIME_RATIOS,
                        {"fleet total per plan (s)": solve}, linear))


    # The four statements of Sec. 6 on the curves themselves (issue 27).
    spreads = {FLEET[e]: spread(by_scenario[e]) for e in FLEET}
    widest = None if None in spreads.values() else max(spreads, key=lambda n: spreads[n]["band_std_time_mean"])
    claims.append(Claim("ib21-fig8-variance-four", "Fig. 8 left: \"The variance of the estimation uncertainty Φ̄_k is "
                        "the largest for 4 UAVs\" (the shaded std band over the runs, averaged over the mission, "
                        "widest for 4 of 2-6 UAVs)", "largest for 4 UAVs",
                        {"widest for": widest, "std of Φ̄ over the runs (m²), per fleet size": spreads},
                        widest == 4))
    growth = {FLEET[e]: initial_growth(by_scenario[e]) for e in FLEET}
    first = None not in growth.values() and all(g["unidentified"] > g["identified"] for g in growth.values())
    claims.append(Claim("ib21-fig8-unidentified-first", "Fig. 8 right: \"The initial growth of φ(Xᵁ_k) ... is always "
                        "faster then the initial growth of φ(X_k)\" (both start from ∅: over the first "
                        f"{INITIAL_FRACTION:.0%} of the run the mean curve of φ(Xᵁ) lies above φ(X)'s on average, "
                        "for every fleet size; the runs where it does, per fleet size)", "always (2, 4 and 6 UAVs)",
                        {"mean over the first tenth (m²) and runs where φ(Xᵁ) > φ(X)": growth}, first))
    late = above_after(by_scenario["ib21-noise-20"], by_scenario["ib21-noise-5"])
    claims.append(Claim("ib21-fig10-twenty-above-five", "Fig. 10: \"When t ⩾ 100 s, the curve of Φ̄_k obtained for "
                        "[w] = [-20 m, 20 m] is above that for [w] = [-5 m, 5 m]\" (bound matched in both; every "
                        "time bin of the mean curves from 100 s on)", "above at every t ⩾ 100 s",
                        {"±20 / ±20 above ±5 / ±5 at t ⩾ 100 s": late}, late is not None
                        and late["bins_above"] == late["bins"]))
    flat = {COMPUTE[e]: quarters(by_scenario[e]) for e in COMPUTE}
    steady = None not in flat.values() and all(
        max(abs(q / np.mean(v) - 1.0) for q in v) <= CONSTANT_TOLERANCE for v in flat.values())
    claims.append(Claim("ib21-fig11-right-constant", "Fig. 11 right (1-3 UAVs, 3 targets, no decoys): \"the average "
                        "total computing time is almost constant with time\" (the mean over the runs of the fleet's "
                        f"control time per plan, in each quarter of the mission, within ±{CONSTANT_TOLERANCE:.0%} of "
                        "the mission's mean; ours)", "almost constant",
                        {"fleet time per plan by quarter (ms)": {n: _in_ms(v) for n, v in flat.items()}},
                        steady))
    fleet = {COMPUTE[e]: [v for v in fleet_time(by_scenario[e]) if v is not None] for e in COMPUTE}
    mean_time = {n: float(np.mean(v)) if v else None for n, v in fleet.items()}
    ratios = {n: None if None in (mean_time[n], mean_time[1]) or not mean_time[1] else mean_time[n] / mean_time[1]
              for n in PAPER_TIME_RATIOS}
    seed_ratios = {n: [b / a for a, b in zip(fleet_time(by_scenario["ib21-compute-1"]),
                                             fleet_time(by_scenario[f"ib21-compute-{n}"]), strict=False)
                       if a and b is not None] for n in PAPER_TIME_RATIOS}

    def near_paper(n, r):
        return abs(r - PAPER_TIME_RATIOS[n]) < abs(r - LINEAR_TIME_RATIOS[n])

    claims.append(Claim("ib21-fig11-right-ratios", "Fig. 11 right: \"The computing times for 2 and 3 UAVs is about "
                        "three and five times that with a single UAV\" (the fleet's control time per plan, mean "
                        "over the runs; \"about\": nearer the paper's ratio than linear growth's 2× and 3×)",
                        PAPER_TIME_RATIOS,
                        {"fleet time per plan (ms)": _in_ms(mean_time), "ratio to 1 UAV": ratios,
                         "seeds nearer the paper's ratio": {n: _fraction(sum(near_paper(n, r) for r in v), len(v))
                                                            for n, v in seed_ratios.items()},
                         "per UAV in decision order (ms)": {COMPUTE[e]: _in_ms(per_uav_time(by_scenario[e]))
                                                            for e in COMPUTE}},
                        None not in ratios.values() and all(near_paper(n, r) for n, r in ratios.items())))

    claims = [c for c in claims if set(CLAIM_NEEDS[c.id]) <= set(ran)]
    rows = []
    for e in ran:
        sm = _sm(by_scenario[e])
        rows.append([f"`{e}`", _fraction(*clear[e]), "—" if phi[e] is None else f"{phi[e]:.0f}",
                     str(int(sum(s["guarantee_violations"] for s in sm))),
                     str(int(sum(s["empty_set_alarms"] for s in sm))), str(len(sm))])
    md = "\n".join(["### IB21 Sec. 6: per setting", "",
                    markdown_table(["scenario", "X̄ cleared", "time-mean Φ̄ (m²)", "guarantee violations",
                                    "empty-set alarms", "runs"], rows)])
    numbers = {"cleared": {e: list(clear[e]) for e in ran}, "phi_bar_time_mean": {e: phi[e] for e in ran},
               "decoy_parts": {e: parts[e] for e in DECOYS if e in ran},
               "solve_time_fleet_mean": {FLEET[e]: solve[FLEET[e]] for e in FLEET if e in ran},
               "phi_bar_spread": {FLEET[e]: spreads[FLEET[e]] for e in FLEET if e in ran},
               "initial_growth": {FLEET[e]: growth[FLEET[e]] for e in FLEET if e in ran},
               "noise_20_above_5_after_100s": late,
               "compute": {COMPUTE[e]: {"fleet_time_per_plan": mean_time[COMPUTE[e]],
                                        "ratio_to_one": ratios.get(COMPUTE[e]),
                                        "per_uav_time": per_uav_time(by_scenario[e]),
                                        "quarters": flat[COMPUTE[e]]} for e in COMPUTE if e in ran}}
    if any(e in ran for e in COMPUTE):
        md += "\n\n" + _compute_table(mean_time, ratios, flat, {COMPUTE[e]: per_uav_time(by_scenario[e])
                                                                  for e in COMPUTE}, fleet)
    return claims, md, numbers


def _in_ms(v):
    """Seconds → milliseconds, through lists and dicts (None stays None)."""
    if isinstance(v, dict):
        return {k: _in_ms(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_in_ms(x) for x in v]
    return None if v is None else 1000 * v


def _ms(v: float | None) -> str:
    return "—" if v is None else f"{1000 * v:.2f}"


def _compute_table(mean_time: dict, ratios: dict, flat: dict, per_uav: dict, fleet: dict) -> str:
    """IB21 Fig. 11 right's numbers: per fleet size the fleet's control time per plan, its ratio to one UAV's (the
    paper's beside), each UAV's in decision order and the mission's quarters."""
    rows = []
    for n, t in mean_time.items():
        paper = "1" if n == 1 else f"{PAPER_TIME_RATIOS[n]:g}"
        ratio = "1" if n == 1 else ("—" if ratios.get(n) is None else f"{ratios[n]:.2f}")
        rows.append([str(n), _ms(t), ratio, paper, " / ".join(_ms(v) for v in per_uav[n] or []) or "—",
                     " / ".join(_ms(v) for v in flat[n] or []) or "—", str(len(fleet[n]))])
    return "\n".join(["### IB21 Fig. 11 right: control time per plan (3 targets, no decoys)", "",
                      markdown_table(["UAVs", "fleet (ms)", "ratio to 1 UAV", "paper", "per UAV, decision order (ms)",
                                      "by quarter of the mission (ms)", "runs"], rows)])


@dataclass(frozen=True)
class Panel:
    """One panel of IB21 Figs. 8-11: the file ``name`` (``.png``), its ``title``, the settings drawn (legend label →
    experiment) and the time series of the runs' ``series`` drawn for each (:func:`swarmtrack.analysis.metrics.series`);
    ``parts``: one sub-panel per part of Φ̄ instead
    (:func:`swarmtrack.capabilities.set_membership.figures.plot_phi_parts_bands`); ``style`` ``"spread"``: the std
    over the runs of Φ̄ alone (:func:`~swarmtrack.capabilities.set_membership.figures.plot_phi_spread`),
    ``"compute"``: the control time per plan of the fleet and of each UAV
    (:func:`~swarmtrack.capabilities.set_membership.figures.plot_compute_time`); ``marks``: the times a statement
    names, (t, text); ``window``: the fraction of the run a statement reads, shaded (Fig. 8 right's initial
    growth)."""

    name: str
    title: str
    settings: dict[str, str]
    quantities: tuple[str, ...] = ("phi_bar",)
    parts: bool = False
    style: str = "bands"
    marks: tuple[tuple[float, str], ...] = ()
    window: float | None = None


_PARTS_OF = (2, 4, 6)  # Fig. 8 right: the parts for 2, 4 and 6 UAVs
_BAND = "mean, \u00b11 std over runs"
#: IB21 Figs. 8-11 by figure (the ``reproduce --figure`` names), each a tuple of panels drawn from the runs.
FIGURES: dict[str, tuple[Panel, ...]] = {
    "8": (Panel("ib21-fig8-left", f"IB21 Fig. 8 left: $\\bar\\Phi$ per fleet size (3 targets, 3 decoys; {_BAND})",
                {f"$N_u$ = {n}": e for e, n in FLEET.items()}),
          Panel("ib21-fig8-left-std", "IB21 Fig. 8 left's shaded area: the std of $\\bar\\Phi$ over the runs per "
                "fleet size (the paper: the largest for 4 UAVs)", {f"$N_u$ = {n}": e for e, n in FLEET.items()},
                style="spread"),
          Panel("ib21-fig8-right", f"IB21 Fig. 8 right: the parts of $\\bar\\Phi$ for 2, 4 and 6 UAVs ({_BAND}; "
                f"shaded: the first {INITIAL_FRACTION:.0%} of the run, where $\\varphi(X^U)$ should grow faster than "
                "$\\varphi(X)$)", {f"$N_u$ = {n}": e for e, n in FLEET.items() if n in _PARTS_OF}, parts=True,
                window=INITIAL_FRACTION)),
    "9": (Panel("ib21-fig9-left", f"IB21 Fig. 9 left: $\\bar\\Phi$ per target speed (6 UAVs, 3 decoys; {_BAND})",
                {"$V^t$ = 1.0 m/s": "ib21-fleet-6", **{f"$V^t$ = {v} m/s": e for e, v in SPEED.items()}}),
          Panel("ib21-fig9-right", f"IB21 Fig. 9 right: $\\bar\\Phi$ per number of decoys (4 UAVs; {_BAND})",
                {f"{n} decoys": e for e, n in DECOYS.items()}),
          Panel("ib21-fig9-right-parts", f"IB21 Fig. 9 right: the parts of $\\bar\\Phi$ per number of decoys "
                f"(4 UAVs; {_BAND})", {f"{n} decoys": e for e, n in DECOYS.items()}, parts=True)),
    "10": (Panel("ib21-fig10-left", f"IB21 Fig. 10 left: $\\bar\\Phi$ per noise bound, true / assumed (5 UAVs, "
                 f"no decoys; {_BAND})", {f"{b} m": e for e, b in NOISE.items()},
                 marks=((LATE_T, "t = 100 s: ±20 / ±20 above ±5 / ±5 from here (paper)"),)),
           Panel("ib21-fig10-right", f"IB21 Fig. 10 right: the parts of $\\bar\\Phi$ per noise bound, true / assumed "
                 f"({_BAND})", {f"{b} m": e for e, b in NOISE.items()}, parts=True)),
    "11": (Panel("ib21-fig11-left", f"IB21 Fig. 11 left: $\\bar\\Phi$ per communication range (6 UAVs; {_BAND})",
                 {f"$d^c$ = {d} m": e for e, d in COMM.items()}),
           Panel("ib21-fig11-right", f"IB21 Fig. 11 right: the control time per plan for 1-3 UAVs (3 targets, no "
                 f"decoys; {_BAND})", {f"$N_u$ = {n}": e for e, n in COMPUTE.items()}, ("solve_time",),
                 style="compute"),
           Panel("ib21-fig11-right-fleets", f"The fleet's control time per plan, sum over the UAVs, for 2-6 UAVs "
                 f"(Fig. 8's runs: 3 targets, 3 decoys; {_BAND})", {f"$N_u$ = {n}": e for e, n in FLEET.items()},
                 ("solve_time",), style="compute")),
}
#: The experiments each figure needs (``swarmtrack reproduce ib21 --figure 8`` runs only these).
FIGURE_GROUPS = {k: tuple(dict.fromkeys(e for panel in panels for e in panel.settings.values()))
                 for k, panels in FIGURES.items()}


def _with_series(runs: list[dict]) -> list[dict]:
    """The runs that finished and carry their time series."""
    return [r for r in converged(runs) if "series" in r]


def draw_panel(panel: Panel, by_scenario: dict[str, list[dict]], out: Path) -> Path | None:
    """One panel of IB21 Figs. 8-11 into ``out/<name>.png``: per setting the mean line and ±1 std band over its runs
    (each run's ``series``: Φ̄, its parts or the solve time); None when none of its experiments has a finished run."""
    from swarmtrack.capabilities.set_membership import figures as plots  # matplotlib, only when drawing

    results = {label: _with_series(by_scenario.get(e, [])) for label, e in panel.settings.items()}
    results = {label: runs for label, runs in results.items() if runs}
    if not results:
        return None
    path = Path(out) / f"{panel.name}.png"
    if panel.style == "spread":
        return plots.plot_phi_spread(results, path, title=panel.title)
    if panel.style == "compute":
        return plots.plot_compute_time(results, path, title=panel.title, paper_ratios=PAPER_TIME_RATIOS)
    if panel.parts:
        window = None
        if panel.window is not None:
            ends = [len(r["series"].get("phi_bar") or []) * float(r["series"]["bin_s"])
                    for runs in results.values() for r in runs]
            window = (0.0, panel.window * max(ends)) if ends and max(ends) > 0 else None
        return plots.plot_phi_parts_bands(results, path, title=panel.title, window=window)
    return plots.plot_phi_bands(results, path, quantities=panel.quantities, title=panel.title, marks=panel.marks)


def figures(out: Path, overrides: Sequence[str] = (), by_scenario: dict[str, list[dict]] | None = None,
            figure: str | None = None) -> list[Path]:
    """IB21 Figs. 8-11 (all, or those of ``figure``) drawn from the runs of the reproduction (``by_scenario``, as
    :func:`analyse` gets them): mean lines with ±1 std bands over the runs (:data:`FIGURES`). Nothing is simulated
    here (``overrides`` reached the runs already); without runs there is nothing to draw."""
    if by_scenario is None:
        return []
    Path(out).mkdir(parents=True, exist_ok=True)
    chosen = FIGURES if figure is None else {figure: FIGURES[figure]}
    drawn = [draw_panel(panel, by_scenario, out) for panels in chosen.values() for panel in panels]
    return [p for p in drawn if p is not None]


PAPER = Paper("ib21", "Ibenthal et al. 2021: guaranteed search and track among decoys (Sec. 6, Figs. 8-11)",
              EXPERIMENTS, analyse, figures, FIGURE_GROUPS)
