"""L24 (Lizzio et al., Drones 2024): CV, CT and FS motion models in the decentralized information filter.

Published numbers: Tables 1-3, RMSE per phase and in total, mean over the three UAVs (cm and cm/s in the paper,
metres and m/s here). Claims: Sec. 4's comparison of the three models. Figures: Figs. 2-7 for each model.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import swarmtrack
from swarmtrack.analysis.metrics import COMPONENTS
from swarmtrack.analysis.papers.base import Claim, Paper, converged, stats
from swarmtrack.analysis.report import markdown_table

MODELS = ("cv", "ct", "fs")

RMSE = {  # Tables 1-3: model -> phase -> [x, y, vx, vy], metres / m/s
    "cv": {"linear": [0.0830, 0.0196, 0.0759, 0.0302], "sinusoidal": [0.0677, 0.2055, 0.0728, 0.2340],
           "circular": [0.2711, 0.2771, 0.4740, 0.4821], "total": [0.2077, 0.2325, 0.3554, 0.3767]},
    "ct": {"linear": [0.0647, 0.0212, 0.1851, 0.0429], "sinusoidal": [0.0818, 0.2344, 0.0851, 0.2094],
           "circular": [0.2676, 0.2580, 0.1132, 0.1518], "total": [0.2053, 0.2254, 0.1259, 0.1552]},
    "fs": {"linear": [0.0648, 0.0468, 0.1380, 0.1537], "sinusoidal": [0.0626, 0.1485, 0.1073, 0.1217],
           "circular": [0.1824, 0.1973, 0.3395, 0.3402], "total": [0.1422, 0.1670, 0.2649, 0.2704]},
}

EXPERIMENTS = tuple(f"l24-{m}" for m in MODELS)


def _vel(src: dict, m: str, phase: str) -> float:
    return (src[m][phase]["vx"] + src[m][phase]["vy"]) / 2


def _pos(src: dict, m: str, phase: str) -> float:
    return (src[m][phase]["x"] + src[m][phase]["y"]) / 2


def analyse(by_scenario: dict[str, list[dict]]) -> tuple[list[Claim], str, dict]:
    """Tables 1-3 beside the project's mean ± std over seeds, and the Sec. 4 claims."""
    table: dict = {}
    for m in MODELS:
        runs = converged(by_scenario[f"l24-{m}"])
        table[m] = {ph: {c: stats([r["rmse"][ph][c] for r in runs]) for c in COMPONENTS} for ph in RMSE[m]}
    mean = {m: {ph: {c: table[m][ph][c][0] for c in COMPONENTS} for ph in table[m]} for m in MODELS}
    P = {m: {ph: dict(zip(COMPONENTS, row, strict=True)) for ph, row in RMSE[m].items()} for m in MODELS}

    claims = []
    lin = {m: _vel(mean, m, "linear") for m in MODELS}
    claims.append(Claim("l24-cv-best-linear-velocity", "CV has the lowest linear-phase velocity RMSE",
                        {m: _vel(P, m, "linear") for m in MODELS}, lin, min(lin, key=lin.get) == "cv"))
    ratio = _vel(mean, "ct", "circular") / _vel(mean, "cv", "circular")
    claims.append(Claim("l24-ct-circular-velocity", "CT's circular-phase velocity RMSE is at most half of CV's",
                        _vel(P, "ct", "circular") / _vel(P, "cv", "circular"), ratio, ratio <= 0.5))
    sin_y = {m: mean[m]["sinusoidal"]["y"] for m in MODELS}
    claims.append(Claim("l24-fs-best-sinusoidal-y", "FS has the lowest sinusoidal-phase y RMSE",
                        {m: P[m]["sinusoidal"]["y"] for m in MODELS}, sin_y, min(sin_y, key=sin_y.get) == "fs"))
    tot = {m: _pos(mean, m, "total") for m in MODELS}
    claims.append(Claim("l24-fs-best-total-position", "FS has the lowest total position RMSE",
                        {m: _pos(P, m, "total") for m in MODELS}, tot, min(tot, key=tot.get) == "fs"))
    factor = {m: tot[m] / _pos(P, m, "total") for m in MODELS}
    claims.append(Claim("l24-total-position-within-3x",
                        "Total position RMSEs are within a factor 3 of the paper's (project: ratio to the paper)",
                        {m: _pos(P, m, "total") for m in MODELS}, factor,
                        all(1 / 3 <= f <= 3 for f in factor.values())))

    rows = []
    for m in MODELS:
        for ph in P[m]:
            cells = [f"{100 * P[m][ph][c]:.2f} / {100 * table[m][ph][c][0]:.2f} ± {100 * table[m][ph][c][1]:.2f}"
                     for c in COMPONENTS]
            rows.append([m.upper(), ph] + cells)
    md = markdown_table(["model", "phase"] + [f"{c} paper / project (cm, cm/s)" for c in COMPONENTS], rows)
    return claims, md, {"rmse": table}


def figures(out: Path, overrides: Sequence[str] = ()) -> list[Path]:
    """Figs. 2-4 (estimates), 5 (trajectories), 6 (target distances), 7 (inter-agent distances) per model."""
    from swarmtrack.analysis import plots  # matplotlib, only when drawing
    from swarmtrack.capabilities.tracking_swarm.figures import plot_estimates

    paths = []
    for name in EXPERIMENTS:
        rec = swarmtrack.simulate(swarmtrack.load_scenario(name, overrides, seed=1))
        paths += [plot_estimates(rec, out / f"{name}_estimates.png"),
                  plots.plot_trajectories(rec, out / f"{name}_trajectories.png"),
                  plots.plot_target_distances(rec, out / f"{name}_target_distances.png"),
                  plots.plot_inter_agent_distances(rec, out / f"{name}_inter_agent_distances.png")]
    return paths


PAPER = Paper("l24", "Lizzio et al., Drones 2024: motion models for cooperative target tracking (Tables 1-3)",
              EXPERIMENTS, analyse, figures)
