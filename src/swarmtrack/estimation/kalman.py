"""Covariance-form extended Kalman filter, batched (the textbook form the information filter must equal).

Used as the reference for the information filter and, later, by the multi-model filters of W20 Ch. 4,
whose number of stacked measurements changes every step.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.estimation.information import symmetrize
from swarmtrack.models.base import MotionModel
from swarmtrack.network.rows import Rows


def ekf_predict(model: MotionModel, x: np.ndarray, P: np.ndarray, rows: Rows | None = None):
    """``x(k|k-1) = f(x)``, ``P(k|k-1) = ∇f P ∇fᵀ + Q``; ``rows``: which of a batch's rows ``x`` holds (a subset's
    prediction bit for bit the whole batch's, :meth:`~swarmtrack.network.rows.Rows.rowwise`)."""
    F = model.jacobian(x)
    x_pred = model.f(x) if rows is None else rows.rowwise(model.f, x)
    return x_pred, symmetrize(F @ P @ np.swapaxes(F, -1, -2) + model.Q)


def ekf_update(x: np.ndarray, P: np.ndarray, H: np.ndarray, R: np.ndarray, innovation: np.ndarray):
    """Kalman update with stacked measurements: ``S = HPHᵀ + R``, ``K = PHᵀS⁻¹`` (by a solve), Joseph form.

    ``H`` (..., m, n), ``R`` (..., m, m), ``innovation`` (..., m) = ``z − h(x)`` with angles already wrapped.
    """
    PHt = P @ np.swapaxes(H, -1, -2)
    S = symmetrize(H @ PHt + R)
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, -1, -2)), -1, -2)
    x_new = x + np.einsum("...ab,...b->...a", K, innovation)
    A = np.eye(P.shape[-1]) - K @ H
    P_new = A @ P @ np.swapaxes(A, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
    return x_new, symmetrize(P_new)
