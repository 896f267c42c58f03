"""Planar quadrotor at fixed altitude with an attitude inner loop: the "true dynamics" of every vehicle.

The papers flew Iris quadrotors in PX4 SITL / Gazebo (L24 Sec. 4, L23 Sec. 4), so the acceleration a UAV
commands and the one it achieves differ by the attitude loop's lag and by the tilt limit. This module
reproduces that with a small model, integrated for all ``M`` vehicles at once on arrays ``(M, ...)``:

* state ``(M, 8)``: ``[x, y, vx, vy, φ, θ, φ̇, θ̇]`` (m, m/s, rad, rad/s);
* planar translational dynamics as in the L24 FS model (L24 Sec. 3.1, FS prediction rows, as corrected
  in SPEC.md): ``ax = (T/m)·sin θ``, ``ay = −(T/m)·sin φ·cos θ``, vertical ``(T/m)·cos φ·cos θ − g``;
  i.e. the thrust direction is ``Rx(φ)·Ry(θ)·e3``;
* attitude ``φ̈ = Uφ/Ixx``, ``θ̈ = Uθ/Iyy`` (L24 FS model rows for the angle rates);
* altitude hold: ``T = m·g/(cos φ cos θ)`` (clipped to ``max_thrust``), so the vertical acceleration is
  zero while the thrust is not saturated; the altitude itself is not simulated;
* attitude controller: the commanded planar acceleration is clipped in norm to ``g·tan(max_tilt)`` and
  inverted exactly for the altitude-hold thrust, ``φ_d = −atan(ay/g)``, ``θ_d = atan(ax·cos φ_d/g)``
  (then ``tan(tilt_d) = ‖a‖/g`` with ``cos(tilt) = cos φ cos θ``); with ``max_roll_pitch`` set, each of
  ``φ_d`` and ``θ_d`` is then saturated at ``±max_roll_pitch`` (W20 Sec. 5.4.2: "Saturation of the RPY angles is
  set at 5°"); a PD on the angles gives ``U = I·(ωn²(angle_d − angle) − 2ζωn·rate)``, clipped to ``±max_moment``.

The vehicle has no yaw: its heading does not enter the planar dynamics (the thrust direction is ``Rx(φ)·Ry(θ)·e3``)
nor any sensor of the project, so a yaw saturation (W20 saturates roll, pitch *and* yaw) has nothing to act on.

Integration is semi-implicit Euler: rates, then angles, then the velocity from the *achieved* (new) tilt,
then the position from the new velocity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

X, Y, VX, VY, PHI, THETA, PHI_DOT, THETA_DOT = range(8)
STATE_DIM = 8
STATE_NAMES = ("x", "y", "vx", "vy", "phi", "theta", "phi_dot", "theta_dot")


@dataclass(frozen=True)
class QuadrotorParams:
    """Physical and inner-loop parameters of an Iris-like quadrotor.

    * ``mass`` = 1.5 kg, ``Ixx`` = ``Iyy`` = 0.029 kg·m²: the PX4 SITL Gazebo ``iris`` model
      (``iris.sdf``: base mass 1.5 kg, ixx 0.029125, iyy 0.029125), as SPEC.md asks for the FS model.
    * ``max_tilt`` = 0.6 rad (≈ 34°): limit of the *tilt setpoint*; PX4's ``MPC_TILTMAX_AIR`` defaults to
      45°; we chose a tighter limit (the papers' manoeuvres need < 15°). Not from the papers. Like the PX4
      parameter it limits the *setpoint*: the achieved tilt can exceed it by the inner-loop overshoot (< 2 %).
    * ``max_roll_pitch`` = None: no per-axis limit (the default, the project's old behaviour). A number [rad]
      saturates the roll and the pitch *setpoints* each at ``±max_roll_pitch`` after the tilt-norm clip, as W20's
      V-REP quadrotor saturated its roll/pitch/yaw angles at 5° (W20 Sec. 5.4.2, beside Table 5.5). Per axis, not in
      norm: with both axes saturated the tilt is ``acos(cos² max_roll_pitch)`` (7.07° for 5°) and the achieved
      acceleration turns toward the diagonal. Like ``max_tilt`` it limits the setpoint; the achieved angles exceed
      it by the inner-loop overshoot only (< 2 %).
    * ``max_thrust`` = 2·m·g when left as ``None`` (thrust-to-weight ratio 2, chosen).
    * ``attitude_wn`` = 12 rad/s and ``attitude_zeta`` = 0.8: inner-loop natural frequency and damping
      (chosen; ~0.35 s settling, ~1.5 % overshoot, an equivalent lag of 2ζ/ωn ≈ 0.13 s).
    * ``max_moment`` = 1.5 N·m: clip of the roll/pitch moments (≈ 0.25 m arm × 6 N differential thrust;
      chosen), i.e. an angular acceleration limit of ≈ 52 rad/s².
    """

    mass: float = 1.5
    Ixx: float = 0.029
    Iyy: float = 0.029
    g: float = 9.81
    max_tilt: float = 0.6
    max_roll_pitch: float | None = None
    max_thrust: float | None = None
    attitude_wn: float = 12.0
    attitude_zeta: float = 0.8
    max_moment: float = 1.5
    # Derived constants used by :func:`step` (computed once).
    _kp: float = field(init=False, repr=False, compare=False)
    _kd: float = field(init=False, repr=False, compare=False)
    _alpha_max: np.ndarray | float = field(init=False, repr=False, compare=False)
    _a_max: float = field(init=False, repr=False, compare=False)
    _f_max: float = field(init=False, repr=False, compare=False)
    _consts: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.max_thrust is None:
            object.__setattr__(self, "max_thrust", 2.0 * self.mass * self.g)
        assert self.max_thrust is not None
        if not 0.0 < self.max_tilt < math.pi / 2:
            raise ValueError("max_tilt must be in (0, π/2)")
        if self.max_roll_pitch is not None and not 0.0 < self.max_roll_pitch < math.pi / 2:
            raise ValueError("max_roll_pitch must be None or in (0, π/2)")
        if self.max_thrust <= self.mass * self.g:
            raise ValueError("max_thrust must exceed the weight m·g")
        wn, zeta = self.attitude_wn, self.attitude_zeta
        alpha_max: np.ndarray | float
        if self.Ixx == self.Iyy:  # a Python float is ~2x faster than a (2,) array in tiny ufuncs
            alpha_max = self.max_moment / self.Ixx
        else:
            alpha_max = np.array([[self.max_moment / self.Ixx], [self.max_moment / self.Iyy]])  # (axis, 1)
            alpha_max.setflags(write=False)
        a_max = self.g * math.tan(self.max_tilt)
        derived = {
            "_kp": wn * wn,
            "_kd": 2.0 * zeta * wn,
            "_alpha_max": alpha_max,
            "_a_max": a_max,
            "_f_max": self.max_thrust / self.mass,
        }
        for name, val in derived.items():
            object.__setattr__(self, name, val)
        angle_max = math.inf if self.max_roll_pitch is None else float(self.max_roll_pitch)
        consts = (self.g, a_max, a_max / self.g, wn * wn, 2.0 * zeta * wn, alpha_max, derived["_f_max"], angle_max)
        object.__setattr__(self, "_consts", consts)

    @property
    def max_horizontal_accel(self) -> float:
        """Largest planar acceleration reachable at the tilt limit with altitude hold, ``g·tan(max_tilt)``."""
        return self._a_max

    @property
    def max_axis_accel(self) -> float:
        """Largest planar acceleration reachable on *each* axis at once (a diagonal command), m/s²: the tilt-norm
        limit shared by the two axes, ``g·tan(max_tilt)/√2``, and with ``max_roll_pitch`` the per-axis saturation
        ``g·tan(max_roll_pitch)`` (``θ_d`` saturated gives ``ax = g·tan θ/cos φ ≥ g·tan θ``). For W20's 5°:
        0.858 m/s² (what :mod:`swarmtrack.control.mpc` plans within); the default 0.6 rad: 4.76 m/s². A limit only:
        the vehicle's behaviour is :func:`step`'s."""
        per_axis = self._a_max / math.sqrt(2.0)
        if self.max_roll_pitch is not None:
            per_axis = min(per_axis, self.g * math.tan(self.max_roll_pitch))
        return per_axis


DEFAULT_PARAMS = QuadrotorParams()


@dataclass(frozen=True, eq=False)
class RowParams:
    """Different :class:`QuadrotorParams` for the rows of one batch of quadrotors (e.g. the swarm's 5° limit beside
    quadrotor targets at the defaults): ``sets`` the distinct parameter sets, ``index`` (M,) each row's set.
    :func:`step` steps each set's rows with its own parameters; the rows do not interact, so every row's numbers
    are those of its set stepped alone."""

    sets: tuple[QuadrotorParams, ...]
    index: np.ndarray


def per_row(params) -> QuadrotorParams | RowParams:
    """The parameters of ``M`` quadrotor rows from each row's :class:`QuadrotorParams` (None: the defaults): one
    ``QuadrotorParams`` when they are all equal (the path of a single set, bit for bit), else a :class:`RowParams`."""
    rows = [DEFAULT_PARAMS if p is None else p for p in params]
    sets = list(dict.fromkeys(rows))
    if len(sets) <= 1:
        return sets[0] if sets else DEFAULT_PARAMS
    index = np.array([sets.index(p) for p in rows], dtype=np.int64)
    index.setflags(write=False)
    return RowParams(tuple(sets), index)


def hover_state(positions) -> np.ndarray:
    """States ``(M, 8)`` hovering (level, at rest) at the planar ``positions`` ``(M, 2)``."""
    positions = np.asarray(positions, dtype=float)
    state = np.zeros((positions.shape[0], STATE_DIM), order="F")  # the layout step() returns
    state[:, 0:2] = positions
    return state


def desired_attitude(accel_cmd, params: QuadrotorParams = DEFAULT_PARAMS) -> np.ndarray:
    """Tilt setpoints ``(M, 2)`` = ``[φ_d, θ_d]`` for commanded planar accelerations ``(M, 2)``.

    The command is clipped in norm to ``g·tan(max_tilt)`` and inverted exactly for the altitude-hold
    thrust ``T = m g/(cos φ cos θ)``: ``tan φ_d = −ay/g``, ``tan θ_d = ax·cos φ_d/g``; then each angle is
    saturated at ``±max_roll_pitch`` when that is set (W20 Sec. 5.4.2).
    """
    a = np.asarray(accel_cmd, dtype=float)
    ax, ay = a[:, 0], a[:, 1]
    scale = np.minimum(1.0, params._a_max / np.maximum(np.hypot(ax, ay), 1e-300)) / params.g
    phi_d = -np.arctan(ay * scale)
    theta_d = np.arctan(ax * scale * np.cos(phi_d))
    out = np.stack((phi_d, theta_d), axis=-1)
    if params.max_roll_pitch is not None:
        np.clip(out, -params.max_roll_pitch, params.max_roll_pitch, out=out)
    return out


def step(state, accel_cmd, params: QuadrotorParams | RowParams, dt: float, disturbance=None) -> np.ndarray:
    """Advance ``M`` quadrotors by ``dt`` under commanded planar accelerations; returns a new ``(M, 8)``.

    ``accel_cmd`` ``(M, 2)`` [m/s²] is what the guidance (flocking, target-following) asks for; the
    vehicle achieves it only through its tilt (see the module docstring). ``disturbance`` ``(M, 2)`` is an
    extra planar acceleration (e.g. wind) added to the achieved one. Pure: ``state`` is not modified. ``params``
    may be a :class:`RowParams` (rows with different parameters, :func:`per_row`).

    The returned array is Fortran-ordered (its transpose, one row per state component, is C-contiguous):
    feeding it back makes every per-component block contiguous, which cut the step from ~19 µs to ~13 µs
    for M = 4 in our measurement (about 30 tiny ufunc calls per step). Any layout is accepted as input.
    """
    if isinstance(params, RowParams):
        return _step_rows(state, accel_cmd, params, dt, disturbance)
    g, a_max, a_max_g, kp, kd, alpha_max, f_max, angle_max = params._consts
    S = np.asarray(state, dtype=float).T  # (8, M): one row per state component
    if not S.flags.c_contiguous:
        S = np.ascontiguousarray(S)
    a = np.asarray(accel_cmd, dtype=float)
    O = np.empty_like(S)
    ax = a[:, 0]
    ay = a[:, 1]
    # Tilt setpoints (as in desired_attitude), written into the velocity rows of O as scratch.
    scale = np.hypot(ax, ay)
    np.maximum(scale, a_max, out=scale)
    np.divide(a_max_g, scale, out=scale)  # min(1, a_max/|a|)/g
    ang_d = O[2:4]
    t = ay * scale  # -tan(phi_d)
    np.arctan(t, out=ang_d[0])
    np.negative(ang_d[0], out=ang_d[0])
    sec = np.hypot(t, 1.0)  # 1/cos(phi_d)
    np.multiply(ax, scale, out=t)
    t /= sec  # tan(theta_d)
    np.arctan(t, out=ang_d[1])
    if angle_max != math.inf:  # per-axis saturation of the roll and pitch setpoints (W20 Sec. 5.4.2)
        np.minimum(ang_d, angle_max, out=ang_d)
        np.maximum(ang_d, -angle_max, out=ang_d)
    # PD attitude law as an angular acceleration, times dt, clipped to ±dt·max_moment/I.
    ang = S[4:6]
    rate = S[6:8]
    dv = ang_d - ang
    dv *= kp * dt
    dv -= rate * (kd * dt)
    lim = alpha_max * dt
    np.minimum(dv, lim, out=dv)
    np.maximum(dv, -lim, out=dv)
    # Semi-implicit Euler: rates, then angles.
    rate_new = O[6:8]
    np.add(rate, dv, out=rate_new)
    ang_new = O[4:6]
    np.multiply(rate_new, dt, out=ang_new)
    ang_new += ang
    # Velocity from the achieved tilt with the altitude-hold thrust: dt·T/m = min(g/(cφ cθ), f_max)·dt.
    c = np.cos(ang_new)
    s = np.sin(ang_new)
    cth = c[1]
    fdt = c[0] * cth
    np.divide(g * dt, fdt, out=fdt)
    np.minimum(fdt, f_max * dt, out=fdt)
    vel_new = O[2:4]
    np.multiply(fdt, s[1], out=vel_new[0])  # dt·ax
    fdt *= cth
    fdt *= s[0]
    np.negative(fdt, out=vel_new[1])  # dt·ay
    if disturbance is not None:
        vel_new += np.asarray(disturbance, dtype=float).T * dt
    vel_new += S[2:4]
    pos_new = O[0:2]
    np.multiply(vel_new, dt, out=pos_new)
    pos_new += S[0:2]
    return O.T


def _step_rows(state, accel_cmd, params: RowParams, dt: float, disturbance) -> np.ndarray:
    """:func:`step` of each parameter set's rows with its own parameters, reassembled (Fortran-ordered)."""
    state = np.asarray(state, dtype=float)
    a = np.asarray(accel_cmd, dtype=float)
    d = None if disturbance is None else np.asarray(disturbance, dtype=float)
    out = np.empty(state.shape, order="F")
    for k, p in enumerate(params.sets):
        rows = params.index == k
        out[rows] = step(state[rows], a[rows], p, dt, None if d is None else d[rows])
    return out


def _tilt_accel(ang, g, f_max):
    c = np.cos(ang)
    s = np.sin(ang)
    cth = c[:, 1]
    f = np.minimum(g / (c[:, 0] * cth), f_max)  # T/m
    acc = np.empty_like(ang)
    np.multiply(f, s[:, 1], out=acc[:, 0])
    f *= cth
    np.multiply(f, s[:, 0], out=acc[:, 1])
    np.negative(acc[:, 1], out=acc[:, 1])
    return acc


def achieved_acceleration(state, params: QuadrotorParams = DEFAULT_PARAMS) -> np.ndarray:
    """Planar acceleration ``(M, 2)`` implied by the current tilt with the altitude-hold thrust.

    ``ax = (T/m) sin θ``, ``ay = −(T/m) sin φ cos θ`` with ``T = min(m g/(cos φ cos θ), max_thrust)``
    (L24 Sec. 3.1, FS model). The disturbance, if any, is not included.
    """
    state = np.asarray(state, dtype=float)
    return _tilt_accel(state[:, 4:6], params.g, params._f_max)


def tilt(state) -> np.ndarray:
    """Tilt angle ``(M,)`` of the thrust axis from the vertical, ``acos(cos φ cos θ)`` [rad]."""
    state = np.asarray(state, dtype=float)
    return np.arccos(np.clip(np.cos(state[:, 4]) * np.cos(state[:, 5]), -1.0, 1.0))


def velocity_tracking_accel(v_cmd, v, a_ff, gain: float) -> np.ndarray:
    """Acceleration command ``a_ff + gain·(v_cmd − v)`` to fly a velocity profile (feed-forward + P).

    Used by the target to fly its prescribed profile (L24 Sec. 4); ``a_ff`` may be ``None`` (no
    feed-forward). ``gain`` in 1/s.
    """
    a = gain * (np.asarray(v_cmd, dtype=float) - v)
    if a_ff is not None:
        a = a + a_ff
    return a
