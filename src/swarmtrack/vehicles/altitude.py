"""The altitude channel of a 3-D world: every object's height ``z``, climb rate ``vz`` and the vertical acceleration
its thrust achieves, ``az``, stepped beside its planar state (issue 28: vehicles that move in altitude).

State ``(M, 3)`` = ``[z, vz, az]``. Each object takes a commanded vertical acceleration ``a`` (m/s², up):

* a **quadrotor**'s collective thrust follows its command through the motors' first-order lag ``τ`` (the PX4 SITL
  Gazebo ``iris`` motor model's ``timeConstantUp`` = 0.0125 s, :data:`QUADROTOR_THRUST_LAG`), and can give at most
  ``max_thrust/m − g`` up and ``g`` down (no thrust): ``az' = az + (dt/τ)(clip(a) − az)``;
* a **double integrator** achieves its command at once (``τ = 0``): ``az' = a``;

then semi-implicit Euler, as the planar vehicles: ``vz' = vz + dt·az'``, ``z' = z + dt·vz'``.

**Decoupled from the planar motion (our choice).** The planar quadrotor holds its altitude with the thrust
``m·g/(cos φ cos θ)`` (:mod:`swarmtrack.vehicles.quadrotor`); a climb of ``az`` would take ``m·(g + az)/(cos φ
cos θ)`` and tilt the horizontal acceleration by ``1 + az/g``. That coupling is left out: the targets' and UAVs'
vertical accelerations stay below 1 m/s², a tenth of ``g``, and the planar dynamics, the identified MPC models and
every planar recording stay exactly as they are.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

STATE_DIM = 3
Z, VZ, AZ = range(3)
#: The quadrotor's thrust lag, s: the ``iris`` motor's ``timeConstantUp`` in PX4-SITL_gazebo's ``iris.sdf``.
QUADROTOR_THRUST_LAG = 0.0125


def initial_state(z0) -> np.ndarray:
    """``(M, 3)`` objects at heights ``z0`` (M,), at rest vertically."""
    z0 = np.asarray(z0, dtype=float).reshape(-1)
    out = np.zeros((len(z0), STATE_DIM))
    out[:, Z] = z0
    return out


def step(state: np.ndarray, accel: np.ndarray, dt: float, lag: np.ndarray, up: np.ndarray,
         down: np.ndarray) -> np.ndarray:
    """Advance every object's altitude by ``dt`` (module docstring); returns a new ``(M, 3)`` array.

    ``accel`` (M,) the commanded vertical accelerations, ``lag`` (M,) each object's thrust lag ``τ`` (0: none),
    ``up`` and ``down`` (M,) the largest vertical acceleration it can give up and down (``inf``: unlimited). A lag
    shorter than ``dt`` is stepped as reached (``dt/τ`` capped at 1)."""
    state = np.asarray(state, dtype=float)
    a = np.clip(np.asarray(accel, dtype=float), -down, up)
    rate = np.minimum(1.0, dt / np.maximum(lag, 1e-300))
    out = np.empty_like(state)
    out[:, AZ] = np.where(lag > 0.0, state[:, AZ] + rate * (a - state[:, AZ]), a)
    out[:, VZ] = state[:, VZ] + dt * out[:, AZ]
    out[:, Z] = state[:, Z] + dt * out[:, VZ]
    return out


def hold(state: np.ndarray, z_ref: np.ndarray, kp: float, kd: float) -> np.ndarray:
    """A UAV's altitude hold: the PD command ``kp·(z_ref − z) − kd·vz`` (M,) towards ``z_ref`` (M,)."""
    return kp * (np.asarray(z_ref, dtype=float) - state[:, Z]) - kd * state[:, VZ]


@dataclass(frozen=True)
class GroupAltitude:
    """A group's altitude channel: its members' start heights ``z0`` (n,), their thrust lag ``lag`` (s; 0: a double
    integrator), the largest vertical accelerations ``up`` and ``down`` (m/s²), and, for a group commanded onboard
    (the UAVs), the heights ``hold`` (n,) its autopilots keep with the PD gains ``kp`` (s⁻²), ``kd`` (s⁻¹). A group
    flying velocity profiles climbs as its profiles say (``VelocityProfile.vertical_velocity``)."""

    z0: np.ndarray
    lag: float = 0.0
    up: float = np.inf
    down: float = np.inf
    hold: np.ndarray | None = None
    kp: float = 1.44
    kd: float = 2.16

    @classmethod
    def quadrotor(cls, z0, mass: float, g: float, max_thrust: float, hold=None, **gains) -> GroupAltitude:
        """Quadrotors: the iris motors' lag, up to ``max_thrust/m − g`` up and ``g`` down (no thrust)."""
        return cls(np.asarray(z0, dtype=float), QUADROTOR_THRUST_LAG, max_thrust / mass - g, g,
                   None if hold is None else np.asarray(hold, dtype=float), **gains)
