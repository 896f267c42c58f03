"""Full-state (FS) quadrotor target model, L24 Sec. 3.1 (corrected, see SPEC "Known typos").

State (12): ``[x, y, vx, vy, vz, phi, theta, phi_dot, theta_dot, U_phi, U_theta, T]``; Euler integration::

    x' = x + dt·vx                         y' = y + dt·vy
    vx' = vx + dt·(T/m)·sin θ              vy' = vy − dt·(T/m)·sin φ·cos θ
    vz' = vz + dt·(−g + cos φ·cos θ·T/m)
    φ' = φ + dt·φ̇                          θ' = θ + dt·θ̇
    φ̇' = φ̇ + dt·Uφ/Ixx                     θ̇' = θ̇ + dt·Uθ/Iyy
    Uφ' = Uφ,  Uθ' = Uθ,  T' = T

L24 appends a fake measurement ``vz = 0`` to every observation so the thrust estimate converges to hover;
:data:`VZ_INDEX` is the state it observes.

Default physical parameters are those of the PX4 SITL Gazebo "iris" model (``iris.sdf`` in
PX4-SITL_gazebo: base_link mass 1.5 kg, ixx = iyy = 0.029125 kg·m²), rounded as in SPEC to
mass = 1.5 kg and Ixx = Iyy = 0.029 kg·m².
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from swarmtrack.models.base import MotionModel

#: Index of the vertical velocity, observed by L24's fake ``vz = 0`` measurement.
VZ_INDEX = 4

# State indices.
_X, _Y, _VX, _VY, _VZ, _PHI, _THETA, _PHID, _THETAD, _UPHI, _UTHETA, _T = range(12)


@dataclass(frozen=True)
class FullStateQuadrotor(MotionModel):
    """Quadrotor inner-loop model with unknown moments and thrust (L24 Sec. 3.1, corrected).

    ``mass`` [kg], ``Ixx``/``Iyy`` [kg·m²] default to the PX4 SITL Gazebo "iris" (mass 1.5 kg,
    ixx = iyy = 0.029125 kg·m²); ``g`` [m/s²].
    """

    name: str = "fs"
    state_names: tuple[str, ...] = (
        "x",
        "y",
        "vx",
        "vy",
        "vz",
        "phi",
        "theta",
        "phi_dot",
        "theta_dot",
        "U_phi",
        "U_theta",
        "T",
    )
    linear: bool = False
    # vz, roll, pitch (rad), their rates (rad/s), moments (N m), thrust (N, about the hover m·g)
    hidden_prior_std: tuple[float, ...] = (0.5, 0.3, 0.3, 1.0, 1.0, 0.1, 0.1, 3.0)
    mass: float = 1.5
    Ixx: float = 0.029
    Iyy: float = 0.029
    g: float = 9.81

    VZ_INDEX = VZ_INDEX  # class attribute (not a dataclass field: no annotation)

    def __post_init__(self) -> None:
        for pname in ("mass", "Ixx", "Iyy", "g"):
            v = getattr(self, pname)
            if not (isinstance(v, int | float | np.floating | np.integer) and math.isfinite(v) and v > 0):
                raise ValueError(f"FullStateQuadrotor: {pname} must be a finite positive number, got {v!r}")

    def initial_state(self) -> np.ndarray:
        """Zeros except the thrust, set to hover ``T = m·g``."""
        x0 = np.zeros(self.dim)
        x0[_T] = self.mass * self.g
        return x0

    def f(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        dt, m = float(self.dt), float(self.mass)
        phi, theta, thrust = x[..., _PHI], x[..., _THETA], x[..., _T]
        sphi, cphi, sth, cth = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
        out = x.copy()
        out[..., _X] += dt * x[..., _VX]
        out[..., _Y] += dt * x[..., _VY]
        out[..., _VX] += dt * thrust / m * sth
        out[..., _VY] -= dt * thrust / m * sphi * cth
        out[..., _VZ] += dt * (-self.g + cphi * cth * thrust / m)
        out[..., _PHI] += dt * x[..., _PHID]
        out[..., _THETA] += dt * x[..., _THETAD]
        out[..., _PHID] += dt * x[..., _UPHI] / self.Ixx
        out[..., _THETAD] += dt * x[..., _UTHETA] / self.Iyy
        return out

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        dt, m = float(self.dt), float(self.mass)
        phi, theta, thrust = x[..., _PHI], x[..., _THETA], x[..., _T]
        sphi, cphi, sth, cth = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
        J = np.zeros(x.shape[:-1] + (12, 12))
        idx = np.arange(12)
        J[..., idx, idx] = 1.0
        J[..., _X, _VX] = dt
        J[..., _Y, _VY] = dt
        J[..., _VX, _THETA] = dt * thrust / m * cth
        J[..., _VX, _T] = dt / m * sth
        J[..., _VY, _PHI] = -dt * thrust / m * cphi * cth
        J[..., _VY, _THETA] = dt * thrust / m * sphi * sth
        J[..., _VY, _T] = -dt / m * sphi * cth
        J[..., _VZ, _PHI] = -dt * thrust / m * sphi * cth
        J[..., _VZ, _THETA] = -dt * thrust / m * cphi * sth
        J[..., _VZ, _T] = dt / m * cphi * cth
        J[..., _PHI, _PHID] = dt
        J[..., _THETA, _THETAD] = dt
        J[..., _PHID, _UPHI] = dt / self.Ixx
        J[..., _THETAD, _UTHETA] = dt / self.Iyy
        return J
