"""Constant-velocity (CV) target model, L24 Sec. 3.1 eq. 5 / W20 eq. 2.37."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from swarmtrack.models.base import LinearMotionModel


@dataclass(frozen=True)
class ConstantVelocity(LinearMotionModel):
    """Nearly-constant-velocity model, state ``[x, y, vx, vy]``.

    ``x' = x + T vx``, ``y' = y + T vy``, velocities constant (L24 Sec. 3.1 eq. 5, W20 eq. 2.37).
    """

    name: str = "cv"
    state_names: tuple[str, ...] = ("x", "y", "vx", "vy")
    linear: bool = True

    @functools.cached_property
    def F(self) -> np.ndarray:
        T = float(self.dt)
        F = np.eye(4)
        F[0, 2] = F[1, 3] = T
        F.flags.writeable = False  # made once, shared
        return F
