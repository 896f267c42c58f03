"""Is a run a success? The shared pieces of the health checks, and the network's.

A run's warnings come from the kinds it used (:func:`swarmtrack.analysis.metrics.summary`, :func:`check`): a
Gaussian estimator's checks (no detection, inconsistent filter, lost target:
:mod:`swarmtrack.capabilities.tracking_swarm.metrics`), a set-membership estimator's (guarantee violated, all sets
empty, unexplained detections without decoys: :mod:`swarmtrack.capabilities.set_membership.metrics`), the formation
MPC's (solver fallbacks, collisions: :mod:`swarmtrack.capabilities.mpc.metrics`), and, for a run whose filters gate
their neighbours or fuse late data, the network's (:class:`NetworkHealth`, here: both kinds of estimator use it):

* **Suspect neighbour**: the other UAVs' χ²-gates left out more than :data:`SUSPECT` of a UAV's contributions
  that reached them (a faulty or lying member; the gating contained it).
* **Stale data**: measurements or messages arrived later than the window an estimator keeps for late data (the
  information filter's re-filtering, the set-membership replay) and were dropped.

Each warning is a dict ``{kind, message, t_start, t_end[, uav]}`` (times in s, UAV numbers 1-based). The
accumulators are O(N) per UAV plus O(steps) scalars: they stream over the recording's chunks.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from swarmtrack.analysis import metrics
from swarmtrack.analysis.coverage import runs
from swarmtrack.registry import Metric
from swarmtrack.sim.recorder import Recording

#: Standard normal quantile of 0.975 (two-sided 95 %).
_Z975 = 1.959963984540054


def chi2_mean_band(dim: int, n: float) -> list[float]:
    """Two-sided 95 % band of the mean of ``n`` independent χ²(``dim``) samples, ``χ²_k⁻¹(0.025, 0.975) / n`` with
    ``k = dim·n``, by the Wilson-Hilferty cube-root normal approximation ``k (1 − 2/(9k) ± z √(2/(9k)))³``
    (relative error below 0.1 % for k ≥ 40, 1 % at k = 4; no scipy import, which costs a run 0.3-0.9 s)."""
    k = dim * n
    c = 2.0 / (9.0 * k)
    return [k * (1.0 - c + s * _Z975 * np.sqrt(c)) ** 3 / n for s in (-1.0, 1.0)]


def spans(flags: np.ndarray, t: np.ndarray, shortest: float) -> list[tuple[float, float]]:
    """Maximal runs of True in ``flags`` lasting at least ``shortest`` seconds, as ``(t_start, t_end)``."""
    return [(float(t[a]), float(t[b - 1])) for a, b in runs(flags, t, shortest)]


#: The fraction of a UAV's delivered contributions gated beyond which it is named a suspect.
SUSPECT = 0.1


class NetworkHealth:
    """Per-UAV totals of the gating probes (``gated``: contributions a UAV left out; ``rejected``: receivers that
    left out a UAV's; ``delivered``: receivers that got a UAV's) with each UAV's first and last rejection, and of
    ``stale`` (late data dropped)."""

    PROBES = ("gated", "rejected", "delivered", "stale")

    def __init__(self, rec: Recording):
        self.rec = rec
        self.names = [p for p in self.PROBES if p in rec.meta["probes"]]
        self.total = {p: np.zeros(rec.n_agents) for p in self.names}
        self.first = np.full(rec.n_agents, np.nan)
        self.last = np.full(rec.n_agents, np.nan)

    def add(self, c, keep=None, err=None) -> None:
        for p in self.names:
            self.total[p] += c.probes[p].sum(axis=0)
        if "rejected" in self.names and len(c.t):
            hit = c.probes["rejected"] > 0  # (k, N)
            any_hit = hit.any(axis=0)
            first, last = c.t[np.argmax(hit, axis=0)], c.t[len(c.t) - 1 - np.argmax(hit[::-1], axis=0)]
            self.first = np.where(any_hit & np.isnan(self.first), first, self.first)
            self.last = np.where(any_hit, last, self.last)

    def _rejected_fraction(self) -> np.ndarray:
        """Per UAV, the fraction of its delivered contributions that receivers gated (0 when none was delivered)."""
        delivered = self.total["delivered"]
        return np.divide(self.total["rejected"], delivered, out=np.zeros_like(delivered), where=delivered > 0)

    def result(self) -> dict:
        """The ``network`` section: per UAV the totals of each probe, the fraction of its contributions gated and
        when the gates first and last left one out."""
        out: dict[str, Any] = {f"{p}_per_uav": self.total[p].tolist() for p in self.names}
        if "rejected" in self.names:
            out["rejected_fraction"] = self._rejected_fraction().tolist()
            out["rejected_window"] = [None if np.isnan(a) else [float(a), float(b)]
                                      for a, b in zip(self.first, self.last, strict=True)]
        return out

    def warnings(self) -> list[dict]:
        warnings = []
        if "rejected" in self.names:
            fraction = self._rejected_fraction()
            for j in np.flatnonzero(fraction > SUSPECT):
                a, b = float(self.first[j]), float(self.last[j])
                warnings.append({"kind": "suspect_neighbour", "uav": int(j) + 1, "t_start": a, "t_end": b,
                                 "message": f"the other UAVs' gates left out {100 * fraction[j]:.0f} % of UAV "
                                            f"{j + 1}'s contributions that reached them, from t = {a:.1f} s to "
                                            f"{b:.1f} s: a faulty or lying member"})
        if "stale" in self.names and self.total["stale"].sum():
            warnings.append({"kind": "stale_data", "t_start": 0.0, "t_end": float(self.rec.t_last),
                             "message": f"{int(self.total['stale'].sum())} measurements or messages arrived later "
                                        "than the window the estimator keeps for late data (re-filtering, replay) "
                                        "and were dropped"})
        return warnings


def networked(rec: Recording) -> bool:
    """The run recorded gating or late-data probes: :class:`NetworkHealth` applies."""
    return any(p in rec.meta["probes"] for p in NetworkHealth.PROBES)


#: The ``network`` section of ``metrics.json`` (its counts) and its warnings, for the kinds that register it.
NETWORK = Metric("network", NetworkHealth, networked, lambda section: {})


def check(rec: Recording) -> list[dict]:
    """The warnings of one run (empty: nothing looked wrong): :func:`swarmtrack.analysis.metrics.warnings`."""
    return metrics.warnings(rec)
