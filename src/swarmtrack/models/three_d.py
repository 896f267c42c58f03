"""Target models in three dimensions: a planar model with the altitude added (L24 Sec. 6's outlook, "a target
moving in a three-dimensional environment").

Each 3-D model is its planar counterpart on the horizontal states and a kinematic model of the altitude:

* ``cv3d``: CV (L24 eq. 5) and CV in altitude, ``[x, y, vx, vy, z, vz]``;
* ``ca3d``: CA (W20 eq. 2.38) and CA in altitude, ``[x, y, vx, vy, z, vz, ax, ay, az]``;
* ``ct3d``: CT (L24 Sec. 3.1, corrected) turning in the horizontal plane and CV in altitude (the coordinated turn of
  Stone Soup's and Bar-Shalom's 3-D CT), ``[x, y, vx, vy, z, vz, ω]``;
* ``fs3d``: the FS quadrotor (L24 Sec. 3.1) with its altitude, ``[x, y, vx, vy, z, vz, φ, θ, …, T]``
  (:class:`FullStateQuadrotor3D`: its vertical motion is the thrust's, so not a separate block).

Every 3-D model starts with the common block ``[x, y, vx, vy, z, vz]`` (:data:`COMMON_3D`): its first four states
are the planar models' ``[x, y, vx, vy]`` (:mod:`swarmtrack.models.base`), so the planar code reads a 3-D estimate
unchanged, and the fusion of models of different sizes (IMM mixing, W20's model fusion) works on a leading block as
in the plane. The hidden states follow: the planar model's, then the altitude's. The two blocks are decoupled:
``f`` and the Jacobian are block diagonal (on :attr:`AltitudeModel.planar_index` and
:attr:`AltitudeModel.vertical_index`), the planar block is computed by the planar model itself (so a 3-D model
predicts its horizontal states bit for bit as the planar one), and ``Q`` may not couple them.
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
from swarmtrack.models.fs import FullStateQuadrotor

#: The common block of every 3-D model, ``[x, y, vx, vy, z, vz]``: its size and the index of ``z``.
COMMON_3D = 6
ALTITUDE = 4


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
        Q = np.asarray(self.Q)
        if Q.shape != (self.dim, self.dim):
            raise ValueError(f"{self.name}: Q must be {self.dim} x {self.dim}, got {Q.shape}")
        if np.any(Q[np.ix_(self.planar_index, self.vertical_index)]):
            raise ValueError(f"{self.name}: Q couples the horizontal and the altitude states; the blocks are "
                             "decoupled")

    @property
    def planar_dim(self) -> int:
        return len(self.planar_class.state_names)

    @property
    def altitude_index(self) -> int:
        """Index of ``z`` in the state (``vz`` follows it)."""
        return ALTITUDE

    @functools.cached_property
    def planar_index(self) -> np.ndarray:
        """The planar model's states in this one: ``[x, y, vx, vy]`` and its hidden states after the common block."""
        return np.r_[0:4, COMMON_3D:COMMON_3D + self.planar_dim - 4]

    @functools.cached_property
    def vertical_index(self) -> np.ndarray:
        """The altitude block's states: ``z, vz`` and, for CA, ``az`` last."""
        return np.r_[ALTITUDE, ALTITUDE + 1, COMMON_3D + self.planar_dim - 4:self.dim]

    @functools.cached_property
    def planar(self) -> MotionModel:
        """The planar model of the horizontal block, with that block of ``Q``."""
        Q = np.array(np.asarray(self.Q)[np.ix_(self.planar_index, self.planar_index)])
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
        F = np.zeros((self.dim, self.dim))
        F[np.ix_(self.planar_index, self.planar_index)] = self.planar.F  # type: ignore[attr-defined]  # a linear planar model (CV, CA)
        F[np.ix_(self.vertical_index, self.vertical_index)] = self.vertical_F
        F.flags.writeable = False
        return F

    def f(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        out = np.empty_like(x)
        out[..., self.planar_index] = self.planar.f(x[..., self.planar_index])
        out[..., self.vertical_index] = x[..., self.vertical_index] @ self.vertical_F.T
        return out

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Block diagonal: the planar model's analytic Jacobian and the altitude block's constant transition."""
        x = np.asarray(x, dtype=float)
        J = np.zeros(x.shape[:-1] + (self.dim, self.dim))
        p, v = self.planar_index, self.vertical_index
        J[..., p[:, None], p[None, :]] = self.planar.jacobian(x[..., p])
        J[..., v[:, None], v[None, :]] = self.vertical_F
        return J

    def initial_information_diagonal(self, information: float) -> np.ndarray:
        """The planar model's diagonal on its states (its hidden ones at their prior), ``information`` on ``z`` and
        ``vz``, and the planar acceleration prior on a CA's vertical acceleration."""
        diag = np.full(self.dim, float(information))
        diag[self.planar_index] = self.planar.initial_information_diagonal(information)
        if self.vertical_order == 2:
            diag[-1] = 1.0 / self.planar.hidden_prior_std[0] ** 2
        return diag

    def initial_state(self) -> np.ndarray:
        x0 = np.zeros(self.dim)
        x0[self.planar_index] = self.planar.initial_state()
        return x0


@dataclass(frozen=True)
class ConstantVelocity3D(AltitudeModel):
    """CV in 3-D, state ``[x, y, vx, vy, z, vz]`` (L24 eq. 5 on each axis)."""

    planar_class: ClassVar[type[MotionModel]] = ConstantVelocity
    vertical_order: ClassVar[int] = 1
    name: str = "cv3d"
    state_names: tuple[str, ...] = ConstantVelocity.state_names + ("z", "vz")
    linear: bool = True


@dataclass(frozen=True)
class ConstantAcceleration3D(AltitudeModel):
    """CA in 3-D, state ``[x, y, vx, vy, z, vz, ax, ay, az]`` (W20 eq. 2.38 on each axis)."""

    planar_class: ClassVar[type[MotionModel]] = ConstantAcceleration
    vertical_order: ClassVar[int] = 2
    name: str = "ca3d"
    state_names: tuple[str, ...] = ("x", "y", "vx", "vy", "z", "vz", "ax", "ay", "az")
    linear: bool = True
    hidden_prior_std: tuple[float, ...] = ConstantAcceleration.hidden_prior_std


@dataclass(frozen=True)
class ConstantTurn3D(AltitudeModel):
    """CT in the horizontal plane with CV in altitude, state ``[x, y, vx, vy, z, vz, ω]``; exact at ω = 0 as the
    planar CT (:mod:`swarmtrack.models.ct`)."""

    planar_class: ClassVar[type[MotionModel]] = ConstantTurn
    vertical_order: ClassVar[int] = 1
    name: str = "ct3d"
    state_names: tuple[str, ...] = ("x", "y", "vx", "vy", "z", "vz", "omega")
    linear: bool = False
    hidden_prior_std: tuple[float, ...] = ConstantTurn.hidden_prior_std


#: The 3-D FS model's states in the planar FS's order (every state but ``z``).
_FS_STATES = np.r_[0:ALTITUDE, ALTITUDE + 1:13]


@dataclass(frozen=True)
class FullStateQuadrotor3D(MotionModel):
    """The FS quadrotor (:class:`~swarmtrack.models.fs.FullStateQuadrotor`, L24 Sec. 3.1) with its altitude, state
    ``[x, y, vx, vy, z, vz, φ, θ, φ̇, θ̇, Uφ, Uθ, T]``: the planar FS already carries ``vz`` (L24 holds it at zero by a
    fake measurement, the target being planar); here ``z' = z + dt·vz`` (its Euler step, as FS's ``x``) and a real
    altitude measurement observes it. Not block diagonal: FS's ``vz`` depends on the attitude and the thrust. The
    other twelve states are predicted by the planar FS itself, bit for bit."""

    name: str = "fs3d"
    state_names: tuple[str, ...] = ("x", "y", "vx", "vy", "z", "vz", "phi", "theta", "phi_dot", "theta_dot",
                                    "U_phi", "U_theta", "T")
    linear: bool = False
    hidden_prior_std: tuple[float, ...] = FullStateQuadrotor.hidden_prior_std[1:]  # FS's, but vz's (common here)
    mass: float = 1.5
    Ixx: float = 0.029
    Iyy: float = 0.029
    g: float = 9.81

    @functools.cached_property
    def planar(self) -> FullStateQuadrotor:
        Q = np.array(np.asarray(self.Q)[np.ix_(_FS_STATES, _FS_STATES)])
        Q.flags.writeable = False
        return FullStateQuadrotor(dt=self.dt, Q=Q, mass=self.mass, Ixx=self.Ixx, Iyy=self.Iyy, g=self.g)

    def __post_init__(self) -> None:
        self.planar  # noqa: B018 - validates the physical parameters

    @property
    def altitude_index(self) -> int:
        return ALTITUDE

    def f(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        out = np.empty_like(x)
        out[..., _FS_STATES] = self.planar.f(x[..., _FS_STATES])
        out[..., ALTITUDE] = x[..., ALTITUDE] + self.dt * x[..., ALTITUDE + 1]
        return out

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        J = np.zeros(x.shape[:-1] + (13, 13))
        J[..., _FS_STATES[:, None], _FS_STATES[None, :]] = self.planar.jacobian(x[..., _FS_STATES])
        J[..., ALTITUDE, ALTITUDE] = 1.0
        J[..., ALTITUDE, ALTITUDE + 1] = self.dt
        return J

    def initial_information_diagonal(self, information: float) -> np.ndarray:
        """``information`` on the common block (``vz`` too: the altitude measurement observes it), FS's priors on the
        attitude, rates, moments and thrust."""
        diag = np.full(self.dim, float(information))
        diag[COMMON_3D:] = 1.0 / np.square(self.hidden_prior_std)
        return diag

    def initial_state(self) -> np.ndarray:
        """Zeros except the thrust, at hover ``m·g`` (as FS)."""
        x0 = np.zeros(13)
        x0[-1] = self.mass * self.g
        return x0
