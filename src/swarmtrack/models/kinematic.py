"""The CV, CA and CT models' motion over any horizon, in closed form: where a target with state ``[x, y, vx, vy]``
and the model's extra states ``[ax, ay, ω]`` is after each of several times τ (W20 eqs. 2.37-2.39; the models'
transitions :meth:`~swarmtrack.models.base.MotionModel.f` with the period set to τ, evaluated at once for every τ).
What W20 eq. 5.23 propagates an MPC's reference with, and how a blind UAV extrapolates its last estimate."""

from __future__ import annotations

import numpy as np

from swarmtrack.models.ct import turn_terms

#: The models this module moves: constant velocity, constant acceleration, constant turn.
KINEMATIC = ("cv", "ca", "ct")


def kinematic_motion(state: np.ndarray, model: str, motion: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """``[x, y, vx, vy]`` (N, H, 4) of N targets after each τ (H,) s of ``model``'s motion from ``state`` (N, 4)
    with extra states ``motion`` (N, 3) = ``[ax, ay, ω]``: CV ``p + v τ``; CA ``p + v τ + a τ²/2``, ``v + a τ``; CT
    ``p + τ (S(ωτ) v + C(ωτ) J v)`` and ``v`` turned by ``ωτ`` (J: a quarter turn left; S, C finite at ω = 0,
    :func:`swarmtrack.models.ct.turn_terms`)."""
    if model not in KINEMATIC:
        raise ValueError(f"unknown kinematic model {model!r}; expected one of {KINEMATIC}")
    p, v = state[:, None, :2], state[:, None, 2:4]
    t = np.asarray(tau, dtype=float)[None, :, None]  # (1, H, 1)
    if model == "cv":
        return np.concatenate([p + v * t, np.broadcast_to(v, p.shape[:1] + t.shape[1:2] + (2,))], axis=-1)
    if model == "ca":
        a = motion[:, None, :2]
        return np.concatenate([p + v * t + 0.5 * a * t * t, v + a * t], axis=-1)
    angle = motion[:, None, 2:3] * t  # (N, H, 1)
    S, C = turn_terms(angle, derivatives=False)
    left = np.stack([-v[..., 1], v[..., 0]], axis=-1)  # J v
    cos, sin = np.cos(angle), np.sin(angle)
    return np.concatenate([p + t * (S * v + C * left), cos * v + sin * left], axis=-1)
