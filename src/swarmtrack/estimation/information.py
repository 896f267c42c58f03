"""Extended Kalman filter in information form, batched over agents (L24 Sec. 3, eqs. 4-7; L23 eqs. 11-18).

State of a bank of filters: information matrix ``Y = P⁻¹`` (..., n, n) and information vector ``y = P⁻¹ x``
(..., n). The sensors of this project observe the target's planar position (the first two states of every
model), so a measurement's information is a 2 x 2 block ``I`` and a 2-vector ``i`` added to the top-left of
``Y`` and ``y``; contributions are kept in that compact form and fused by plain sums (L24 eq. 7).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.models.base import MotionModel
from swarmtrack.sensors.range_bearing import polar_model, position_covariance, to_position, wrap_angle

UPDATES = ("position", "polar")


class FilterDivergence(RuntimeError):
    """An information filter lost positive definiteness or produced non-finite numbers."""

    def __init__(self, agents: np.ndarray, t: float, what: str):
        self.agents = [int(a) for a in np.atleast_1d(agents)]
        self.t = float(t)
        names = ", ".join(f"UAV {a + 1}" for a in self.agents)
        super().__init__(f"estimator diverged at t = {t:.2f} s on {names}: {what}")


@dataclass(frozen=True)
class RangeBearingUpdate:
    """How a range-bearing measurement enters the filter.

    ``position``: converted to the position it implies, with the paper's covariance
    ``R_i = Λ diag(σr², ρ̂²σβ²) Λᵀ`` evaluated at the predicted range and bearing (L24 Sec. 4, L23 eq. 20).
    ``polar``: the EKF update on ``[ρ, β]`` with ``R = diag(σr², σβ²)`` and wrapped bearing innovation
    (L24 eq. 6). The two agree to first order.
    """

    sigma_range: float
    sigma_bearing: float
    mode: str = "position"
    min_range: float = 0.05

    def contributions(self, x_pos: np.ndarray, sensor_pos: np.ndarray, z: np.ndarray):
        """Local measurement information ``(I, i)`` (L24 eq. 6), restricted to the position block.

        ``x_pos`` is the predicted target position each contribution is linearised at, ``sensor_pos`` the
        measuring UAV's own navigation position, ``z = [range, bearing]``; all broadcast together.
        Returns ``I (..., 2, 2)`` and ``i (..., 2)``.
        """
        rel = x_pos - sensor_pos
        if self.mode == "position":
            rho = np.maximum(np.hypot(rel[..., 0], rel[..., 1]), self.min_range)
            beta = np.arctan2(rel[..., 1], rel[..., 0])
            R = position_covariance(rho, beta, self.sigma_range, self.sigma_bearing)
            I = _inv2(R)
            i = np.einsum("...ab,...b->...a", I, to_position(z, sensor_pos))
            return I, i
        h, H = polar_model(x_pos, sensor_pos, min_range=self.min_range)
        nu = z - h
        nu[..., 1] = wrap_angle(nu[..., 1])
        w = np.array([1.0 / self.sigma_range**2, 1.0 / self.sigma_bearing**2])
        HtW = np.swapaxes(H, -1, -2) * w
        I = HtW @ H
        i = np.einsum("...ab,...b->...a", HtW, nu + np.einsum("...ab,...b->...a", H, x_pos))
        return I, i


def _inv2(R: np.ndarray) -> np.ndarray:
    """Closed-form inverse of symmetric 2 x 2 blocks (well conditioned here: R is SPD by construction)."""
    a, b, d = R[..., 0, 0], R[..., 0, 1], R[..., 1, 1]
    det = a * d - b * b
    out = np.empty_like(R)
    out[..., 0, 0] = d / det
    out[..., 1, 1] = a / det
    out[..., 0, 1] = out[..., 1, 0] = -b / det
    return out


def symmetrize(M: np.ndarray) -> np.ndarray:
    return 0.5 * (M + np.swapaxes(M, -1, -2))


def initial_information(model: MotionModel, n_filters: int, information: float = 1e-6):
    """Near-zero initial information (no prior, L24 Sec. 3.1): ``Y = εI`` on ``[x, y, vx, vy]``, a weak
    prior on the model's hidden states (:meth:`MotionModel.initial_information_diagonal`), ``y = Y x0``."""
    Y = np.broadcast_to(np.diag(model.initial_information_diagonal(information)),
                        (n_filters, model.dim, model.dim)).copy()
    y = Y @ model.initial_state()
    return Y, y


def recover(Y: np.ndarray, y: np.ndarray):
    """State and covariance from information, by solving ``Y [x P] = [y I]`` (inverse of L24 eq. 4)."""
    n = Y.shape[-1]
    rhs = np.concatenate([y[..., None], np.broadcast_to(np.eye(n), Y.shape)], axis=-1)
    sol = np.linalg.solve(Y, rhs)
    return sol[..., 0], symmetrize(sol[..., 1:])


def predict(model: MotionModel, x: np.ndarray, P: np.ndarray):
    """Prediction in information form from the posterior moments (L24 Sec. 3.1; linear case: ``∇f = F``).

    ``Y(k|k-1) = (∇f P ∇fᵀ + Q)⁻¹`` and ``y(k|k-1) = Y(k|k-1) f(x)``, both from one solve against
    ``P(k|k-1)``. ``x, P`` come from :func:`recover`. Returns ``Y_pred, y_pred, x_pred``.
    """
    F = model.jacobian(x)
    x_pred = model.f(x)
    P_pred = symmetrize(F @ P @ np.swapaxes(F, -1, -2) + model.Q)
    n = model.dim
    sol = np.linalg.solve(P_pred, np.concatenate(
        [x_pred[..., None], np.broadcast_to(np.eye(n), P_pred.shape)], axis=-1))
    return symmetrize(sol[..., 1:]), sol[..., 0], x_pred


def add_position_information(Y: np.ndarray, y: np.ndarray, I: np.ndarray, i: np.ndarray):
    """Update (L24 eq. 7) with fused position-block information; returns new arrays."""
    Y = Y.copy()
    y = y.copy()
    Y[..., :2, :2] += I
    y[..., :2] += i
    return Y, y


def check_information(Y: np.ndarray, y: np.ndarray, t: float) -> None:
    """Raise :class:`FilterDivergence` naming the agents whose information is non-finite or not PD."""
    bad = ~(np.isfinite(Y).all(axis=(-1, -2)) & np.isfinite(y).all(axis=-1))
    if not bad.any():
        try:
            np.linalg.cholesky(Y)
            return
        except np.linalg.LinAlgError:
            bad = np.linalg.eigvalsh(Y)[..., 0] <= 0.0
            raise FilterDivergence(np.flatnonzero(bad), t, "information matrix is not positive definite") from None
    raise FilterDivergence(np.flatnonzero(bad), t, "non-finite information")
