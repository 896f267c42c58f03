"""Constant-acceleration (CA) target model, W20 eq. 2.38."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from swarmtrack.models.base import LinearMotionModel


@dataclass(frozen=True)
class ConstantAcceleration(LinearMotionModel):
    """Nearly-constant-acceleration model, state ``[x, y, vx, vy, ax, ay]`` (W20 eq. 2.38).

    ``p' = p + T v + T²/2 a``, ``v' = v + T a``, ``a' = a``.
    """

    name: str = "ca"
    state_names: tuple[str, ...] = ("x", "y", "vx", "vy", "ax", "ay")
    linear: bool = True
    hidden_prior_std: tuple[float, ...] = (3.0, 3.0)  # acceleration, m/s²

    @functools.cached_property
    def F(self) -> np.ndarray:
        T = float(self.dt)
        F = np.eye(6)
        F[0, 2] = F[1, 3] = T
        F[2, 4] = F[3, 5] = T
        F[0, 4] = F[1, 5] = 0.5 * T * T
        F.flags.writeable = False  # made once, shared
        return F
