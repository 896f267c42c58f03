"""True vehicle dynamics the world integrates (batched over vehicles): quadrotor, double integrator,
and the velocity profiles the target flies (L24 Sec. 2 and Sec. 4; SPEC.md Capability 1), including a ground
robot's CV/CA/CT segments (W20 Ch. 4).

This package depends on nothing else in swarmtrack (in particular not on ``swarmtrack.sim`` or
``swarmtrack.estimation``). :mod:`swarmtrack.vehicles.kernels` is the compiled (numba) fast path of the
physics; it is not imported here, so using the reference does not pay for importing numba.
"""

from . import double_integrator, profile, quadrotor
from .profile import (
    Phase,
    Segment,
    VelocityProfile,
    evasive_segments,
    ground_robot_profile,
    l23_profile,
    l24_profile,
)
from .quadrotor import (
    QuadrotorParams,
    achieved_acceleration,
    hover_state,
    velocity_tracking_accel,
)

__all__ = [
    "Phase",
    "QuadrotorParams",
    "Segment",
    "VelocityProfile",
    "achieved_acceleration",
    "double_integrator",
    "evasive_segments",
    "ground_robot_profile",
    "hover_state",
    "l23_profile",
    "l24_profile",
    "profile",
    "quadrotor",
    "velocity_tracking_accel",
]
