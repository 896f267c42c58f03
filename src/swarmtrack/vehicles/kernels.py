"""Compiled fast path of the world's physics (numba): several physics ticks of every vehicle in one call.

:func:`swarmtrack.vehicles.quadrotor.step`, :func:`swarmtrack.vehicles.double_integrator.step` and
:func:`swarmtrack.vehicles.quadrotor.velocity_tracking_accel` are the readable, batched *reference*; at a
handful of vehicles one physics tick there costs ~30 numpy calls, so the world's 100 Hz loop is call
overhead. :func:`advance` does the same arithmetic, one vehicle at a time, in the same order of operations
(so the numbers agree with the reference to a few ulps: only ``sin``, ``cos``, ``atan`` and ``hypot`` come
from a different math library), for ``ticks`` ticks in a row:

* the target's autopilot: ``a = gain·(v_cmd[k] − v) + a_ff[k]`` (feed-forward + P, L24 Sec. 4) plus the
  wind gust ``wind[k]``, flown by the quadrotor model;
* every quadrotor (L24 Sec. 3.1 FS model rows, see :mod:`~swarmtrack.vehicles.quadrotor`): tilt setpoint
  from the norm-clipped command with the altitude-hold inversion, PD attitude law clipped to
  ``±max_moment/I``, semi-implicit Euler (rates, angles, velocity from the achieved tilt, position);
* every double integrator (L24 Sec. 2): ``p ← p + dt·u``, ``q ← q + dt·p``;
* the ring buffer of past (target, UAV) positions the world's delayed measurements read.

The kernel is ``@numba.njit(cache=True, fastmath=False)``, serial, and updates its arrays in place; the
world calls it through :meth:`swarmtrack.sim.world.World.advance`, and the tests hold it to the reference.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .quadrotor import QuadrotorParams


@numba.njit(cache=True, fastmath=False, inline="always")
def _clip(v, lim):
    """``v`` clipped to ``[−lim, lim]``; NaN stays NaN (as ``np.minimum``/``np.maximum``)."""
    if v > lim:
        return lim
    if v < -lim:
        return -lim
    return v


@numba.njit(cache=True, fastmath=False, inline="always")
def _quadrotor_step(S, m, ax, ay, dt, g, a_max, a_max_g, kp, kd, alpha_phi, alpha_theta, f_max):
    """Vehicle ``m`` of the quadrotor states ``S`` (8, M) (one row per state component, the reference's internal
    layout) advanced by ``dt`` under the command ``(ax, ay)``, in place.

    Exactly the operations of :func:`swarmtrack.vehicles.quadrotor.step` for one vehicle, no disturbance.
    """
    phi = S[4, m]
    theta = S[5, m]
    phi_dot = S[6, m]
    theta_dot = S[7, m]
    # Tilt setpoints: the command clipped in norm to g·tan(max_tilt), inverted for the altitude-hold thrust.
    scale = math.hypot(ax, ay)
    if scale < a_max:  # np.maximum(scale, a_max): a NaN stays NaN
        scale = a_max
    scale = a_max_g / scale  # min(1, a_max/|a|)/g
    t = ay * scale  # -tan(phi_d)
    phi_d = -math.atan(t)
    sec = math.hypot(t, 1.0)  # 1/cos(phi_d)
    theta_d = math.atan(ax * scale / sec)
    # PD attitude law as an angular acceleration, times dt, clipped to ±dt·max_moment/I.
    kp_dt = kp * dt
    kd_dt = kd * dt
    dv_phi = _clip((phi_d - phi) * kp_dt - phi_dot * kd_dt, alpha_phi * dt)
    dv_theta = _clip((theta_d - theta) * kp_dt - theta_dot * kd_dt, alpha_theta * dt)
    # Semi-implicit Euler: rates, then angles.
    phi_dot = phi_dot + dv_phi
    theta_dot = theta_dot + dv_theta
    phi = phi_dot * dt + phi
    theta = theta_dot * dt + theta
    # Velocity from the achieved tilt with the altitude-hold thrust: dt·T/m = min(g/(cφ cθ), f_max)·dt.
    cth = math.cos(theta)
    fdt = (g * dt) / (math.cos(phi) * cth)
    fmax_dt = f_max * dt
    if fdt > fmax_dt:
        fdt = fmax_dt
    vx = fdt * math.sin(theta) + S[2, m]
    vy = -(fdt * cth * math.sin(phi)) + S[3, m]
    S[0, m] = vx * dt + S[0, m]
    S[1, m] = vy * dt + S[1, m]
    S[2, m] = vx
    S[3, m] = vy
    S[4, m] = phi
    S[5, m] = theta
    S[6, m] = phi_dot
    S[7, m] = theta_dot


@numba.njit(cache=True, fastmath=False)
def _advance(S, points, uav_cmd, v_cmd, a_ff, wind, tick, ticks, gain, dt, consts, history):
    g, a_max, a_max_g, kp, kd, alpha_phi, alpha_theta, f_max = consts
    n_quad = S.shape[1]
    n_point = points.shape[0]
    lag = history.shape[0]
    for k in range(tick, tick + ticks):
        # Target (row 0): autopilot velocity tracking (feed-forward + P) plus the gust, flown by the model.
        ax = gain * (v_cmd[k, 0] - S[2, 0]) + a_ff[k, 0] + wind[k, 0]
        ay = gain * (v_cmd[k, 1] - S[3, 0]) + a_ff[k, 1] + wind[k, 1]
        _quadrotor_step(S, 0, ax, ay, dt, g, a_max, a_max_g, kp, kd, alpha_phi, alpha_theta, f_max)
        for m in range(1, n_quad):  # quadrotor UAVs
            _quadrotor_step(S, m, uav_cmd[m - 1, 0], uav_cmd[m - 1, 1], dt, g, a_max, a_max_g, kp, kd,
                            alpha_phi, alpha_theta, f_max)
        for m in range(n_point):  # double-integrator UAVs: velocity first, then position
            vx = uav_cmd[m, 0] * dt + points[m, 2]
            vy = uav_cmd[m, 1] * dt + points[m, 3]
            points[m, 0] = vx * dt + points[m, 0]
            points[m, 1] = vy * dt + points[m, 1]
            points[m, 2] = vx
            points[m, 3] = vy
        # Ring buffer of past positions: slot (k + 1) mod lag holds the truth after this tick.
        slot = (k + 1) % lag
        for m in range(n_quad):
            history[slot, m, 0] = S[0, m]
            history[slot, m, 1] = S[1, m]
        for m in range(n_point):
            history[slot, 1 + m, 0] = points[m, 0]
            history[slot, 1 + m, 1] = points[m, 1]


def params_tuple(params: QuadrotorParams) -> tuple[float, ...]:
    """The constants :func:`advance` takes: ``(g, a_max, a_max/g, kp, kd, α_max,φ, α_max,θ, f_max)``."""
    g, a_max, a_max_g, kp, kd, alpha_max, f_max = params._consts
    alpha = np.broadcast_to(np.asarray(alpha_max, dtype=float).ravel(), (2,))
    return (float(g), float(a_max), float(a_max_g), float(kp), float(kd), float(alpha[0]), float(alpha[1]),
            float(f_max))


def advance(quads, points, uav_cmd, v_cmd, a_ff, wind, tick: int, ticks: int, gain: float, dt: float,
            consts: tuple[float, ...], history) -> None:
    """Advance the vehicles by ``ticks`` physics ticks from tick ``tick``, **in place**.

    ``quads`` (M, 8) are quadrotor states with the target in row 0 and quadrotor UAVs in rows 1.. (M = 1 when
    the UAVs are double integrators); ``points`` (N, 4) are double-integrator UAVs ``[x, y, vx, vy]``
    (N = 0 when they are quadrotors). ``uav_cmd`` (N_uav, 2) is the UAVs' commanded acceleration, held over
    the ticks; ``v_cmd``, ``a_ff``, ``wind`` (K, 2) are the target's velocity profile, its derivative and the
    gusts sampled at every tick (rows ``tick .. tick + ticks − 1`` are used) and ``gain`` its autopilot's
    velocity gain; ``consts`` from :func:`params_tuple`. ``history`` (L, 1 + N_uav, 2) is the ring buffer
    of past positions: after tick ``k`` (0-based, global) slot ``(k + 1) mod L`` holds the target's and
    the UAVs' positions. The float arrays must be float64. The kernel works on ``quads.T`` (8, M), the
    layout :func:`~swarmtrack.vehicles.quadrotor.step` computes in: with the Fortran-ordered states it
    returns (which the world keeps) that is C-contiguous, the layout the kernel is compiled for.
    """
    if tick < 0 or tick + ticks > min(len(v_cmd), len(a_ff), len(wind)):
        raise IndexError(f"ticks {tick}..{tick + ticks - 1} are beyond the sampled profile ({len(v_cmd)} ticks)")
    _advance(quads.T, points, np.ascontiguousarray(uav_cmd, dtype=np.float64), v_cmd, a_ff, wind, int(tick),
             int(ticks), float(gain), float(dt), consts, history)


__all__ = ["advance", "params_tuple"]
