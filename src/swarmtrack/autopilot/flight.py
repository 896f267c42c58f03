"""PX4's multicopter position control as the simulated vehicle flies it (reference: PX4-Autopilot v1.14,
``src/modules/mc_pos_control/PositionControl/PositionControl.cpp`` and ``ControlMath.cpp``; gains and limits from
``multicopter_position_control_gain_params.c`` / ``..._limits_params.c``, read from the vehicle's parameter table by
their PX4 names).

Everything here is in MAVLink's local NED frame (x north, y east, z down; SI units). A setpoint is PX4's
``trajectory_setpoint``: a position, a velocity and an acceleration, each (3,), NaN where not controlled
(:class:`Setpoint`, built from ``SET_POSITION_TARGET_LOCAL_NED`` by :func:`setpoint_of` as ``mavlink_receiver.cpp``
builds it). It is flown through PX4's cascade (:func:`horizontal`, :func:`vertical`):

- position → velocity: ``v_sp = MPC_XY_P · (p_sp − p) + v_ff``, limited to ``MPC_XY_VEL_MAX`` with the position
  term's direction first (``ControlMath::constrainXY``); vertically ``MPC_Z_P`` and ``MPC_Z_VEL_MAX_UP/DN``;
- velocity → acceleration: ``a_sp = MPC_XY_VEL_P_ACC · (v_sp − v) + a_ff`` (``MPC_Z_VEL_P_ACC`` vertically); a NaN
  term adds nothing (``ControlMath::addIfNotNan``), so an acceleration-only setpoint is flown *exactly* as given
  (float32's value, unclipped);
- the velocity loop's horizontal acceleration is limited by the tilt ``MPC_TILTMAX_AIR`` (``|a| ≤ g·tan θ``), as
  PX4's ``_accelerationControl`` limits the thrust's tilt; in the autopilot's own modes (Hold, Position, Return,
  Land, Takeoff) by ``MPC_ACC_HOR`` and their speed by ``MPC_XY_CRUISE``, as their smooth trajectories do.

Not modelled: the velocity loop's integral and derivative terms (``MPC_XY_VEL_I_ACC``, ``MPC_XY_VEL_D_ACC``: the
world has no wind and its model no steady error), the jerk limits, and yaw control beyond holding the setpoint's yaw.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

#: Standard gravity (m/s²), PX4's ``CONSTANTS_ONE_G``.
G = 9.80665
_NAN3 = (math.nan, math.nan, math.nan)


def _nan3() -> np.ndarray:
    return np.array(_NAN3)


@dataclass
class Setpoint:
    """PX4's ``trajectory_setpoint`` (NED; NaN where not controlled)."""

    position: np.ndarray = field(default_factory=_nan3)
    velocity: np.ndarray = field(default_factory=_nan3)
    acceleration: np.ndarray = field(default_factory=_nan3)
    yaw: float = math.nan
    yaw_rate: float = math.nan

    def horizontal_valid(self) -> bool:
        """PX4's ``PositionControl::_inputValid`` horizontally: x and y come in pairs, and one of them is given."""
        pairs = all(np.isfinite(v[0]) == np.isfinite(v[1]) for v in (self.position, self.velocity, self.acceleration))
        return pairs and any(np.isfinite(v[0]) for v in (self.position, self.velocity, self.acceleration))

    def vertical_valid(self) -> bool:
        return any(np.isfinite(v[2]) for v in (self.position, self.velocity, self.acceleration))


def _masked(mask: int, bits: tuple[int, int, int], values) -> np.ndarray:
    return np.array([math.nan if mask & b else float(x) for b, x in zip(bits, values, strict=True)])


_POS_BITS = (mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE,
             mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE)
_VEL_BITS = (mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE,
             mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE)
_ACC_BITS = (mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE,
             mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE)


def _yaw_rotation(yaw: float, v: np.ndarray) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]])


def setpoint_of(msg, yaw: float) -> tuple[Setpoint | None, str | None]:
    """The setpoint of a ``SET_POSITION_TARGET_LOCAL_NED`` (``yaw``: the vehicle's, rad, for ``MAV_FRAME_BODY_NED``),
    or None and PX4's text of why it drops it (``MavlinkReceiver::handle_message_set_position_target_local_ned``):

    - ``MAV_FRAME_LOCAL_NED``: each field unless its type-mask bit ignores it;
    - ``MAV_FRAME_BODY_NED``: velocity and acceleration rotated by the vehicle's yaw, no position;
    - another frame (``MAV_FRAME_LOCAL_OFFSET_NED``, ``MAV_FRAME_BODY_OFFSET_NED``): dropped, "coordinate frame N
      unsupported";
    - the force bit with an acceleration: dropped, "force not supported";
    - nothing set: dropped, "invalid".
    """
    mask, frame = int(msg.type_mask), int(msg.coordinate_frame)
    if frame == mavlink.MAV_FRAME_LOCAL_NED:
        sp = Setpoint(_masked(mask, _POS_BITS, (msg.x, msg.y, msg.z)),
                      _masked(mask, _VEL_BITS, (msg.vx, msg.vy, msg.vz)),
                      _masked(mask, _ACC_BITS, (msg.afx, msg.afy, msg.afz)))
    elif frame == mavlink.MAV_FRAME_BODY_NED:
        vel = _masked(mask, _VEL_BITS, (msg.vx, msg.vy, msg.vz))
        acc = _masked(mask, _ACC_BITS, (msg.afx, msg.afy, msg.afz))
        sp = Setpoint(_nan3(), _nan3() if mask & sum(_VEL_BITS) else _yaw_rotation(yaw, vel),
                      _nan3() if mask & sum(_ACC_BITS) else _yaw_rotation(yaw, acc))
    else:
        return None, f"SET_POSITION_TARGET_LOCAL_NED coordinate frame {frame} unsupported"
    sp.yaw = math.nan if mask & mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE else float(msg.yaw)
    sp.yaw_rate = math.nan if mask & mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE else float(msg.yaw_rate)
    given = [not np.isnan(v).all() for v in (sp.position, sp.velocity, sp.acceleration)]
    if given[2] and mask & mavlink.POSITION_TARGET_TYPEMASK_FORCE_SET:
        return None, "SET_POSITION_TARGET_LOCAL_NED force not supported"
    if not any(given):
        return None, "SET_POSITION_TARGET_LOCAL_NED invalid"
    return sp, None


def global_setpoint_of(msg, origin, home) -> tuple[Setpoint | None, str | None]:
    """The setpoint of a ``SET_POSITION_TARGET_GLOBAL_INT`` as PX4's receiver builds it
    (``handle_message_set_position_target_global_int``): the position projected about the local frame's geodetic
    ``origin`` (:class:`~swarmtrack.autopilot.geodesy.Origin`), its altitude AMSL (``MAV_FRAME_GLOBAL_INT``) or above
    ``home`` (NED (3,), ``MAV_FRAME_GLOBAL_RELATIVE_ALT_INT``; dropped without a home); velocity and acceleration in
    NED as given. Another frame is dropped, "invalid coordinate frame N"."""
    mask, frame = int(msg.type_mask), int(msg.coordinate_frame)
    pos = _nan3()
    if not mask & sum(_POS_BITS):
        n, e, d = origin.to_local(msg.lat_int / 1e7, msg.lon_int / 1e7, float(msg.alt))
        if frame == mavlink.MAV_FRAME_GLOBAL_INT:
            pos = np.array([n, e, d])
        elif frame == mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT and home is not None:
            pos = np.array([n, e, home[2] - float(msg.alt)])
        elif frame == mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT:
            return None, "SET_POSITION_TARGET_GLOBAL_INT needs a home altitude"
        else:
            return None, f"SET_POSITION_TARGET_GLOBAL_INT invalid coordinate frame {frame}"
    sp = Setpoint(pos, _masked(mask, _VEL_BITS, (msg.vx, msg.vy, msg.vz)),
                  _masked(mask, _ACC_BITS, (msg.afx, msg.afy, msg.afz)))
    sp.yaw = math.nan if mask & mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE else float(msg.yaw)
    sp.yaw_rate = math.nan if mask & mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE else float(msg.yaw_rate)
    given = [not np.isnan(v).all() for v in (sp.position, sp.velocity, sp.acceleration)]
    if given[2] and mask & mavlink.POSITION_TARGET_TYPEMASK_FORCE_SET:
        return None, "SET_POSITION_TARGET_GLOBAL_INT force not supported"
    if not any(given):
        return None, "SET_POSITION_TARGET_GLOBAL_INT invalid"
    return sp, None


@dataclass
class Limits:
    """The gains and limits the cascade flies with, by PX4's parameter names (defaults: PX4 v1.14's)."""

    xy_p: float = 0.95  # MPC_XY_P (1/s)
    xy_vel_p: float = 1.8  # MPC_XY_VEL_P_ACC (1/s)
    xy_vel_max: float = 12.0  # MPC_XY_VEL_MAX (m/s)
    xy_cruise: float = 5.0  # MPC_XY_CRUISE (m/s), the own modes' speed
    acc_hor: float = 3.0  # MPC_ACC_HOR (m/s²), the own modes' acceleration
    tilt_max: float = 45.0  # MPC_TILTMAX_AIR (deg)
    z_p: float = 1.0  # MPC_Z_P (1/s)
    z_vel_p: float = 4.0  # MPC_Z_VEL_P_ACC (1/s)
    z_vel_max_up: float = 3.0  # MPC_Z_VEL_MAX_UP (m/s)
    z_vel_max_dn: float = 1.5  # MPC_Z_VEL_MAX_DN (m/s)

    NAMES = {"xy_p": "MPC_XY_P", "xy_vel_p": "MPC_XY_VEL_P_ACC", "xy_vel_max": "MPC_XY_VEL_MAX",
             "xy_cruise": "MPC_XY_CRUISE", "acc_hor": "MPC_ACC_HOR", "tilt_max": "MPC_TILTMAX_AIR", "z_p": "MPC_Z_P",
             "z_vel_p": "MPC_Z_VEL_P_ACC", "z_vel_max_up": "MPC_Z_VEL_MAX_UP", "z_vel_max_dn": "MPC_Z_VEL_MAX_DN"}

    @classmethod
    def of(cls, params) -> Limits:
        """The limits in a parameter table (``params.get(NAME)``)."""
        return cls(**{k: float(params.get(name)) for k, name in cls.NAMES.items()})


def constrain_xy(v0: np.ndarray, v1: np.ndarray, vmax: float) -> np.ndarray:
    """``v0 + v1`` limited to ``vmax`` keeping ``v0`` first (PX4's ``ControlMath::constrainXY``)."""
    total = v0 + v1
    n0 = float(np.linalg.norm(v0))
    if np.linalg.norm(total) <= vmax:
        return total
    if n0 >= vmax or np.linalg.norm(v1 - v0) < 1e-3:
        return v0 / n0 * vmax
    if n0 < 1e-3:
        return v1 / np.linalg.norm(v1) * vmax
    u1 = v1 / np.linalg.norm(v1)
    b, c = 2.0 * float(u1 @ v0), n0 * n0 - vmax * vmax
    return v0 + u1 * (-b + math.sqrt(max(b * b - 4.0 * c, 0.0))) / 2.0


def _add_if_not_nan(setpoint: np.ndarray, addition: np.ndarray) -> np.ndarray:
    """PX4's ``ControlMath::addIfNotNan``: the sum where both are finite, the addition where the setpoint is NaN."""
    return np.where(np.isfinite(setpoint), np.where(np.isfinite(addition), setpoint + addition, setpoint), addition)


def _limit_norm(a: np.ndarray, limit: float) -> np.ndarray:
    n = float(np.linalg.norm(a))
    return a if n <= limit or n == 0.0 else a * (limit / n)


def horizontal(sp: Setpoint, p: np.ndarray, v: np.ndarray, lim: Limits, own_mode: bool = False) -> np.ndarray:
    """The horizontal acceleration (2,) (NED) that flies ``sp`` from position ``p`` and velocity ``v`` (2,): PX4's
    cascade (module docstring). ``own_mode``: one of the autopilot's modes (speed ``MPC_XY_CRUISE``, acceleration
    ``MPC_ACC_HOR``), not offboard (``MPC_XY_VEL_MAX``, tilt). An invalid setpoint (x without y) is PX4's
    position-control failsafe: brake to zero velocity."""
    if not sp.horizontal_valid():
        sp = Setpoint(velocity=np.zeros(3))
    vel_from_pos = lim.xy_p * (sp.position[:2] - p)
    vel_sp = _add_if_not_nan(sp.velocity[:2].copy(), vel_from_pos)
    if np.isfinite(vel_sp).all():
        from_pos = np.nan_to_num(vel_from_pos)
        vel_sp = constrain_xy(from_pos, vel_sp - from_pos, lim.xy_cruise if own_mode else lim.xy_vel_max)
    from_vel = lim.xy_vel_p * (vel_sp - v)
    if not np.isfinite(from_vel).all():  # no velocity loop: the acceleration as given
        return sp.acceleration[:2].copy()
    acc = _add_if_not_nan(sp.acceleration[:2].copy(), from_vel)
    return _limit_norm(acc, lim.acc_hor if own_mode else G * math.tan(math.radians(lim.tilt_max)))


def vertical(sp: Setpoint, z: float, vz: float, lim: Limits, climb: float | None = None,
             descend: float | None = None) -> float:
    """The vertical acceleration (NED, m/s², down positive) that flies ``sp`` from ``z``, ``vz``: PX4's cascade,
    the climb and descent rates limited to ``climb`` and ``descend`` (default ``MPC_Z_VEL_MAX_UP/DN``). No vertical
    setpoint: hold the vertical speed at zero (PX4's failsafe setpoint)."""
    if not sp.vertical_valid():
        sp = Setpoint(velocity=np.zeros(3))
    pz, vz_ff, az_ff = float(sp.position[2]), float(sp.velocity[2]), float(sp.acceleration[2])
    from_pos = lim.z_p * (pz - z)
    vz_sp = from_pos + (vz_ff if math.isfinite(vz_ff) else 0.0) if math.isfinite(from_pos) else vz_ff
    if not math.isfinite(vz_sp):
        return az_ff
    up = lim.z_vel_max_up if climb is None else climb
    down = lim.z_vel_max_dn if descend is None else descend
    vz_sp = min(max(vz_sp, -up), down)
    return lim.z_vel_p * (vz_sp - vz) + (az_ff if math.isfinite(az_ff) else 0.0)


def stopping_point(p: np.ndarray, v: np.ndarray, acc: float) -> np.ndarray:
    """Where a vehicle at ``p`` moving at ``v`` stops braking at ``acc`` (m/s²): PX4's Position and Hold modes hold
    the point where they brake to rest, not the one where they were entered."""
    speed = float(np.linalg.norm(v))
    return p + v * (speed / (2.0 * acc)) if acc > 0 else p.copy()


def attitude_of(acc: np.ndarray, yaw: float) -> np.ndarray:
    """A plausible ``[roll, pitch, yaw]`` (rad, NED/FRD) of a multicopter flying the horizontal acceleration ``acc``
    (2,) (NED) at heading ``yaw``: its thrust tilted as PX4's ``_accelerationControl`` tilts it (body z along
    ``(−a_n, −a_e, g)``), read as Euler angles."""
    forward = acc[0] * math.cos(yaw) + acc[1] * math.sin(yaw)
    right = -acc[0] * math.sin(yaw) + acc[1] * math.cos(yaw)
    pitch = -math.atan2(forward, G)
    roll = math.atan2(right * math.cos(pitch), G)
    return np.array([roll, pitch, yaw])


class Vertical:
    """The vehicle's own vertical channel when the world is planar: altitude above its ground (``z ≤ 0`` in NED is
    above it) and vertical speed, a double integrator the autopilot's vertical acceleration drives. On the ground
    (``z = 0``) it stays there while pushed down; disarmed in the air it falls."""

    STEP = 0.01  # s: the integration step

    def __init__(self, z: float = 0.0):
        self.z, self.vz = float(z), 0.0

    @property
    def on_ground(self) -> bool:
        return self.z >= 0.0 and self.vz >= 0.0

    def advance(self, dt: float, az: float, armed: bool) -> None:
        """``dt`` s under the vertical acceleration ``az`` (NED); disarmed, gravity."""
        if not math.isfinite(az):
            az = 0.0
        a = az if armed else G
        steps = max(1, math.ceil(dt / self.STEP))
        h = dt / steps
        for _ in range(steps):
            self.vz += a * h
            self.z += self.vz * h
            if self.z >= 0.0:  # the ground
                self.z, self.vz = 0.0, min(self.vz, 0.0) if a < 0 else 0.0
