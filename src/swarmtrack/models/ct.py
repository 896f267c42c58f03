"""Constant-turn (CT) target model with unknown turn rate, L24 Sec. 3.1 (corrected, see SPEC "Known typos").

State ``[x, y, vx, vy, omega]``. With ``a = ωT``::

    x'  = x + vx·sin(a)/ω − vy·(1 − cos a)/ω
    y'  = y + vx·(1 − cos a)/ω + vy·sin(a)/ω
    vx' = vx·cos a − vy·sin a
    vy' = vx·sin a + vy·cos a
    ω'  = ω

(L24 Sec. 3.1 prints ``y`` where ``vy`` is meant in the position rows; W20 eq. 2.39 is the same model with the
state order ``[x, vx, y, vy, ω]``.) Writing ``sin(a)/ω = T·S(a)`` and ``(1 − cos a)/ω = T·C(a)`` with
``S(a) = sin(a)/a`` and ``C(a) = (1 − cos a)/a``, both and their derivatives are evaluated by Taylor series
for ``|a| < SMALL_TURN``, so ``f`` and the analytic Jacobian are finite and accurate at ``ω = 0`` (where the
model reduces to constant velocity) and continuous across the threshold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.models.base import MotionModel

#: |ω·T| below which the series forms are used. The series below are truncated after the a⁷ term, so their
#: relative error at the threshold is ~1e-18; the closed forms above it lose at most ~1e-12 to cancellation.
SMALL_TURN = 1e-2


def turn_terms(a: np.ndarray, derivatives: bool = True) -> tuple[np.ndarray, ...]:
    """``S(a) = sin a / a``, ``C(a) = (1 − cos a)/a`` and (unless ``derivatives=False``) their derivatives
    ``S'(a)``, ``C'(a)``.

    Closed forms use ``1 − cos a = 2 sin²(a/2)`` (no cancellation); series for ``|a| < SMALL_TURN``.
    """
    small = np.abs(a) < SMALL_TURN
    a_safe = np.where(small, 1.0, a)
    sin_a, cos_a = np.sin(a_safe), np.cos(a_safe)
    one_minus_cos = 2.0 * np.sin(0.5 * a_safe) ** 2
    S_exact = sin_a / a_safe
    C_exact = one_minus_cos / a_safe
    a2 = a * a
    S_series = 1.0 - a2 / 6.0 * (1.0 - a2 / 20.0 * (1.0 - a2 / 42.0 * (1.0 - a2 / 72.0)))
    C_series = a / 2.0 * (1.0 - a2 / 12.0 * (1.0 - a2 / 30.0 * (1.0 - a2 / 56.0)))
    if not derivatives:
        return np.where(small, S_series, S_exact), np.where(small, C_series, C_exact)
    dS_exact = (a_safe * cos_a - sin_a) / a_safe**2
    dC_exact = (a_safe * sin_a - one_minus_cos) / a_safe**2

    dS_series = -a / 3.0 * (1.0 - a2 / 10.0 * (1.0 - a2 / 28.0 * (1.0 - a2 / 54.0)))
    dC_series = 0.5 - a2 / 8.0 * (1.0 - a2 / 18.0 * (1.0 - a2 / 40.0 * (1.0 - a2 / 70.0)))

    return (
        np.where(small, S_series, S_exact),
        np.where(small, C_series, C_exact),
        np.where(small, dS_series, dS_exact),
        np.where(small, dC_series, dC_exact),
    )


@dataclass(frozen=True)
class ConstantTurn(MotionModel):
    """Nearly-constant-turn model with the turn rate in the state (L24 Sec. 3.1, corrected; W20 eq. 2.39)."""

    name: str = "ct"
    state_names: tuple[str, ...] = ("x", "y", "vx", "vy", "omega")
    linear: bool = False
    hidden_prior_std: tuple[float, ...] = (0.5,)  # turn rate, rad/s

    def f(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        T = float(self.dt)
        px, py, vx, vy, w = (x[..., i] for i in range(5))
        a = w * T
        S, C = turn_terms(a, derivatives=False)
        sin_a, cos_a = np.sin(a), np.cos(a)
        return np.stack(
            [
                px + T * (vx * S - vy * C),
                py + T * (vx * C + vy * S),
                vx * cos_a - vy * sin_a,
                vx * sin_a + vy * cos_a,
                w,
            ],
            axis=-1,
        )

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Analytic ``∂f/∂x`` (..., 5, 5); the ω column uses ``d(T·S(ωT))/dω = T²·S'(ωT)`` (same for C)."""
        x = np.asarray(x, dtype=float)
        T = float(self.dt)
        vx, vy, w = x[..., 2], x[..., 3], x[..., 4]
        a = w * T
        S, C, dS, dC = turn_terms(a)
        sin_a, cos_a = np.sin(a), np.cos(a)
        J = np.zeros(x.shape[:-1] + (5, 5))
        J[..., 0, 0] = 1.0
        J[..., 0, 2] = T * S
        J[..., 0, 3] = -T * C
        J[..., 0, 4] = T * T * (vx * dS - vy * dC)
        J[..., 1, 1] = 1.0
        J[..., 1, 2] = T * C
        J[..., 1, 3] = T * S
        J[..., 1, 4] = T * T * (vx * dC + vy * dS)
        J[..., 2, 2] = cos_a
        J[..., 2, 3] = -sin_a
        J[..., 2, 4] = -T * (vx * sin_a + vy * cos_a)
        J[..., 3, 2] = sin_a
        J[..., 3, 3] = cos_a
        J[..., 3, 4] = T * (vx * cos_a - vy * sin_a)
        J[..., 4, 4] = 1.0
        return J
