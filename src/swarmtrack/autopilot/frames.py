"""The project's frame and MAVLink's.

swarmtrack's world frame is **ENU**: x east, y north, z up; a heading is measured from east, counter-clockwise
(``atan2(vy, vx)``). PX4 and ArduPilot's local frame (``MAV_FRAME_LOCAL_NED``, ``LOCAL_POSITION_NED``,
``SET_POSITION_TARGET_LOCAL_NED``) is **NED**: x north, y east, z down; yaw is measured from north, clockwise, and
body axes are forward-right-down (``ATTITUDE``: roll about forward, pitch about right).

Between the two, a vector (position, velocity, acceleration) swaps its first two components and negates the third:
``(e, n, u) ↔ (n, e, −d)``. The map is its own inverse. A heading maps as ``ψ_ned = π/2 − ψ_enu`` (wrapped to
(−π, π]), also its own inverse. Both frames share their origin (the autopilot's local origin is the world's).
"""

from __future__ import annotations

import numpy as np


def enu_to_ned(v) -> np.ndarray:
    """Vectors ``(..., 3)`` (or planar ``(..., 2)``: east, north ↔ north, east) from ENU to NED; the inverse too."""
    v = np.asarray(v, dtype=float)
    out = v[..., [1, 0, *range(2, v.shape[-1])]].copy()
    if v.shape[-1] > 2:
        out[..., 2] = -out[..., 2]
    return out


ned_to_enu = enu_to_ned


def wrap(angle) -> np.ndarray:
    """Angles wrapped to (−π, π]."""
    a = np.mod(np.asarray(angle, dtype=float) + np.pi, 2 * np.pi) - np.pi
    return np.where(a == -np.pi, np.pi, a)


def yaw_enu_to_ned(psi) -> np.ndarray:
    """A heading from ENU's convention (from east, counter-clockwise) to NED's (from north, clockwise); the inverse
    too."""
    return wrap(np.pi / 2 - np.asarray(psi, dtype=float))


yaw_ned_to_enu = yaw_enu_to_ned
