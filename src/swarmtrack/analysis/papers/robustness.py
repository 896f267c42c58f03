"""Robustness of the estimators to an imperfect network and to time (issue 11): no paper, the project's own study.

The papers assume a clean network. This study degrades one thing at a time and checks, as claims, what a user deciding
whether to fly needs: that the filters degrade gracefully with message loss (the information filter of L24 on
``robust-5``, 5 UAVs in full topology, and W20's multi-model filter on ``w20-switching-ideal``, its clean camera), that
time-stamp-aware fusion (:mod:`swarmtrack.estimation.refilter`) removes the overconfidence a sensor latency or network
delays cause, that a UAV that drops out and rejoins breaks nothing, and that χ²-gating contains a lying neighbour
(:mod:`swarmtrack.estimation.gating`, :mod:`swarmtrack.network.faults`). Each setting is a variant of a built-in
scenario (:attr:`~swarmtrack.analysis.papers.base.Paper.variants`); figures are the degradation curves (mean, ±1 std
over the runs).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from swarmtrack.analysis.papers.base import Claim, Paper, converged, mean_std_ci
from swarmtrack.analysis.report import markdown_table
from swarmtrack.estimation.gating import GATINGS

BASE = "robust-5"
LOSS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)
MM_LOSS = (0.0, 0.25, 0.5)
DELAY = (0.0, 0.25, 0.5, 1.0)  # s, each message's delay uniform in [0, value]
DROPOUTS = (0, 1, 2, 3)  # UAVs out of the network, each for 30 s, one after the other from t = 20 s
MM_DROPOUTS = (0, 1)  # w20-switching (3 UAVs, 74 s): UAV 2 out from 20 to 50 s
LIAR = "network.liar={uav: 3, mode: bias, offset: [1.0, 0.0]}"  # claims the target 1 m off
MODELS = ("cv", "ct", "fs")
#: The L24 scenarios' sensor latency (s), inferred from L24 Tables 1-3 (docs/tracking-swarm.md).
LATENCY = 0.15


def _name(kind: str, value) -> str:
    return f"robust-{kind}-{value:g}" if isinstance(value, float) else f"robust-{kind}-{value}"


def _dropout_overrides(k: int) -> tuple[str, ...]:
    if not k:
        return ()
    windows = ", ".join(f"{{uavs: [{j + 2}], window: [{20 + 30 * j}, {50 + 30 * j}]}}" for j in range(k))
    return (f"network.outages=[{windows}]",)


VARIANTS: dict[str, tuple[str, tuple[str, ...]]] = {}
VARIANTS.update({_name("loss", p): (BASE, (f"network.loss_probability={p}",)) for p in LOSS})
VARIANTS.update({_name("mm-loss", p): ("w20-switching-ideal", (f"network.loss_probability={p}",)) for p in MM_LOSS})
VARIANTS.update({_name("delay", d): (BASE, (f"network.delay_max={d}",)) for d in DELAY})
VARIANTS.update({_name("delay-as-current", d): (BASE, (f"network.delay_max={d}", "estimator.delayed_data=as_current"))
                 for d in DELAY[1:]})
VARIANTS.update({_name("dropout", k): (BASE, _dropout_overrides(k)) for k in DROPOUTS})
VARIANTS.update({_name("mm-dropout", k): ("w20-switching-ideal", _dropout_overrides(k)) for k in MM_DROPOUTS})
VARIANTS.update({_name("liar", g): (BASE, (LIAR, f"estimator.gating={g}")) for g in GATINGS})
VARIANTS["robust-liar-random-chi2"] = (BASE, ("network.liar={uav: 3, mode: random, sigma: 2.0}",
                                              "estimator.gating=chi2"))
VARIANTS["robust-clean-chi2"] = (BASE, ("estimator.gating=chi2",))  # what the gate costs an honest swarm
for m in MODELS:  # L24's scenarios (latency 0.15 s, as current) against time-stamp-aware fusion and no latency
    VARIANTS[f"robust-{m}-refilter"] = (f"l24-{m}", ("estimator.delayed_data=refilter",))
    VARIANTS[f"robust-{m}-no-latency"] = (f"l24-{m}", ("sensor.latency=0",))

GROUPS = {
    "loss": tuple(_name("loss", p) for p in LOSS) + tuple(_name("mm-loss", p) for p in MM_LOSS),
    "delay": tuple(_name("delay", d) for d in DELAY) + tuple(_name("delay-as-current", d) for d in DELAY[1:]),
    "dropout": tuple(_name("dropout", k) for k in DROPOUTS) + tuple(_name("mm-dropout", k) for k in MM_DROPOUTS),
    "liar": (_name("loss", 0.0), "robust-clean-chi2", *(_name("liar", g) for g in GATINGS),
             "robust-liar-random-chi2"),
    "timestamps": tuple(f"l24-{m}" for m in MODELS) + tuple(f"robust-{m}-{k}" for m in MODELS
                                                            for k in ("refilter", "no-latency")),
}
EXPERIMENTS = tuple(dict.fromkeys(e for group in GROUPS.values() for e in group))


def _values(runs: list[dict], get) -> list[float]:
    out = []
    for r in converged(runs):
        try:
            v = get(r)
        except (KeyError, TypeError):
            continue
        if v is not None:
            out.append(float(v))
    return out


def position_rmse(r: dict, phase: str = "total") -> float:
    """A run's position RMSE (m), mean over the UAVs, of ``phase``."""
    row = r["rmse"][phase]
    return float(np.hypot(row["x"], row["y"]))


def honest_rmse(r: dict, liar: int) -> float:
    """The position RMSE of the UAVs other than UAV ``liar`` (1-based; mean over them)."""
    per = np.asarray(r["position_rmse_per_uav"], dtype=float)
    return float(np.delete(per, liar - 1).mean())


def liar_of(by: dict) -> int:
    """The UAV that lied in the liar runs (their summaries' ``liar_uav``); the runs without a liar are judged on the
    same UAVs."""
    return next(r["liar_uav"] for r in converged(by[_name("liar", "none")]) if "liar_uav" in r)


def _nees(r: dict, phase: str = "total") -> float:
    return float(r["consistency"][phase]["nees"])


def _lost(runs: list[dict]) -> int:
    """Runs that diverged or lost the target (a ``lost_target`` warning)."""
    return sum("diverged" in r or any(w["kind"] == "lost_target" for w in r.get("warnings", [])) for r in runs)


def _stat(by: dict, name: str, get) -> dict:
    return mean_std_ci(_values(by.get(name, []), get))


def _avg(runs: list[dict], get) -> float | None:
    return mean_std_ci(_values(runs, get))["mean"]


def analyse(by_scenario: dict[str, list[dict]]) -> tuple[list[Claim], str, dict]:
    """Claims on the groups whose experiments ran (``--figure`` runs one group)."""
    ran = {g for g, names in GROUPS.items() if all(n in by_scenario for n in names)}
    claims, tables, numbers = [], [], {}
    by = by_scenario
    if "loss" in ran:
        curve = {p: _stat(by, _name("loss", p), position_rmse) for p in LOSS}
        mm = {p: _stat(by, _name("mm-loss", p), position_rmse) for p in MM_LOSS}
        lost = {n: _lost(by[n]) for n in GROUPS["loss"]}
        numbers["loss"] = {"information": curve, "multimodel": mm, "lost_or_diverged": lost}
        worst = curve[LOSS[-1]]["mean"] / curve[0.0]["mean"]
        claims.append(Claim("robust-loss-graceful", "Graceful degradation: up to 50 % message loss no run of the "
                            "information or multi-model filter diverges or loses the target, and the information "
                            "filter's position RMSE at 50 % loss is at most 2x the clean one",
                            "issue 11 (no paper)", {"lost or diverged runs": sum(lost.values()),
                                                    "RMSE ratio 50 % / 0 %": worst},
                            sum(lost.values()) == 0 and worst <= 2.0))
        tables.append(markdown_table(
            ["loss", "information filter position RMSE (m)", "NEES", "multi-model position RMSE (m)", "NEES"],
            [[f"{100 * p:.0f} %", _fmt(curve.get(p)), _fmt(_stat(by, _name("loss", p), _nees)) if p in curve else "",
              _fmt(mm.get(p)), _fmt(_stat(by, _name("mm-loss", p), _nees)) if p in mm else ""]
             for p in sorted({*LOSS, *MM_LOSS})]))
    if "delay" in ran:
        stamped = {d: _stat(by, _name("delay", d), position_rmse) for d in DELAY}
        stamped_nees = {d: _stat(by, _name("delay", d), _nees) for d in DELAY}
        naive = {d: _stat(by, _name("delay-as-current", d), position_rmse) for d in DELAY[1:]}
        naive_nees = {d: _stat(by, _name("delay-as-current", d), _nees) for d in DELAY[1:]}
        numbers["delay"] = {"refilter": {"rmse": stamped, "nees": stamped_nees},
                            "as_current": {"rmse": naive, "nees": naive_nees}}
        limit = 1.5 * stamped_nees[0.0]["mean"]
        claims.append(Claim("robust-delay-refilter-consistent", "With random network delays up to 1 s, time-stamp-"
                            "aware fusion keeps the NEES within 1.5x that of the run without delay at every delay "
                            "bound, while fusing late messages as current exceeds that at the largest",
                            "issue 11 (no paper)", {"refilter NEES": {d: v["mean"] for d, v in stamped_nees.items()},
                                                    "as-current NEES": {d: v["mean"] for d, v in naive_nees.items()}},
                            all(v["mean"] <= limit for v in stamped_nees.values())
                            and naive_nees[DELAY[-1]]["mean"] > limit))
        tables.append(markdown_table(
            ["delay bound", "refilter RMSE (m)", "refilter NEES", "as-current RMSE (m)", "as-current NEES"],
            [[f"{d:g} s", _fmt(stamped[d]), _fmt(stamped_nees[d]), _fmt(naive.get(d)), _fmt(naive_nees.get(d))]
             for d in DELAY]))
    if "dropout" in ran:
        curve = {k: _stat(by, _name("dropout", k), position_rmse) for k in DROPOUTS}
        mm = {k: _stat(by, _name("mm-dropout", k), position_rmse) for k in MM_DROPOUTS}
        lost = {n: _lost(by[n]) for n in GROUPS["dropout"]}
        numbers["dropout"] = {"information": curve, "multimodel": mm, "lost_or_diverged": lost}
        claims.append(Claim("robust-dropout-carries-on", "UAVs that leave the network for 30 s and rejoin (up to 3 "
                            "of 5, one after the other; one of W20's 3) cost at most 1.5x the clean position RMSE, "
                            "with no lost target", "issue 11 (no paper)",
                            {"information": {k: v["mean"] for k, v in curve.items()},
                             "multi-model": {k: v["mean"] for k, v in mm.items()}, "lost": sum(lost.values())},
                            sum(lost.values()) == 0 and curve[DROPOUTS[-1]]["mean"] <= 1.5 * curve[0]["mean"]
                            and mm[MM_DROPOUTS[-1]]["mean"] <= 1.5 * mm[0]["mean"]))
        tables.append(markdown_table(["UAVs dropping out", "information filter RMSE (m)", "multi-model RMSE (m)",
                                      "lost or diverged runs"],
                                     [[str(k), _fmt(curve[k]), _fmt(mm.get(k)),
                                       str(lost[_name("dropout", k)] + lost.get(_name("mm-dropout", k), 0))]
                                      for k in DROPOUTS]))
    if "liar" in ran:
        def honest(r):
            return honest_rmse(r, liar_of(by))

        clean = _stat(by, _name("loss", 0.0), honest)
        rows = {"no liar": clean, "no liar, chi2 gate": _stat(by, "robust-clean-chi2", honest)}
        rows.update({f"liar, gating {g}": _stat(by, _name("liar", g), honest) for g in GATINGS})
        rows["random liar, chi2 gate"] = _stat(by, "robust-liar-random-chi2", honest)
        numbers["liar"] = rows
        ratio = {k: v["mean"] / clean["mean"] for k, v in rows.items()}
        claims.append(Claim("robust-liar-gated", "With one liar among five UAVs (full topology), the χ²-gate keeps "
                            "the honest UAVs' position RMSE within 20 % of the run without the liar, while ungated "
                            "fusion degrades visibly (more than 1.5x)", "issue 11 goal (no paper)", ratio,
                            ratio["liar, gating chi2"] <= 1.2 and ratio["liar, gating none"] > 1.5))
        claims.append(Claim("robust-liar-ci-not-enough", "Covariance intersection weights the liar down but rejects "
                            "nothing: with the biased liar it is worse than the χ²-gate", "issue 11 (comparison)",
                            {k: ratio[k] for k in ("liar, gating chi2", "liar, gating ci")},
                            ratio["liar, gating ci"] > ratio["liar, gating chi2"]))
        tables.append(markdown_table(["setting", "honest UAVs' position RMSE (m)", "vs no liar"],
                                     [[k, _fmt(v), f"{ratio[k]:.2f}x"] for k, v in rows.items()]))
    if "timestamps" in ran:
        claims += _timestamp_claims(by, numbers, tables)
    return claims, "\n\n".join(tables), numbers


def _timestamp_claims(by: dict, numbers: dict, tables: list) -> list[Claim]:
    """L24's scenarios with their 0.15 s latency: fused as current (the paper's filter), at the time stamps, and
    without latency; the issue's goals and L24's FS claims under time-stamp-aware fusion."""
    table, claims = {}, []
    for m in MODELS:
        runs = {"as current": by[f"l24-{m}"], "refilter": by[f"robust-{m}-refilter"],
                "no latency": by[f"robust-{m}-no-latency"]}
        table[m] = {k: {"rmse": _avg(r, position_rmse),
                        "rmse_linear": _avg(r, lambda x: position_rmse(x, "linear")),
                        "y_sinusoidal": _avg(r, lambda x: x["rmse"]["sinusoidal"]["y"]),
                        "nees": _avg(r, _nees),
                        "nees_linear": _avg(r, lambda x: _nees(x, "linear")),
                        "band_linear": _values(r, lambda x: x["consistency"]["linear"]["band"][1])}
                    for k, r in runs.items()}
    numbers["timestamps"] = table
    cv = table["cv"]
    hi = float(np.mean(cv["refilter"]["band_linear"])) if cv["refilter"]["band_linear"] else float("nan")
    lo_runs = _values(by["robust-cv-refilter"], lambda x: x["consistency"]["linear"]["band"][0])
    lo = float(np.mean(lo_runs)) if lo_runs else float("nan")
    claims.append(Claim("robust-l24-cv-nees-in-band", "Issue 11 goal: with time-stamp-aware fusion, l24-cv's NEES on "
                        "the linear phase lies inside its 95 % χ² band", "issue 11 (no paper)",
                        {"band": [lo, hi], "as current": cv["as current"]["nees_linear"],
                         "refilter": cv["refilter"]["nees_linear"], "no latency": cv["no latency"]["nees_linear"]},
                        lo <= cv["refilter"]["nees_linear"] <= hi))
    claims.append(Claim("robust-l24-cv-not-overconfident", "With time-stamp-aware fusion l24-cv's NEES on the linear "
                        "phase is no longer above its band (fused as current it is)", "issue 11 (no paper)",
                        {"band upper": hi, "as current": cv["as current"]["nees_linear"],
                         "refilter": cv["refilter"]["nees_linear"]},
                        cv["refilter"]["nees_linear"] <= hi < cv["as current"]["nees_linear"]))
    ratio = cv["refilter"]["rmse"] / cv["no latency"]["rmse"]
    claims.append(Claim("robust-l24-cv-rmse", "Issue 11 goal: l24-cv's position RMSE with time-stamp-aware fusion "
                        "within 1.5x of the run without latency", "issue 11 (no paper)",
                        {"refilter": cv["refilter"]["rmse"], "no latency": cv["no latency"]["rmse"],
                         "ratio": ratio, "ratio, linear phase":
                         cv["refilter"]["rmse_linear"] / cv["no latency"]["rmse_linear"]}, ratio <= 1.5))
    y = {m: table[m]["refilter"]["y_sinusoidal"] for m in MODELS}
    total = {m: table[m]["refilter"]["rmse"] for m in MODELS}
    claims.append(Claim("robust-l24-fs-lowest-y-sinusoidal", "L24's FS claim under time-stamp-aware fusion: FS has "
                        "the lowest y RMSE in the sinusoidal phase", "L24 Table 2 (FS lowest)", y,
                        min(y, key=y.get) == "fs"))
    claims.append(Claim("robust-l24-fs-lowest-total", "L24's FS claim under time-stamp-aware fusion: FS has the "
                        "lowest total position RMSE", "L24 Tables 1-3 (FS lowest)", total,
                        min(total, key=total.get) == "fs"))
    rows = [[m, k, _num(v["rmse"]), _num(v["rmse_linear"]), _num(v["y_sinusoidal"]), _num(v["nees"]),
             _num(v["nees_linear"])] for m in MODELS for k, v in table[m].items()]
    tables.append(markdown_table(["model", "latency handling", "position RMSE (m)", "linear phase (m)",
                                  "sinusoidal y (m)", "NEES", "NEES linear"], rows))
    return claims


def _num(v) -> str:
    return "" if v is None else f"{v:.4f}"


def _fmt(s: dict | None) -> str:
    if not s or s["mean"] is None:
        return ""
    return f"{s['mean']:.4f} ± {s['std']:.4f}"


def figures(out: Path, overrides: Sequence[str] = (), by_scenario: dict | None = None,
            figure: str | None = None) -> list[Path]:
    """The degradation curves (mean, ±1 std over the runs) of the groups that ran."""
    from swarmtrack.analysis.papers import robustness_figures as plots  # matplotlib, only when drawing

    by = by_scenario or {}
    drawn = []

    def curve(names: dict, get) -> tuple[list, list, list]:
        xs, means, stds = [], [], []
        for x, name in names.items():
            s = _stat(by, name, get)
            if s["mean"] is not None:
                xs.append(x)
                means.append(s["mean"])
                stds.append(s["std"])
        return xs, means, stds

    def both(names: dict) -> dict:
        return {"position RMSE [m]": curve(names, position_rmse), "NEES": curve(names, _nees)}

    wanted = [figure] if figure else list(GROUPS)
    if "loss" in wanted and all(n in by for n in GROUPS["loss"]):
        drawn.append(plots.plot_degradation(
            {"information filter (robust-5)": both({100 * p: _name("loss", p) for p in LOSS}),
             "multi-model filter (w20-switching)": both({100 * p: _name("mm-loss", p) for p in MM_LOSS})},
            "message loss [%]", out / "robustness-loss.png"))
    if "delay" in wanted and all(n in by for n in GROUPS["delay"]):
        drawn.append(plots.plot_degradation(
            {"time-stamp-aware (refilter)": both({d: _name("delay", d) for d in DELAY}),
             "as current": both({0.0: _name("delay", 0.0), **{d: _name("delay-as-current", d) for d in DELAY[1:]}})},
            "delay bound [s] (uniform in [0, bound])", out / "robustness-delay.png"))
    if "dropout" in wanted and all(n in by for n in GROUPS["dropout"]):
        drawn.append(plots.plot_degradation(
            {"information filter (robust-5)": both({k: _name("dropout", k) for k in DROPOUTS}),
             "multi-model filter (w20-switching)": both({k: _name("mm-dropout", k) for k in MM_DROPOUTS})},
            "UAVs dropping out for 30 s", out / "robustness-dropout.png"))
    if "liar" in wanted and all(n in by for n in GROUPS["liar"]):
        names = {"no liar": _name("loss", 0.0), "liar, no gate": _name("liar", "none"),
                 "liar, χ² gate": _name("liar", "chi2"), "liar, CI": _name("liar", "ci"),
                 "random liar, χ² gate": "robust-liar-random-chi2"}
        xs = list(names)
        stats = [_stat(by, n, lambda r: honest_rmse(r, liar_of(by))) for n in names.values()]
        drawn.append(plots.plot_degradation({"honest UAVs": {"position RMSE [m]": (
            list(range(len(xs))), [s["mean"] for s in stats], [s["std"] for s in stats])}}, "setting",
            out / "robustness-liar.png", ticks=xs))
    return drawn


PAPER = Paper("robustness", "Issue 11: imperfect networks and time (loss, delay, dropouts, a liar; no paper)",
              EXPERIMENTS, analyse, figures, figure_groups=GROUPS, variants=VARIANTS)
