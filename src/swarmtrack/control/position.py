"""The UAV's own position controller: it flies to a position setpoint (W20 Sec. 5.3.2, the "high level position
controller" whose input the MPC chooses).

W20 used the position controllers of V-REP's quadrotor and of the AscTec Pelican and gives neither law nor gains.
Ours is a PD law on the navigation solution, ``a = kp (s − p) − kd v``, norm-clipped to ``accel_limit``, turned
into attitude by the quadrotor's inner loop (:mod:`swarmtrack.vehicles.quadrotor`). Gains (chosen): natural
frequency 1.2 rad/s and damping 0.9 (``kp = 1.44 s⁻²``, ``kd = 2.16 s⁻¹``), acceleration limit 3 m/s² (a 17° tilt):
a 1 m step settles in about 4 s without saturating, the second-order behaviour W20 identifies (Sec. 5.4.1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PositionGains:
    """``kp`` s⁻², ``kd`` s⁻¹, ``accel_limit`` m/s² (norm clip on the commanded acceleration)."""

    kp: float = 1.44
    kd: float = 2.16
    accel_limit: float = 3.0

    def __post_init__(self) -> None:
        if not (self.kp > 0 and self.kd > 0 and self.accel_limit > 0):
            raise ValueError(f"position gains must be positive, got kp={self.kp}, kd={self.kd}, "
                             f"accel_limit={self.accel_limit}")


def position_control(setpoint: np.ndarray, nav: np.ndarray, gains: PositionGains) -> np.ndarray:
    """Acceleration commands (N, 2) that fly each UAV from its navigation state ``nav`` (N, 4) ``[x, y, vx, vy]``
    to its ``setpoint`` (N, 2): ``kp (s − p) − kd v``, each row scaled down to norm ``accel_limit``."""
    a = gains.kp * (setpoint - nav[:, :2]) - gains.kd * nav[:, 2:4]
    norm = np.sqrt(np.einsum("ij,ij->i", a, a))
    return a * (gains.accel_limit / np.maximum(norm, gains.accel_limit))[:, None]
