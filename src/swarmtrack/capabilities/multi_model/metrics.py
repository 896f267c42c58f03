"""What the analysis reads of the multi-model EKF's runs (W20 Ch. 4): the Gaussian estimate's sections, checks and
figures (:mod:`swarmtrack.capabilities.tracking_swarm.metrics`), ``model_use`` (whose filter each UAV's output used,
from the ``winner`` and ``switches`` probes) and the W20 figures (:mod:`.figures`): the own-model estimates, the
model selection and, for the IMM kinds, the model probabilities."""

from __future__ import annotations

import numpy as np

from swarmtrack.analysis.coverage import at_last_came, came
from swarmtrack.capabilities.tracking_swarm import metrics as gaussian
from swarmtrack.registry import Figure, Metric
from swarmtrack.sim.recorder import Chunk, Recording

_FIGURES = "swarmtrack.capabilities.multi_model.figures:"


def recorded(probe: str):
    """A test a recording passes when it recorded ``probe``."""
    def test(rec: Recording) -> bool:
        return probe in rec.meta["probes"]

    test.__name__ = f"recorded_{probe}"
    return test


def _model_use_applies(rec: Recording) -> bool:
    return gaussian.applies(rec) and "winner" in rec.meta["probes"]


class _ModelUse:
    """Which team member's estimate each UAV's output used (the ``winner`` probe: T-test winner, or the most
    probable filter): the share of steps per member and the count of switches per UAV (W20 Fig. 4.9 counts 36)."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.counts = np.zeros(rec.n_agents)
        self.switches = np.zeros(rec.n_agents)  # each UAV's cumulative count at its last sample that came

    def add(self, c: Chunk, keep: np.ndarray, err) -> None:
        present = came(self.rec, c)[keep]
        winner = c.probes["winner"][keep][present].astype(np.int64)  # 1-based, 0: none
        self.counts += np.bincount(winner.ravel(), minlength=len(self.counts) + 1)[1:len(self.counts) + 1]
        if keep.any():
            self.switches = at_last_came(present, c.probes["switches"][keep], self.switches)

    def result(self) -> dict:
        total = self.counts.sum()
        share = (self.counts / total).tolist() if total else []
        return {"share": share, "switches": float(self.switches.mean())}


METRICS = (*gaussian.METRICS, Metric("model_use", _ModelUse, _model_use_applies,
                                     lambda section: {"model_switches": section.get("switches")}, ("model_switches",)))
HEALTH = gaussian.HEALTH
FIGURES = (*gaussian.FIGURES,
           Figure("model_estimates_path.png", _FIGURES + "plot_w20_path", recorded("own_estimate")),
           Figure("model_estimates.png", _FIGURES + "plot_w20_xy_time", recorded("own_estimate")),
           Figure("model_selection.png", _FIGURES + "plot_model_selection", recorded("winner")),
           gaussian.PROBABILITIES)
