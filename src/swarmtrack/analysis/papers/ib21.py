"""IB21 (Ibenthal et al., Automatica 2021): guaranteed search and track of targets among decoys, Sec. 6 and Figs. 8-11.

The paper's results are curves over 30 runs of 400 s; its statements are qualitative (who clears the unexplored set,
what slows the decrease of the uncertainty Φ̄). Each claim below is one statement with the paper's wording, checked on
the runs' ``set_membership`` metrics (:mod:`swarmtrack.analysis.metrics`): whether X̄ was cleared, the time-mean of
Φ̄ and of its parts (from the runs' series), guarantee violations and empty-set alarms, the MPC's solve time. The
mismatch values of Fig. 10 and the ranges of Fig. 11 are ours (the legends are lost; docs/set-membership.md).
A full study is 16 settings × 30 runs of 400 s: use ``--runs`` and ``--set duration=…`` for a shorter one.

The figures (:data:`FIGURES`) are Figs. 8-11 drawn from the same runs: per setting the mean line and ±1 std band over
the runs of each run's ``series`` (Φ̄, its parts, the fleet's solve time per plan). ``reproduce ib21 --figure 8``
runs only the experiments one figure needs (:data:`FIGURE_GROUPS`) and checks only the claims on them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
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


#: The experiments each claim of :func:`analyse` reads (the guarantee: whichever ran, so always kept).
CLAIM_NEEDS = {"ib21-fig8-three-or-fewer": ("ib21-fleet-2", "ib21-fleet-3"), "ib21-fig8-four-some": ("ib21-fleet-4",),
               "ib21-fig8-five-or-more": ("ib21-fleet-5", "ib21-fleet-6"), "ib21-fig9-speed": tuple(SPEED),
               "ib21-fig9-decoys": tuple(DECOYS), "ib21-fig10-over-slowest": tuple(NOISE),
               "ib21-fig10-under-lost": ("ib21-noise-under",), "ib21-guarantee": (), "ib21-fig11-range": tuple(COMM),
               "ib21-fig11-compute": tuple(FLEET)}


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
    claims.append(Claim("ib21-fig11-compute", "Fig. 11 right: the fleet's control time grows with the fleet; per UAV "
                        "at most linearly with the fleet size (the issue's goal; the paper reports 2 and 3 UAVs at "
                        "about 3× and 5× one UAV's time)", PAPER_TIME_RATIOS,
                        {"fleet total per plan (s)": solve}, linear))

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
               "solve_time_fleet_mean": {FLEET[e]: solve[FLEET[e]] for e in FLEET if e in ran}}
    return claims, md, numbers


@dataclass(frozen=True)
class Panel:
    """One panel of IB21 Figs. 8-11: the file ``name`` (``.png``), its ``title``, the settings drawn (legend label →
    experiment) and the time series of the runs' ``series`` drawn for each (:func:`swarmtrack.analysis.metrics.series`);
    ``parts``: one sub-panel per part of Φ̄ instead
    (:func:`swarmtrack.capabilities.set_membership.figures.plot_phi_parts_bands`)."""

    name: str
    title: str
    settings: dict[str, str]
    quantities: tuple[str, ...] = ("phi_bar",)
    parts: bool = False


_PARTS_OF = (2, 4, 6)  # Fig. 8 right: the parts for 2, 4 and 6 UAVs
_BAND = "mean, \u00b11 std over runs"
#: IB21 Figs. 8-11 by figure (the ``reproduce --figure`` names), each a tuple of panels drawn from the runs.
FIGURES: dict[str, tuple[Panel, ...]] = {
    "8": (Panel("ib21-fig8-left", f"IB21 Fig. 8 left: $\\bar\\Phi$ per fleet size (3 targets, 3 decoys; {_BAND})",
                {f"$N_u$ = {n}": e for e, n in FLEET.items()}),
          Panel("ib21-fig8-right", f"IB21 Fig. 8 right: the parts of $\\bar\\Phi$ for 2, 4 and 6 UAVs ({_BAND})",
                {f"$N_u$ = {n}": e for e, n in FLEET.items() if n in _PARTS_OF}, parts=True)),
    "9": (Panel("ib21-fig9-left", f"IB21 Fig. 9 left: $\\bar\\Phi$ per target speed (6 UAVs, 3 decoys; {_BAND})",
                {"$V^t$ = 1.0 m/s": "ib21-fleet-6", **{f"$V^t$ = {v} m/s": e for e, v in SPEED.items()}}),
          Panel("ib21-fig9-right", f"IB21 Fig. 9 right: $\\bar\\Phi$ per number of decoys (4 UAVs; {_BAND})",
                {f"{n} decoys": e for e, n in DECOYS.items()}),
          Panel("ib21-fig9-right-parts", f"IB21 Fig. 9 right: the parts of $\\bar\\Phi$ per number of decoys "
                f"(4 UAVs; {_BAND})", {f"{n} decoys": e for e, n in DECOYS.items()}, parts=True)),
    "10": (Panel("ib21-fig10-left", f"IB21 Fig. 10 left: $\\bar\\Phi$ per noise bound, true / assumed (5 UAVs, "
                 f"no decoys; {_BAND})", {f"{b} m": e for e, b in NOISE.items()}),
           Panel("ib21-fig10-right", f"IB21 Fig. 10 right: the parts of $\\bar\\Phi$ per noise bound, true / assumed "
                 f"({_BAND})", {f"{b} m": e for e, b in NOISE.items()}, parts=True)),
    "11": (Panel("ib21-fig11-left", f"IB21 Fig. 11 left: $\\bar\\Phi$ per communication range (6 UAVs; {_BAND})",
                 {f"$d^c$ = {d} m": e for e, d in COMM.items()}),
           Panel("ib21-fig11-right", f"IB21 Fig. 11 right: the fleet's control time per plan, sum over the UAVs "
                 f"(3 targets, 3 decoys; {_BAND})", {f"$N_u$ = {n}": e for e, n in FLEET.items()}, ("solve_time",))),
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
    if panel.parts:
        return plots.plot_phi_parts_bands(results, path, title=panel.title)
    return plots.plot_phi_bands(results, path, quantities=panel.quantities, title=panel.title)


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
