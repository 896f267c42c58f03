"""Compiled fast path of the world's physics (numba): several physics ticks of every vehicle in one call.

:func:`swarmtrack.vehicles.quadrotor.step`, :func:`swarmtrack.vehicles.double_integrator.step` and
:func:`swarmtrack.vehicles.quadrotor.velocity_tracking_accel` are the readable, batched *reference*; at a
handful of vehicles one physics tick there costs ~30 numpy calls, so the world's 100 Hz loop is call
overhead. :func:`advance` does the same arithmetic, one vehicle at a time, in the same order of operations
(so the numbers agree with the reference to a few ulps: only ``sin``, ``cos``, ``atan`` and ``hypot`` come
from a different math library), for ``ticks`` ticks in a row:

* every driven vehicle's autopilot (targets, decoys): ``a = gain·(v_cmd[k] − v) + a_ff[k]`` (feed-forward + P,
  L24 Sec. 4) plus the wind gust ``wind[k]``; every commanded vehicle (UAVs) holds its command;
* every quadrotor (L24 Sec. 3.1 FS model rows, see :mod:`~swarmtrack.vehicles.quadrotor`): tilt setpoint
  from the norm-clipped command with the altitude-hold inversion, each angle saturated at ``±max_roll_pitch``
  when that is set (W20 Sec. 5.4.2; the default kernel, one parameter set without it, is compiled without the
  comparisons, as fast as before), PD attitude law clipped to
  ``±max_moment/I``, semi-implicit Euler (rates, angles, velocity from the achieved tilt, position);
* every double integrator (L24 Sec. 2): ``p ← p + dt·u``, ``q ← q + dt·p``;
* the ring buffer of past positions the world's delayed measurements read.

The kernel is ``@numba.njit(cache=True, fastmath=False)``, serial, and updates its arrays in place; the
world calls it through :meth:`swarmtrack.sim.world.World.advance`, and the tests hold it to the reference.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .quadrotor import QuadrotorParams, RowParams


@numba.njit(cache=True, fastmath=False, inline="always")
def _clip(v, lim):
    """``v`` clipped to ``[−lim, lim]``; NaN stays NaN (as ``np.minimum``/``np.maximum``)."""
    if v > lim:
        return lim
    if v < -lim:
        return -lim
    return v


@numba.njit(cache=True, fastmath=False, inline="always")
def _quadrotor_step(S, m, ax, ay, dt, c, limited):
    """Vehicle ``m`` of the quadrotor states ``S`` (8, M) (one row per state component, the reference's internal
    layout) advanced by ``dt`` under the command ``(ax, ay)``, in place; ``c`` the vehicle's constants, a row of
    :func:`params_tuple`'s table as a tuple; ``limited`` (a constant of the calling kernel) whether to apply the
    per-axis saturation ``angle_max``.

    Exactly the operations of :func:`swarmtrack.vehicles.quadrotor.step` for one vehicle, no disturbance.
    """
    g, a_max, a_max_g, kp, kd, alpha_phi, alpha_theta, f_max, angle_max = c
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
    if limited:  # per-axis saturation of the setpoints (W20 Sec. 5.4.2); a NaN stays NaN
        if phi_d > angle_max:
            phi_d = angle_max
        elif phi_d < -angle_max:
            phi_d = -angle_max
        if theta_d > angle_max:
            theta_d = angle_max
        elif theta_d < -angle_max:
            theta_d = -angle_max
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


@numba.njit(cache=True, fastmath=False, inline="always")
def _row(table, k):
    """Row ``k`` of the constants' table as a tuple of floats (kept in registers across the vehicle loop)."""
    return (table[k, 0], table[k, 1], table[k, 2], table[k, 3], table[k, 4], table[k, 5], table[k, 6], table[k, 7],
            table[k, 8])


@numba.njit(cache=True, fastmath=False, inline="always")
def _advance_body(quads, points, profile, tick, ticks, dt, consts, history, general):
    states, quad_cmd, quad_driver, quad_obj = quads
    table, index = consts  # a row of constants per parameter set; each quadrotor's set (empty: all the first)
    per_row = index.shape[0] > 0
    c0 = _row(table, 0)
    S = states.T  # (8, Mq), C-contiguous for the Fortran-ordered states the reference returns
    P, point_cmd, point_driver, point_obj = points
    v_cmd, a_ff, wind, gains = profile
    n_quad = S.shape[1]
    n_point = P.shape[0]
    lag = history.shape[0]
    for k in range(tick, tick + ticks):
        for m in range(n_quad):
            d = quad_driver[m]
            if d >= 0:  # driven: autopilot velocity tracking (feed-forward + P) plus the gust
                ax = gains[d] * (v_cmd[k, d, 0] - S[2, m]) + a_ff[k, d, 0] + wind[k, d, 0]
                ay = gains[d] * (v_cmd[k, d, 1] - S[3, m]) + a_ff[k, d, 1] + wind[k, d, 1]
            else:  # commanded onboard
                ax = quad_cmd[m, 0]
                ay = quad_cmd[m, 1]
            if general:  # rows of several parameter sets, per-axis limits
                _quadrotor_step(S, m, ax, ay, dt, _row(table, index[m]) if per_row else c0, True)
            else:  # one set, no per-axis limit: the default, compiled without either
                _quadrotor_step(S, m, ax, ay, dt, c0, False)
        for m in range(n_point):  # double integrators: velocity first, then position
            d = point_driver[m]
            if d >= 0:
                ax = gains[d] * (v_cmd[k, d, 0] - P[m, 2]) + a_ff[k, d, 0] + wind[k, d, 0]
                ay = gains[d] * (v_cmd[k, d, 1] - P[m, 3]) + a_ff[k, d, 1] + wind[k, d, 1]
            else:
                ax = point_cmd[m, 0]
                ay = point_cmd[m, 1]
            vx = ax * dt + P[m, 2]
            vy = ay * dt + P[m, 3]
            P[m, 0] = vx * dt + P[m, 0]
            P[m, 1] = vy * dt + P[m, 1]
            P[m, 2] = vx
            P[m, 3] = vy
        # Ring buffer of past positions: slot (k + 1) mod lag holds the truth after this tick.
        if lag > 1:
            slot = (k + 1) % lag
            for m in range(n_quad):
                history[slot, quad_obj[m], 0] = S[0, m]
                history[slot, quad_obj[m], 1] = S[1, m]
            for m in range(n_point):
                history[slot, point_obj[m], 0] = P[m, 0]
                history[slot, point_obj[m], 1] = P[m, 1]


@numba.njit(cache=True, fastmath=False)
def _advance(quads, points, profile, tick, ticks, dt, consts, history):
    """:func:`advance` for one parameter set without a per-axis limit (every scenario but W20 Ch. 5's)."""
    _advance_body(quads, points, profile, tick, ticks, dt, consts, history, False)


@numba.njit(cache=True, fastmath=False)
def _advance_general(quads, points, profile, tick, ticks, dt, consts, history):
    """:func:`advance` for rows of several parameter sets or a per-axis limit (``max_roll_pitch``)."""
    _advance_body(quads, points, profile, tick, ticks, dt, consts, history, True)


def _constants(params: QuadrotorParams) -> list[float]:
    g, a_max, a_max_g, kp, kd, alpha_max, f_max, angle_max = params._consts
    alpha = np.broadcast_to(np.asarray(alpha_max, dtype=float).ravel(), (2,))
    return [float(g), float(a_max), float(a_max_g), float(kp), float(kd), float(alpha[0]), float(alpha[1]),
            float(f_max), float(angle_max)]


def params_tuple(params: QuadrotorParams | RowParams) -> tuple[np.ndarray, np.ndarray]:
    """The constants :func:`advance` takes: ``(table, index)``, ``table`` (K, 9) one row
    ``(g, a_max, a_max/g, kp, kd, α_max,φ, α_max,θ, f_max, angle_max)`` per parameter set (``angle_max`` the per-axis
    setpoint saturation ``max_roll_pitch``, ``inf`` when None) and ``index`` (M,) each quadrotor's row, empty for
    one :class:`~swarmtrack.vehicles.quadrotor.QuadrotorParams` (every quadrotor on row 0)."""
    if isinstance(params, RowParams):
        return (np.array([_constants(p) for p in params.sets], dtype=float),
                np.ascontiguousarray(params.index, dtype=np.int64))
    return np.array([_constants(params)], dtype=float), np.zeros(0, dtype=np.int64)


def advance(quads: tuple, points: tuple, profile: tuple, tick: int, ticks: int, dt: float, consts: tuple,
            history) -> None:
    """Advance every vehicle by ``ticks`` physics ticks from tick ``tick``, **in place**.

    ``quads`` = ``(states, cmd, driver, obj)`` the quadrotors: states (Mq, 8), held commands (Mq, 2), drivers (Mq,)
    and object indices (Mq,); ``points`` = ``(states, cmd, driver, obj)`` the double integrators, states (Mp, 4)
    ``[x, y, vx, vy]``. A vehicle is either *driven* (``driver[m]`` = d ≥ 0: its autopilot flies the velocity
    profile ``v_cmd[:, d]`` with feed-forward ``a_ff[:, d]``, gain ``gains[d]`` and gust ``wind[:, d]``, the
    ``profile`` = ``(v_cmd, a_ff, wind, gains)``, the first three (K, D, 2) sampled at every tick) or *commanded*
    (−1: the acceleration ``cmd[m]`` is held over the ticks). ``consts`` from :func:`params_tuple`. ``history``
    (L, M, 2) is the ring buffer of past positions of the world's M objects (``obj`` gives each vehicle's object
    index): after tick ``k`` (global) slot ``(k + 1) mod L`` holds the positions; with L = 1 it is not kept. The
    kernel works on ``states.T`` (8, Mq), the layout :func:`~swarmtrack.vehicles.quadrotor.step` computes in: with
    the Fortran-ordered states it returns (which the world keeps) that is C-contiguous.
    """
    v_cmd, a_ff, wind, _ = profile
    if tick < 0 or tick + ticks > min(len(v_cmd), len(a_ff), len(wind)):
        raise IndexError(f"ticks {tick}..{tick + ticks - 1} are beyond the sampled profile ({len(v_cmd)} ticks)")
    table, index = consts
    if len(index) not in (0, len(quads[0])):
        raise ValueError(f"{len(index)} parameter rows for {len(quads[0])} quadrotors")
    general = len(index) > 0 or bool(np.isfinite(table[:, 8]).any())
    (_advance_general if general else _advance)(quads, points, profile, int(tick), int(ticks), float(dt), consts,
                                                history)



# --- kinematic vehicles (IB21 Sec. 6): walkers and fixed wings, stepped together ---------------------------------

#: Columns of a packed kinematic state (:func:`kinematic_step`): a walker's five, a fixed wing's seven.
PACK_WIDTH = 7


@numba.njit(cache=True)
def kinematic_step(S, members, trig, draws, tick, command, dt, out, angles, ok):  # pragma: no cover (compiled)
    """One tick of every member of a packed set of kinematic groups (rows of ``S`` (K, 7), in place into ``out``).

    ``members`` = ``(walker, v_dt, rate_max, area, group)`` the rows' constants; ``trig`` = ``(cos_h, sin_h, cos_g,
    sin_g)``. Row i is a walker (``walker[i]``; its five columns,
    :func:`swarmtrack.vehicles.ground_walker.step`'s rows inside the ``area[i]`` box, input ``draws[tick, i]``) or a
    fixed wing (its seven columns, :func:`swarmtrack.models.fixed_wing.step`'s rows, input ``command[i]``, yaw rate
    saturated at ``rate_max[i]``), with ``v_dt[i] = dt·speed``. ``cos_h``, ``sin_h`` are numpy's cosine and sine of
    each row's heading, ``cos_g``, ``sin_g`` of a fixed wing's γ. The products and sums are the per-group compiled
    passes' (``_step_inside``, ``_step_kernel``), so the numbers are the same. A walker that would cross a wall
    clears ``ok[group[i]]``: its group is stepped by the reference (its rows here are then not meaningful).
    ``angles`` (2K,) receives each new row's heading, then its γ (a walker's yaw rate, not used), for the next
    tick's trig. Returns the number of groups stepped by the reference."""
    walker, v_dt, rate_max, area, group = members
    cos_h, sin_h, cos_g, sin_g = trig
    ok[:] = True
    k_total = len(S)
    for i in range(k_total):
        if walker[i]:
            x = cos_h[i] * v_dt[i] + S[i, 0]
            y = sin_h[i] * v_dt[i] + S[i, 1]
            if x < area[i, 0] or x > area[i, 2] or y < area[i, 1] or y > area[i, 3]:
                ok[group[i]] = False
                continue
            out[i, 0] = x
            out[i, 1] = y
            out[i, 2] = S[i, 2] + dt * S[i, 3]
            out[i, 3] = S[i, 3] + dt * S[i, 4]
            out[i, 4] = draws[tick, i]
            out[i, 5] = 0.0
            out[i, 6] = 0.0
            angles[i] = out[i, 2]
        else:
            horizontal = v_dt[i] * cos_g[i]
            out[i, 0] = S[i, 0] + horizontal * cos_h[i]
            out[i, 1] = S[i, 1] + horizontal * sin_h[i]
            out[i, 2] = S[i, 2] + v_dt[i] * sin_g[i]
            out[i, 3] = S[i, 3]
            out[i, 4] = S[i, 4] + dt * S[i, 5]
            rate = S[i, 5] + dt * S[i, 6]
            if rate < -rate_max[i]:  # np.minimum(np.maximum(·)): NaN stays NaN
                rate = -rate_max[i]
            elif rate > rate_max[i]:
                rate = rate_max[i]
            out[i, 5] = rate
            out[i, 6] = command[i]
            angles[i] = out[i, 4]
        angles[k_total + i] = out[i, 3]
    failed = 0
    for g in range(len(ok)):
        failed += not ok[g]
    return failed


@numba.njit(cache=True)
def kinematic_truth(S, walker, speed, cos_h, sin_h, cos_g, objects, truth):  # pragma: no cover (compiled)
    """``[x, y, vx, vy]`` of every packed member into ``truth[objects[i]]``: the velocity ``speed·(cos, sin)`` of the
    heading for a walker, ``(speed·cos γ)·(cos ψ, sin ψ)`` for a fixed wing, as the modules' ``truth4`` compute it."""
    for i in range(len(S)):
        o = objects[i]
        factor = speed[i] if walker[i] else speed[i] * cos_g[i]
        truth[o, 0] = S[i, 0]
        truth[o, 1] = S[i, 1]
        truth[o, 2] = factor * cos_h[i]
        truth[o, 3] = factor * sin_h[i]


__all__ = ["advance", "kinematic_step", "kinematic_truth", "params_tuple"]
