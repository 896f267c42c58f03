"""Defences of the information filter's sharing against bad neighbours (:mod:`swarmtrack.estimation.gating`): the
χ²-gate on each delivered contribution and covariance intersection, as strategies an
:class:`~swarmtrack.estimation.information.InformationEstimator` is built with."""

from __future__ import annotations

from typing import Any

import numpy as np

from swarmtrack.estimation.base import Probe
from swarmtrack.estimation.gating import chi2_gate, covariance_intersection
from swarmtrack.estimation.information import InformationEstimator, InformationSharing, add_position_information


class Chi2Gate:
    """Each neighbour's contribution is added only when the position it implies passes a χ²(2) test against the
    receiver's own prediction (:func:`~swarmtrack.estimation.gating.chi2_gate`). Records whom: per receiver the
    contributions it left out (``gated``), per sender how many receivers left its out (``rejected``), and got it
    (``delivered``).

    Built for a subset of the swarm (``n_uavs`` receivers of a swarm of ``senders``): ``gated`` is per receiver;
    ``rejected`` and ``delivered`` stay per sender (``senders``,), tallied over this subset's receivers only, so the
    swarm's counts are the sums of its processes' (a sender cannot know who gated it)."""

    probes = (Probe("gated", ()), Probe("rejected", ()), Probe("delivered", ()))

    def __init__(self, n_uavs: int, probability: float = 0.999, *, senders: int | None = None):
        self.n = n_uavs
        senders = n_uavs if senders is None else senders
        self.threshold = -2.0 * np.log1p(-probability)  # the χ²(2) quantile (χ²(2) is exponential, mean 2)
        self._gated = np.zeros(n_uavs)
        self._rejected = np.zeros(senders)
        self._delivered = np.zeros(senders)

    def reset(self) -> None:
        self._gated[:] = 0.0
        self._rejected[:] = 0.0
        self._delivered[:] = 0.0

    def _gate(self, links, payloads: dict, x_pos: np.ndarray, P_pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """χ²-gated sums of one part of an inbox, counting the links."""
        I, i, recv, send, ok = chi2_gate(links, payloads, x_pos, P_pos, self.threshold, self.n)
        np.add.at(self._gated, recv[~ok], 1.0)
        np.add.at(self._rejected, send[~ok], 1.0)
        np.add.at(self._delivered, send, 1.0)
        return I, i

    def current(self, est: InformationEstimator, inbox) -> tuple[np.ndarray, np.ndarray]:
        """The gated sums of every part of the inbox against this step's prediction (late parts as if current)."""
        x_pos, P_pos = est.x_pred[..., est.index], est.predicted_position_covariance(est.x, est.P)
        I: Any = 0.0  # arrays from the first part on (an inbox has one at least)
        i: Any = 0.0
        for part in inbox.parts():
            I_p, i_p = self._gate(part.links, part.payloads, x_pos, P_pos)
            I, i = I + I_p, i + i_p
        return I, i

    def part(self, part, rows: np.ndarray, prior) -> tuple[np.ndarray, np.ndarray]:
        """The gated sums of the sending ``rows`` of one ``part``, against the prediction ``prior()`` for the step
        their data was taken at."""
        return self._gate(part.links, {**part.payloads, "seen": rows}, *prior())

    def sample(self) -> dict[str, np.ndarray]:
        return {"gated": self._gated.copy(), "rejected": self._rejected.copy(), "delivered": self._delivered.copy()}


class CovarianceIntersection(InformationSharing):
    """Own measurement by L24 eq. 7, then every neighbour's contribution by covariance intersection, one neighbour
    at a time (:func:`~swarmtrack.estimation.gating.covariance_intersection`): consistent whatever the neighbours'
    correlations."""

    additive = False

    def information(self, est: InformationEstimator, inbox) -> tuple[np.ndarray, np.ndarray]:
        Y, y = add_position_information(est.Y_pred, est.y_pred, est.own["info_matrix"], est.own["info_vector"])
        for part in inbox.parts():
            Y, y = covariance_intersection(Y, y, part.links, part.payloads)
        return Y, y
