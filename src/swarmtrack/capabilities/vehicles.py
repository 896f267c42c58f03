"""The built-in vehicle kinds (:class:`~swarmtrack.vehicles.base.Vehicle`), registered once each.

=====================  ==========================================================================================
``quadrotor``          Iris-like quadrotor, attitude loop and tilt limits (L24 Sec. 3.1; L23), the default; the
                       swarm's ``quadrotor`` section sets its attitude limits (W20 Sec. 5.4.2's 5° per axis)
``double_integrator``  planar double integrator, the flocking agents' model (L24 Sec. 2; L23 Sec. 2)
``walker``             IB21 Sec. 6's ground targets and decoys: constant speed, random-walk yaw rate, kept in the
                       area by reflection (:mod:`swarmtrack.vehicles.ground_walker`); groups only
``nearly_cv``          issue 40's box targets: nearly constant velocity (white-noise acceleration), reflected at the
                       area's border (:mod:`swarmtrack.vehicles.nearly_cv`); groups only
``fixed_wing``         IB21 Sec. 6's UAV at constant speed and altitude, steered by its yaw acceleration
                       (:mod:`swarmtrack.vehicles.fixed_wing`); the swarm only
=====================  ==========================================================================================

The kinematic modules are named, not imported, so that validating a scenario does not import them (or numba).
"""

from __future__ import annotations

from swarmtrack import registry
from swarmtrack.vehicles.base import Vehicle


def walker_params(spec):
    """A walker group's :class:`~swarmtrack.vehicles.ground_walker.WalkerParams` from its section (IB21 Sec. 6)."""
    from swarmtrack.vehicles.ground_walker import WalkerParams

    return WalkerParams(spec.speed, spec.yaw_accel_bound, tuple(spec.area))


def nearly_cv_params(spec):
    """A nearly-constant-velocity group's :class:`~swarmtrack.vehicles.nearly_cv.NearlyCVParams` (issue 40)."""
    from swarmtrack.vehicles.nearly_cv import NearlyCVParams

    return NearlyCVParams(spec.speed, spec.accel_noise, tuple(spec.area))


def fixed_wing_params(spec):
    """The swarm's :class:`~swarmtrack.vehicles.fixed_wing.FixedWingParams` from its ``fixed_wing`` section."""
    from swarmtrack.vehicles.fixed_wing import FixedWingParams

    f = spec.fixed_wing
    return FixedWingParams(f.speed, f.altitude, f.yaw_rate_max)


def quadrotor_params(spec):
    """The swarm's :class:`~swarmtrack.vehicles.quadrotor.QuadrotorParams` from its ``quadrotor`` section (attitude
    limits: ``max_tilt``, and W20 Sec. 5.4.2's per-axis ``max_roll_pitch``); a group's section has none: the defaults.
    Returns None when every limit is at its default, so a world of default quadrotors is built as before."""
    q = getattr(spec, "quadrotor", None)
    if q is None:
        return None
    from swarmtrack.vehicles.quadrotor import DEFAULT_PARAMS, QuadrotorParams

    params = QuadrotorParams(max_tilt=q.max_tilt, max_roll_pitch=q.max_roll_pitch)
    return None if params == DEFAULT_PARAMS else params


registry.register_vehicle(Vehicle("quadrotor", "Iris-like, attitude loop and tilt limits (L24)", physics="quadrotor",
                                  params=quadrotor_params, keys=("quadrotor",)))
registry.register_vehicle(Vehicle("double_integrator", "planar, the flocking agents' model (L24 Sec. 2)",
                                  physics="double_integrator"))
registry.register_vehicle(Vehicle(
    "walker", "constant speed, random-walk yaw rate, reflected at the area's border (IB21 Sec. 6)",
    kinematic="swarmtrack.vehicles.ground_walker", pack="walker", uav=False, params=walker_params,
    keys=("count", "speed", "yaw_accel_bound", "area")))
registry.register_vehicle(Vehicle(
    "nearly_cv", "nearly constant velocity (white-noise acceleration), reflected at the area's border (issue 40)",
    kinematic="swarmtrack.vehicles.nearly_cv", uav=False, params=nearly_cv_params,
    keys=("count", "speed", "accel_noise", "area")))
registry.register_vehicle(Vehicle(
    "fixed_wing", "constant speed and altitude, steered by its yaw acceleration (IB21 Sec. 6)",
    kinematic="swarmtrack.vehicles.fixed_wing", pack="fixed_wing", command_width=1, group=False,
    params=fixed_wing_params, keys=("fixed_wing",)))
