"""What an honest UAV does with what its neighbours send when one of them may lie.

Two rules for the information filter's neighbour contributions ``(I_j, i_j)`` (L24 eq. 6; each is one neighbour's own
measurement, the position ``q_j = I_j⁻¹ i_j`` with covariance ``I_j⁻¹``):

* ``chi2``: a χ²-test of each contribution against the receiver's own prediction, ``ν = q_j − x̂(k|k−1)[:2]``,
  ``S = I_j⁻¹ + P(k|k−1)[:2, :2]``; a contribution with ``νᵀS⁻¹ν`` above the ``probability`` quantile of χ²(2) is
  left out (gated), and the receiver records whom it gated. A consistent neighbour is gated with probability
  ``1 − probability``.
* ``ci``: covariance intersection (Julier and Uhlmann 1997): each contribution is fused as
  ``Y ← ωY + (1 − ω)EI_jEᵀ``, ``y ← ωy + (1 − ω)Ei_j`` with ``ω`` minimising the determinant of the fused
  covariance (over a grid). It is consistent whatever the correlation between the pieces, but it rejects
  nothing: a bias is only weighted down.
"""

from __future__ import annotations

import numpy as np

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


def chi2_gate(links, payloads: dict, x_pos: np.ndarray, P_pos: np.ndarray, threshold: float, n: int):
    """The χ²-gated inbox sums ``I (n, 2, 2), i (n, 2)``, and the ``receivers, senders`` of every delivered
    contribution with ``ok``, whether it passed (``νᵀS⁻¹ν ≤ threshold``).

    ``x_pos`` (n, 2) and ``P_pos`` (n, 2, 2) are each receiver's predicted position and its covariance."""
    recv, send = delivered(links, payloads)
    I_e, i_e = payloads["info_matrix"][send], payloads["info_vector"][send]
    ok = position_nis(_implied_positions(I_e, i_e), I_e, x_pos[recv], P_pos[recv]) <= threshold
    I = np.zeros((n, 2, 2))
    i = np.zeros((n, 2))
    np.add.at(I, recv[ok], I_e[ok])
    np.add.at(i, recv[ok], i_e[ok])
    return I, i, recv, send, ok


def ci_weight(C: np.ndarray, I_j: np.ndarray, d: int) -> np.ndarray:
    """The ω of :data:`CI_WEIGHTS` minimising the determinant of the fused covariance ``(ωY + (1 − ω)EI_jEᵀ)⁻¹`` for
    each receiver (``C`` (m, 2, 2) the position block of ``P = Y⁻¹``, ``I_j`` (m, 2, 2), ``E`` the position rows of
    a ``d``-state filter).

    By the matrix determinant lemma ``det(ωY + (1 − ω)EI_jEᵀ) = ωᵈ det Y det(I₂ + (1 − ω)/ω · I_j C)``: 2 x 2
    algebra per ω. The determinant (not the trace) because it does not add m² to (m/s)², and because the position
    block's trace alone falls again as ω → 0, which would throw away the receiver's velocity."""
    K = I_j @ C  # (m, 2, 2)
    a = ((1.0 - CI_WEIGHTS) / CI_WEIGHTS)[:, None]  # (weights, 1)
    det2 = (1.0 + a * K[None, :, 0, 0]) * (1.0 + a * K[None, :, 1, 1]) - a * a * K[None, :, 0, 1] * K[None, :, 1, 0]
    return CI_WEIGHTS[np.argmax(d * np.log(CI_WEIGHTS)[:, None] + np.log(det2), axis=0)]


def covariance_intersection(Y: np.ndarray, y: np.ndarray, links, payloads: dict) -> tuple[np.ndarray, np.ndarray]:
    """Fuse every delivered contribution into each receiver's ``Y (n, d, d), y (n, d)`` by covariance intersection,
    one neighbour at a time (the r-th neighbour of every receiver together), ω from :func:`ci_weight`."""
    recv, send = delivered(links, payloads)
    Y, y = Y.copy(), y.copy()
    rank = np.arange(recv.size) - np.searchsorted(recv, recv)  # receiver-major: position among its neighbours
    E = np.eye(Y.shape[-1])[:, :2]
    for r in range(int(rank.max()) + 1 if rank.size else 0):
        at = rank == r
        rows, I_e, i_e = recv[at], payloads["info_matrix"][send[at]], payloads["info_vector"][send[at]]
        C = np.linalg.solve(Y[rows], np.broadcast_to(E, (len(rows), *E.shape)))[:, :2]  # (Y⁻¹)[:2, :2]
        omega = ci_weight(C, I_e, Y.shape[-1])
        Y[rows] *= omega[:, None, None]
        Y[rows, :2, :2] += (1.0 - omega)[:, None, None] * I_e
        y[rows] *= omega[:, None]
        y[rows, :2] += (1.0 - omega)[:, None] * i_e
    return Y, y
