"""The reproducible papers, one module each, and the registry :data:`PAPERS` that ``swarmtrack reproduce`` reads.

A paper module holds the published numbers as printed (units converted to metres and m/s), its experiments
(built-in scenario names), ``analyse(by_scenario) -> (claims, markdown, numbers)`` and ``figures(out)``, and
exports them as ``PAPER`` (:class:`Paper`). Adding a paper is one module here and one line below.
"""

from swarmtrack.analysis.papers import ib21, l23, l24, mtt, robustness, w20, w20_control
from swarmtrack.analysis.papers.base import Claim, Paper

PAPERS: dict[str, Paper] = {
    "l24": l24.PAPER,  # Lizzio et al., Drones 2024: Tables 1-3, Figs. 2-7
    "l23": l23.PAPER,  # Lizzio et al., EASN 2022: Table 1, Fig. 1
    "w20-estimation": w20.PAPER,  # Wolfe 2020 thesis Ch. 4: Tables 4.2, 4.4, 4.5, Figs. 4.4-4.11
    "w20-control": w20_control.PAPER,  # Wolfe 2020 thesis Ch. 5: Tables 5.6, 5.8, 5.9, 5.11, 5.12, Figs. 5.6-5.14
    "robustness": robustness.PAPER,  # issue 11: loss, delays, dropouts, a liar, time stamps (no paper)
    "ib21": ib21.PAPER,  # Ibenthal et al., Automatica 2021: Sec. 6, Figs. 8-11 (claims, figures from the runs)
    "mtt": mtt.PAPER,  # issue 40: many targets in clutter, the LMB swarm beside the field's trackers (no paper)
}

__all__ = ["PAPERS", "Claim", "Paper"]
