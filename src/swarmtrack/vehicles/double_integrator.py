"""Planar double integrator ``q̇ = p``, ``ṗ = u`` (L24 Sec. 2; L23 Sec. 2): the flocking agents' model.

State ``(M, 4)`` = ``[x, y, vx, vy]``; integrated for all ``M`` agents at once with semi-implicit Euler
(velocity first, then the position from the new velocity). For a constant acceleration ``a`` the velocity
is exact and the position after ``n`` steps exceeds the exact ``q0 + p0·t + a·t²/2`` by ``a·dt·t/2``.
"""

from __future__ import annotations

import numpy as np

STATE_DIM = 4


def clip_norm(accel, limit: float) -> np.ndarray:
    """Scale each row of ``accel`` ``(M, 2)`` down so that its Euclidean norm is at most ``limit``."""
    accel = np.asarray(accel, dtype=float)
    n2 = np.einsum("ij,ij->i", accel, accel)
    scale = limit / np.sqrt(np.maximum(n2, limit * limit))
    return accel * scale[:, None]


def step(state, accel, dt: float, accel_limit: float | None = None) -> np.ndarray:
    """Advance ``M`` double integrators by ``dt``; returns a new ``(M, 4)`` array.

    If ``accel_limit`` is given, the acceleration *vector* of each agent is clipped in norm (its
    direction is kept), not per axis.
    """
    state = np.asarray(state, dtype=float)
    u = clip_norm(accel, accel_limit) if accel_limit is not None else np.asarray(accel, dtype=float)
    out = np.empty_like(state)
    v_new = out[:, 2:4]
    np.multiply(u, dt, out=v_new)
    v_new += state[:, 2:4]
    q_new = out[:, 0:2]
    np.multiply(v_new, dt, out=q_new)
    q_new += state[:, 0:2]
    return out
