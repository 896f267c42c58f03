"""Many targets in clutter (issue 40; no paper): swarmtrack's LMB swarm on the bouncing-box benchmark of the
multi-sensor LMB filter libraries, beside the field's trackers.

The anchors (:data:`ANCHORS`) are issue 40's table, as measured there: 10 targets in a 200 m x 200 m box (CV with
velocity noise), 4 position sensors (σ = 1 m), 100 steps of 1 s; easy: P_D 0.98 and about 1 clutter point a scan
per sensor; hard: 0.90 and 10; GOSPA (c = 10 m, p = 1, α = 2) averaged over steps 20-99, 3 seeds, one core. The
LMB figures came from the Rust library multisensor-lmb-filters-rs through its Python binding, the others from Stone
Soup 1.9.1. Their scenes were drawn by their own generator, not by swarmtrack's world: the same benchmark, not the
same detections. The study (:func:`study`) runs Stone Soup's GM-PHD and JPDA on swarmtrack's own detections as live
references (when Stone Soup is installed) and times a UAV's tracker.

Experiments: the two boxes with the fused swarm (each UAV's filter over its own and its neighbours' detections, tracks
fused), with the centralised filter on the same detections (``-centre``), each UAV alone (``-alone``), each UAV's own
posterior fused with its neighbours' by geometric average only (``-ga``, the GA-LMB of the anchors), the classic GNN
and JPDA trackers in the LMB's place (``-gnn``, ``-jpda``: the same messages and fusion), the hard box over a lossy
network (``-lossy``, 30 % of messages lost); the search-and-track swarm (``mtt-swarm``); and one target on
L24's scene with detection probability 1 and no clutter, the LMB swarm against the information filter
(``l24-ct-lmb``, ``l24-ct-information``, both without L24's sensor latency, which the LMB filter does not model).
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from swarmtrack.analysis.papers.base import Claim, Paper, converged, stats
from swarmtrack.analysis.report import markdown_table

#: Issue 40's table: tracker → (easy GOSPA, easy ms/step, hard GOSPA, hard ms/step); times on a busy machine (the
#: issue: rerun alone, the hard case took 42 ms for the centralised LMB and 7.3 ms for GA-LMB, the same GOSPA).
ANCHORS = {
    "centralised LMB, all 4 sensors (iterated corrector)": (5.41, 10, 5.75, 100),
    "4 local LMB posteriors fused by geometric average (GA-LMB)": (6.33, 1.1, 8.70, 14),
    "one sensor alone (LMB)": (10.49, 1.5, 12.52, 81),
    "Stone Soup 1.9.1 GM-PHD, 4 sensors": (6.30, 190, 11.25, 435),
    "Stone Soup 1.9.1 JPDA, one sensor": (13.52, 110, 27.31, 129),
}
#: The goals of issue 40: the fused swarm's GOSPA, its distance to the centralised filter, a UAV's time per step,
#: and one target's error against the information filter's.
GOAL = {"easy": 6.0, "hard": 8.0}
WITHIN_CENTRALISED = 0.10
MS_PER_UAV_STEP = 5.0
ONE_TARGET = 0.05

CASES = ("easy", "hard")
VARIANTS = {
    **{f"mtt-box-{c}-centre": (f"mtt-box-{c}", ("estimator.share=centre",)) for c in CASES},
    **{f"mtt-box-{c}-alone": (f"mtt-box-{c}", ("estimator.share=none", "estimator.fuse_tracks=false")) for c in CASES},
    **{f"mtt-box-{c}-ga": (f"mtt-box-{c}", ("estimator.share=none",)) for c in CASES},
    **{f"mtt-box-{c}-{k}": (f"mtt-box-{c}", (f"estimator.kind={k}",)) for c in CASES for k in ("gnn", "jpda")},
    "mtt-box-hard-lossy": ("mtt-box-hard", ("network.loss_probability=0.3",)),
    "l24-ct-lmb": ("l24-ct", ("sensor.latency=0", "sensor.labelled=false", "estimator={kind: lmb, accel_std: 1.0}")),
    "l24-ct-information": ("l24-ct", ("sensor.latency=0",)),
}
BOX = tuple(f"mtt-box-{c}{v}" for c in CASES for v in ("", "-centre", "-alone", "-ga", "-gnn", "-jpda")) + \
    ("mtt-box-hard-lossy",)
EXPERIMENTS = (*BOX, "mtt-swarm", "l24-ct-lmb", "l24-ct-information")
#: How many seeds the live references run on (the anchors' 3; Stone Soup's GM-PHD takes a tenth of a second a step).
REFERENCE_SEEDS = 3


def _mean(runs: list[dict], *keys) -> tuple[float, float]:
    """Mean and std over the converged runs of the number at ``keys`` in each run's metrics."""
    def number(run: dict) -> float:
        value: Any = functools.reduce(operator.getitem, keys, run)
        return float(value)

    return stats([number(r) for r in converged(runs)])


def _diverged(by_scenario: dict[str, list[dict]]) -> int:
    """Runs that diverged or whose tracks stopped being finite."""
    return sum("diverged" in r or any(w.get("kind") == "tracks_not_finite" for w in r.get("warnings", []))
               for runs in by_scenario.values() for r in runs)


def analyse(by_scenario: dict[str, list[dict]]) -> tuple[list[Claim], str, dict]:
    """The box experiments' GOSPA beside the anchors, the goals as claims, the swarm and the one-target case."""
    numbers: dict = {}
    rows = []
    for name in (*BOX, "mtt-swarm"):
        runs = by_scenario[name]
        g = {k: _mean(runs, "gospa", k) for k in ("gospa", "localisation", "missed", "false")}
        numbers[name] = {**{k: v[0] for k, v in g.items()}, "gospa_std": g["gospa"][1],
                         "label_switches": _mean(runs, "continuity", "label_switches")[0],
                         "bytes_per_uav_step": _mean(runs, "tracking", "bytes_per_uav_step")[0]}
        n = numbers[name]
        rows.append([name, f"{n['gospa']:.2f} ± {n['gospa_std']:.2f}", f"{n['localisation']:.2f}",
                     f"{n['missed']:.2f}", f"{n['false']:.2f}", f"{n['label_switches']:.1f}",
                     f"{n['bytes_per_uav_step']:.0f}"])
    md = markdown_table(["experiment", "GOSPA (mean ± std)", "localisation", "missed", "false",
                         "label switches per UAV", "bytes per UAV per step"], rows)
    md += "\n\nIssue 40's anchors (their own scenes of the same benchmark, 3 seeds; see the module docstring):\n\n"
    md += markdown_table(["tracker", "easy GOSPA", "easy ms/step", "hard GOSPA", "hard ms/step"],
                         [[k, f"{a:.2f}", f"{b:g}", f"{c:.2f}", f"{d:g}"] for k, (a, b, c, d) in ANCHORS.items()])
    claims = []
    for case in CASES:
        fused, centre = numbers[f"mtt-box-{case}"]["gospa"], numbers[f"mtt-box-{case}-centre"]["gospa"]
        claims.append(Claim(f"mtt-{case}-gospa", f"The fused swarm's GOSPA on mtt-box-{case} is at most "
                            f"{GOAL[case]:g} (ahead of GA-LMB and Stone Soup's GM-PHD)", GOAL[case], fused,
                            fused <= GOAL[case]))
        gap = fused / centre - 1.0
        claims.append(Claim(f"mtt-{case}-centralised", f"The fused swarm is within {WITHIN_CENTRALISED:.0%} of the "
                            "centralised LMB on the same detections", WITHIN_CENTRALISED, gap,
                            gap <= WITHIN_CENTRALISED))
    diverged = _diverged(by_scenario)
    claims.append(Claim("mtt-no-divergence", "No run diverged (every reported track finite) over the seeds", 0,
                        diverged, diverged == 0))
    lmb = _mean(by_scenario["l24-ct-lmb"], "gospa", "position_rmse")[0]
    info = stats([(r["rmse"]["total"]["x"] ** 2 + r["rmse"]["total"]["y"] ** 2) ** 0.5
                  for r in converged(by_scenario["l24-ct-information"])])[0]
    numbers["one_target"] = {"lmb_position_rmse": lmb, "information_position_rmse": info}
    claims.append(Claim("mtt-one-target", f"On one target (P_D 1, no clutter, l24-ct), the LMB swarm's position RMSE "
                        f"is within {ONE_TARGET:.0%} of the information filter's (or below it)", info, lmb,
                        lmb <= (1.0 + ONE_TARGET) * info))
    md += (f"\n\nOne target on l24-ct (no latency): the LMB swarm's position RMSE {lmb:.4f} m, the information "
           f"filter's {info:.4f} m.")
    return claims, md, numbers


def study(by_scenario: dict[str, list[dict]], overrides: Sequence[str], runs: int) -> tuple[list[Claim], str, dict]:
    """A UAV's time per step on each box (seed 1, its compiled kernels and its numpy reference, one process), and
    Stone Soup's GM-PHD and JPDA on the same detections over the first :data:`REFERENCE_SEEDS` seeds, when Stone Soup
    is installed."""
    import importlib.util
    import os

    from swarmtrack.capabilities.multi_target.study import references, timed
    from swarmtrack.scenarios import load_scenario

    numbers: dict = {"load_average": os.getloadavg()[0]}
    rows = []
    claims = []
    for case in CASES:
        name = f"mtt-box-{case}"
        _, ms = timed(load_scenario(name, overrides, seed=1))
        _, ms_numpy = timed(load_scenario(name, [*overrides, "kernels=numpy"], seed=1))
        numbers[f"{case}_ms_per_uav_step"] = 1e3 * ms
        numbers[f"{case}_ms_per_uav_step_numpy"] = 1e3 * ms_numpy
        rows.append([name, f"{1e3 * ms:.2f}", f"{1e3 * ms_numpy:.2f}"])
        if case == "hard":
            claims.append(Claim("mtt-hard-time", f"A UAV's tracker takes at most {MS_PER_UAV_STEP:g} ms a step on "
                                "mtt-box-hard (one core)", MS_PER_UAV_STEP, 1e3 * ms, 1e3 * ms <= MS_PER_UAV_STEP))
    md = ("\n\nA UAV's estimation work per step (seed 1; load average "
          f"{numbers['load_average']:.2f}):\n\n" + markdown_table(["scenario", "ms per UAV per step",
                                                                   "numpy reference"], rows))
    if importlib.util.find_spec("stonesoup") is None:
        return claims, md + "\n\nStone Soup is not installed: no live references (the extra 'stonesoup').", numbers
    ref_rows = []
    for case in CASES:
        got: dict[str, list] = {}
        for seed in range(1, min(runs, REFERENCE_SEEDS) + 1):
            scenario = load_scenario(f"mtt-box-{case}", overrides, seed=seed)
            rec, _ = timed(scenario)
            for ref in references(rec, scenario):
                got.setdefault(ref.name, []).append((ref.gospa, ref.seconds_per_step))
        for ref_name, values in got.items():
            g, s = stats([v[0] for v in values]), stats([v[1] for v in values])
            numbers[f"{case}:{ref_name}"] = {"gospa": g[0], "ms_per_step": 1e3 * s[0]}
            ref_rows.append([case, ref_name, f"{g[0]:.2f} ± {g[1]:.2f}", f"{1e3 * s[0]:.0f}"])
    md += (f"\n\nThe field's trackers on swarmtrack's own detections (seeds 1-{min(runs, REFERENCE_SEEDS)}):\n\n"
           + markdown_table(["box", "tracker", "GOSPA", "ms per step"], ref_rows))
    return claims, md, numbers


def figures(out: Path, overrides: Sequence[str] = ()) -> list[Path]:
    """The hard box's tracks over the truth and its GOSPA over time, and the swarm's (seed 1)."""
    import swarmtrack
    from swarmtrack.capabilities.multi_target.figures import plot_gospa, plot_tracks

    drawn = []
    for name in ("mtt-box-hard", "mtt-swarm"):
        rec = swarmtrack.simulate(swarmtrack.load_scenario(name, overrides, seed=1))
        drawn += [plot_tracks(rec, out / f"{name}_tracks.png"), plot_gospa(rec, out / f"{name}_gospa.png")]
    return drawn


PAPER = Paper("mtt", "Many targets in clutter (issue 40): the LMB swarm on the bouncing-box benchmark",
              EXPERIMENTS, analyse, figures, variants=VARIANTS, study=study)
