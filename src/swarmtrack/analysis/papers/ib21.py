"""IB21 (Ibenthal et al., Automatica 2021): guaranteed search and track of targets among decoys, Sec. 6 and Figs. 8-11.

The paper's results are curves over 30 runs of 400 s; its statements are qualitative (who clears the unexplored set,
what slows the decrease of the uncertainty Φ̄). Each claim below is one statement with the paper's wording, checked on
the runs' ``set_membership`` metrics (:mod:`swarmtrack.analysis.metrics`): whether X̄ was cleared, the time-mean of
Φ̄ and of its parts (from the runs' series), guarantee violations and empty-set alarms, the MPC's solve time. The
mismatch values of Fig. 10 and the ranges of Fig. 11 are ours (the legends are lost; docs/set-membership.md).
A full study is 16 settings × 30 runs of 400 s: use ``--runs`` and ``--set duration=…`` for a shorter one.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from swarmtrack.analysis.papers.base import Claim, Paper, converged, mean_std_ci
from swarmtrack.analysis.report import markdown_table

FLEET = {f"ib21-fleet-{n}": n for n in (2, 3, 4, 5, 6)}  # Fig. 8: 3 targets, 3 decoys, 1 m/s
SPEED = {"ib21-speed-1.6": 1.6, "ib21-speed-1.8": 1.8}  # Fig. 9 left: 6 UAVs
DECOYS = {"ib21-decoys-0": 0, "ib21-fleet-4": 3, "ib21-decoys-6": 6}  # Fig. 9 right: 4 UAVs
NOISE = {"ib21-noise-5": "±5 / ±5", "ib21-noise-20": "±20 / ±20", "ib21-noise-over": "±5 / ±20",
         "ib21-noise-under": "±20 / ±5"}  # Fig. 10: 5 UAVs, no decoys; true / assumed bound (m)
COMM = {"ib21-comm-50": 50, "ib21-comm-100": 100, "ib21-fleet-6": 200, "ib21-comm-600": 600}  # Fig. 11 left
EXPERIMENTS = tuple(dict.fromkeys([*FLEET, *SPEED, *DECOYS, *NOISE, *COMM]))
#: The runs whose true noise bound lies inside the assumed one: the guarantee must hold in every one.
MATCHED = tuple(e for e in EXPERIMENTS if e != "ib21-noise-under")
#: IB21 Fig. 11 right: 2 and 3 UAVs take about 3 and 5 times one UAV's control time.
PAPER_TIME_RATIOS = {2: 3.0, 3: 5.0}


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


def analyse(by_scenario: dict[str, list[dict]]) -> tuple[list[Claim], str, dict]:
    """The statements of Sec. 6 on Figs. 8-11 beside the project's numbers."""
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
    claims.append(Claim("ib21-fig11-compute", "Fig. 11 right: the fleet's control time grows with the fleet; per UAV "
                        "at most linearly with the fleet size (the issue's goal; the paper reports 2 and 3 UAVs at "
                        "about 3× and 5× one UAV's time)", PAPER_TIME_RATIOS,
                        {"fleet total per plan (s)": solve}, linear))

    rows = []
    for e in EXPERIMENTS:
        sm = _sm(by_scenario[e])
        rows.append([f"`{e}`", _fraction(*clear[e]), "—" if phi[e] is None else f"{phi[e]:.0f}",
                     str(int(sum(s["guarantee_violations"] for s in sm))),
                     str(int(sum(s["empty_set_alarms"] for s in sm))), str(len(sm))])
    md = "\n".join(["### IB21 Sec. 6: per setting", "",
                    markdown_table(["scenario", "X̄ cleared", "time-mean Φ̄ (m²)", "guarantee violations",
                                    "empty-set alarms", "runs"], rows)])
    numbers = {"cleared": {e: list(clear[e]) for e in EXPERIMENTS}, "phi_bar_time_mean": phi,
               "decoy_parts": parts, "solve_time_fleet_mean": solve}
    return claims, md, numbers


def figures(out: Path, overrides: Sequence[str] = ()) -> list[Path]:
    """None yet: the paper's figures are bands over runs (Figs. 8-11); ``swarmtrack sweep`` and ``summarize`` draw
    Φ̄ and its parts as bands over seeds today (docs/set-membership.md)."""
    return []


PAPER = Paper("ib21", "Ibenthal et al. 2021: guaranteed search and track among decoys (Sec. 6, Figs. 8-11)",
              EXPERIMENTS, analyse, figures)
