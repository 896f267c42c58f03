"""What an honest UAV does with what its neighbours send when one of them may lie.

Two rules for the information filter's neighbour contributions ``(I_j, i_j)`` (L24 eq. 6; each is one neighbour's own
measurement, the position ``q_j = I_j⁻¹ i_j`` with covariance ``I_j⁻¹``):

* ``chi2``: a χ²-test of each contribution against the receiver's own prediction, ``ν = q_j − x̂(k|k−1)[:2]``,
  ``S = I_j⁻¹ + P(k|k−1)[:2, :2]``; a contribution with ``νᵀS⁻¹ν`` above the ``probability`` quantile of χ²(2) is
  left out (gated), and the receiver records whom it gated. A consistent neighbour is gated with probability
  ``1 − probability``.
* ``ci``: covariance intersection (Julier and Uhlmann 1997): each contribution is fused as
  ``Y ← ωY + (1 − ω)EI_jEᵀ``, ``y ← ωy + (1 − ω)Ei_j`` with ``ω`` minimising the trace of the fused covariance
  (over a grid). It is consistent whatever the correlation between the pieces, but it rejects nothing: a bias is
  only weighted down.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from swarmtrack.estimation.information import position_nis
from swarmtrack.network.links import edge_list

GATINGS = ("none", "chi2", "ci")
#: The weights ω that covariance intersection tries.
CI_WEIGHTS = np.linspace(0.02, 0.98, 49)


def _implied_positions(I: np.ndarray, i: np.ndarray) -> np.ndarray:
    """``I⁻¹ i`` (..., 2) for 2 x 2 information blocks (closed form)."""
    a, b, d = I[..., 0, 0], I[..., 0, 1], I[..., 1, 1]
    det = a * d - b * b
    return np.stack([(d * i[..., 0] - b * i[..., 1]) / det, (a * i[..., 1] - b * i[..., 0]) / det], axis=-1)


def delivered(links, payloads: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(receivers, senders)`` of every link that carried a contribution with information (the sender saw)."""
    recv, send = edge_list(links)
    keep = payloads["seen"][send]
    return recv[keep], send[keep]


def chi2_gate(links, payloads: dict, x_pos: np.ndarray, P_pos: np.ndarray, probability: float, n: int):
    """The χ²-gated inbox sums ``(I (n, 2, 2), i (n, 2))`` and the ``(receivers, senders)`` of the gated links.

    ``x_pos`` (n, 2) and ``P_pos`` (n, 2, 2) are each receiver's predicted position and its covariance."""
    recv, send = delivered(links, payloads)
    I_e, i_e = payloads["info_matrix"][send], payloads["info_vector"][send]
    nis = position_nis(_implied_positions(I_e, i_e), I_e, x_pos[recv], P_pos[recv])
    ok = nis <= chi2.ppf(probability, 2)
    I = np.zeros((n, 2, 2))
    i = np.zeros((n, 2))
    np.add.at(I, recv[ok], I_e[ok])
    np.add.at(i, recv[ok], i_e[ok])
    return I, i, (recv[~ok], send[~ok])


def covariance_intersection(Y: np.ndarray, y: np.ndarray, links, payloads: dict) -> tuple[np.ndarray, np.ndarray]:
    """Fuse every delivered contribution into each receiver's ``Y (n, d, d), y (n, d)`` by covariance intersection,
    one neighbour at a time (the r-th neighbour of every receiver together), ``ω`` minimising ``tr(Y⁻¹)``."""
    recv, send = delivered(links, payloads)
    Y, y = Y.copy(), y.copy()
    rank = np.arange(recv.size) - np.searchsorted(recv, recv)  # receiver-major: position among its neighbours
    w = CI_WEIGHTS[:, None, None, None]
    for r in range(int(rank.max()) + 1 if rank.size else 0):
        at = rank == r
        rows, I_e, i_e = recv[at], payloads["info_matrix"][send[at]], payloads["info_vector"][send[at]]
        Yj = np.zeros(Y[rows].shape)
        Yj[:, :2, :2] = I_e
        candidates = w * Y[rows][None] + (1.0 - w) * Yj[None]  # (weights, m, d, d)
        eye = np.broadcast_to(np.eye(Y.shape[-1]), candidates.shape)
        trace = np.trace(np.linalg.solve(candidates, eye), axis1=-2, axis2=-1)  # (weights, m)
        omega = CI_WEIGHTS[np.argmin(trace, axis=0)]
        Y[rows] = omega[:, None, None] * Y[rows] + (1.0 - omega)[:, None, None] * Yj
        y[rows] *= omega[:, None]
        y[rows, :2] += (1.0 - omega)[:, None] * i_e
    return Y, y
