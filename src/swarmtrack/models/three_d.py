"""Target models in three dimensions: a planar model with the altitude appended (L24 Sec. 6's outlook, "a target
moving in a three-dimensional environment").

Each 3-D model is its planar counterpart on the horizontal states followed by a kinematic model of the altitude:

* ``cv3d``: CV ``[x, y, vx, vy]`` (L24 eq. 5) and CV in altitude ``[z, vz]``;
* ``ca3d``: CA ``[x, y, vx, vy, ax, ay]`` (W20 eq. 2.38) and CA in altitude ``[z, vz, az]``;
* ``ct3d``: CT ``[x, y, vx, vy, ω]`` (L24 Sec. 3.1, corrected) turning in the horizontal plane, and CV in altitude
  ``[z, vz]`` (the coordinated turn of Stone Soup's and Bar-Shalom's 3-D CT).

The horizontal states come first and in the planar order, so the first four are ``[x, y, vx, vy]`` as in every
model (:mod:`swarmtrack.models.base`) and the planar code reads a 3-D estimate unchanged; the altitude states come
last. The two blocks are decoupled: ``f`` and the Jacobian are block diagonal, the planar block is computed by the
planar model itself (so a 3-D model predicts its horizontal states bit for bit as the planar one), and ``Q`` is
taken block diagonal. With Stone Soup's interleaved order ``[x, vx, y, vy, …, z, vz]`` the states map by the same
permutation as the planar models (:func:`swarmtrack.interop.stonesoup_models.permutation`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from swarmtrack.models.base import MotionModel
from swarmtrack.models.ca import ConstantAcceleration
from swarmtrack.models.ct import ConstantTurn
from swarmtrack.models.cv import ConstantVelocity

#: The altitude states of each vertical order: 1 for CV ``[z, vz]``, 2 for CA ``[z, vz, az]``.
VERTICAL_STATES = {1: ("z", "vz"), 2: ("z", "vz", "az")}


def vertical_transition(dt: float, order: int) -> np.ndarray:
    """The altitude block's transition: CV ``[[1, T], [0, 1]]`` or CA with ``z' = z + T vz + T²/2 az`` (the planar
    models' rows, W20 eqs. 2.37-2.38, on one axis)."""
    T = float(dt)
    if order == 1:
        return np.array([[1.0, T], [0.0, 1.0]])
    return np.array([[1.0, T, 0.5 * T * T], [0.0, 1.0, T], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class AltitudeModel(MotionModel):
    """A planar model (:attr:`planar_class`) with a kinematic altitude block of :attr:`vertical_order` appended
    (module docstring). ``Q`` is the whole model's; its off-diagonal blocks between the planar and the altitude
    states must be zero (they are for ``Q = diag(q)``)."""

    planar_class: ClassVar[type[MotionModel]]
    vertical_order: ClassVar[int]

    def __post_init__(self) -> None:
        n = self.planar_dim
        Q = np.asarray(self.Q)
        if Q.shape != (self.dim, self.dim):
            raise ValueError(f"{self.name}: Q must be {self.dim} x {self.dim}, got {Q.shape}")
        if np.any(Q[:n, n:]) or np.any(Q[n:, :n]):
            raise ValueError(f"{self.name}: Q couples the horizontal and the altitude states; the blocks are "
                             "decoupled")

    @property
    def planar_dim(self) -> int:
        return len(self.planar_class.state_names)

    @property
    def altitude_index(self) -> int:
        """Index of ``z`` in the state (``vz`` follows it)."""
        return self.planar_dim

    @functools.cached_property
    def planar(self) -> MotionModel:
        """The planar model of the horizontal block, with that block of ``Q``."""
        n = self.planar_dim
        Q = np.array(np.asarray(self.Q)[:n, :n])
        Q.flags.writeable = False
        return self.planar_class(dt=self.dt, Q=Q)

    @functools.cached_property
    def vertical_F(self) -> np.ndarray:
        F = vertical_transition(self.dt, self.vertical_order)
        F.flags.writeable = False
        return F

    @functools.cached_property
    def F(self) -> np.ndarray:
        """The constant transition of a linear model (CV, CA): the planar ``F`` and the altitude block."""
        n = self.planar_dim
        F = np.zeros((self.dim, self.dim))
        F[:n, :n] = self.planar.F
        F[n:, n:] = self.vertical_F
        F.flags.writeable = False
        return F

    def f(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        n = self.planar_dim
        return np.concatenate([self.planar.f(x[..., :n]), x[..., n:] @ self.vertical_F.T], axis=-1)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Block diagonal: the planar model's analytic Jacobian and the altitude block's constant transition."""
        x = np.asarray(x, dtype=float)
        n = self.planar_dim
        J = np.zeros(x.shape[:-1] + (self.dim, self.dim))
        J[..., :n, :n] = self.planar.jacobian(x[..., :n])
        J[..., n:, n:] = self.vertical_F
        return J

    def initial_information_diagonal(self, information: float) -> np.ndarray:
        """The planar model's diagonal (its hidden states at their prior), ``information`` on the altitude's
        position and velocity, and the planar acceleration prior on a CA's vertical acceleration."""
        extra = np.full(self.dim - self.planar_dim, float(information))
        if self.vertical_order == 2:
            extra[2] = 1.0 / self.planar.hidden_prior_std[0] ** 2
        return np.concatenate([self.planar.initial_information_diagonal(information), extra])

    def initial_state(self) -> np.ndarray:
        return np.concatenate([self.planar.initial_state(), np.zeros(self.dim - self.planar_dim)])


@dataclass(frozen=True)
class ConstantVelocity3D(AltitudeModel):
    """CV in 3-D, state ``[x, y, vx, vy, z, vz]`` (L24 eq. 5 on each axis)."""

    planar_class: ClassVar[type[MotionModel]] = ConstantVelocity
    vertical_order: ClassVar[int] = 1
    name: str = "cv3d"
    state_names: tuple[str, ...] = ConstantVelocity.state_names + VERTICAL_STATES[1]
    linear: bool = True


@dataclass(frozen=True)
class ConstantAcceleration3D(AltitudeModel):
    """CA in 3-D, state ``[x, y, vx, vy, ax, ay, z, vz, az]`` (W20 eq. 2.38 on each axis)."""

    planar_class: ClassVar[type[MotionModel]] = ConstantAcceleration
    vertical_order: ClassVar[int] = 2
    name: str = "ca3d"
    state_names: tuple[str, ...] = ConstantAcceleration.state_names + VERTICAL_STATES[2]
    linear: bool = True
    hidden_prior_std: tuple[float, ...] = ConstantAcceleration.hidden_prior_std


@dataclass(frozen=True)
class ConstantTurn3D(AltitudeModel):
    """CT in the horizontal plane with CV in altitude, state ``[x, y, vx, vy, ω, z, vz]``; exact at ω = 0 as the
    planar CT (:mod:`swarmtrack.models.ct`)."""

    planar_class: ClassVar[type[MotionModel]] = ConstantTurn
    vertical_order: ClassVar[int] = 1
    name: str = "ct3d"
    state_names: tuple[str, ...] = ConstantTurn.state_names + VERTICAL_STATES[1]
    linear: bool = False
    hidden_prior_std: tuple[float, ...] = ConstantTurn.hidden_prior_std
