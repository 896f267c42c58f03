"""L23 (Lizzio et al., EASN 2022): information fusion and flocking variants for a tracking swarm.

Published numbers: Table 1, the standard deviation of the estimates without and with full fusion (m and m/s,
mean over the three UAVs). Claims: Table 1's fusion gain and Fig. 1's flocking comparison (qualitative).
Figure: Fig. 1, inter-agent distances under standard, integral and tailored flocking.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import swarmtrack
from swarmtrack.analysis.metrics import COMPONENTS
from swarmtrack.analysis.papers.base import Claim, Paper, converged, stats
from swarmtrack.analysis.report import markdown_table

SPREAD = {  # Table 1: fusion -> [x, y, vx, vy]
    "no-fusion": [0.2647, 0.3903, 0.1328, 0.1285],
    "full-fusion": [0.1333, 0.1149, 0.0762, 0.0619],
}

FLOCKING = ("standard", "integral", "tailored")

EXPERIMENTS = (*(f"l23-{k}" for k in SPREAD), *(f"l23-flocking-{v}" for v in FLOCKING))


def analyse(by_scenario: dict[str, list[dict]]) -> tuple[list[Claim], str, dict]:
    """Table 1 beside the project's mean ± std over seeds; Fig. 1's spacing offset and overshoot per variant."""
    spread = {k: {c: stats([r["spread"][c] for r in converged(by_scenario[f"l23-{k}"])]) for c in COMPONENTS}
              for k in SPREAD}
    ratio = {c: spread["full-fusion"][c][0] / spread["no-fusion"][c][0] for c in COMPONENTS}
    paper_ratio = {c: SPREAD["full-fusion"][k] / SPREAD["no-fusion"][k] for k, c in enumerate(COMPONENTS)}
    claims = [Claim("l23-fusion-halves-spread",
                    "With full fusion every component's estimate spread is at most 0.7x that without",
                    paper_ratio, ratio, all(r <= 0.7 for r in ratio.values()))]
    runs = {v: converged(by_scenario[f"l23-flocking-{v}"]) for v in FLOCKING}
    flock = {v: {k: stats([r["inter_agent_distance"][k] for r in runs[v]]) for k in ("offset", "overshoot")}
             for v in FLOCKING}
    chains = {v: sum(r["inter_agent_distance"]["open_pairs"] > 0 for r in runs[v]) for v in FLOCKING}
    off = {v: flock[v]["offset"][0] for v in flock}
    claims.append(Claim("l23-standard-offset-removed",
                        "Standard flocking keeps a steady-state spacing offset (> 0.1 m) that the integral and "
                        "tailored variants remove (< 0.05 m)", "Fig. 1a-c (qualitative)", off,
                        off["standard"] > 0.1 and off["integral"] < 0.05 and off["tailored"] < 0.05))
    over = {v: flock[v]["overshoot"][0] for v in flock}
    claims.append(Claim("l23-tailored-smoother", "Tailored flocking overshoots less than integral action",
                        "Fig. 1b-c (qualitative)", over, over["tailored"] < over["integral"]))
    rows = [[k, *[f"{SPREAD[k][i]:.4f} / {spread[k][c][0]:.4f} ± {spread[k][c][1]:.4f}"
                  for i, c in enumerate(COMPONENTS)]] for k in SPREAD]
    md = markdown_table(["fusion"] + [f"{c} paper / project (m, m/s)" for c in COMPONENTS], rows)
    md += "\n\n" + markdown_table(
        ["flocking", "spacing offset (m)", "overshoot (m)", "runs ending as an open chain"],
        [[v, f"{flock[v]['offset'][0]:.3f} ± {flock[v]['offset'][1]:.3f}",
          f"{flock[v]['overshoot'][0]:.3f} ± {flock[v]['overshoot'][1]:.3f}", str(chains[v])] for v in flock])
    return claims, md, {"spread": spread, "flocking": flock, "open_chains": chains}


def figures(out: Path, overrides: Sequence[str] = ()) -> list[Path]:
    """Fig. 1: inter-agent distances of the three flocking variants side by side (seed 1)."""
    from swarmtrack.capabilities.tracking_swarm import figures  # matplotlib, only when drawing

    recs = {v: swarmtrack.simulate(swarmtrack.load_scenario(f"l23-flocking-{v}", overrides, seed=1)) for v in FLOCKING}
    return [figures.plot_flocking_comparison(recs, out / "l23_fig1_flocking.png")]


PAPER = Paper("l23", "Lizzio et al., EASN 2022: fusion and flocking for a tracking swarm (Table 1, Fig. 1)",
              EXPERIMENTS, analyse, figures)
