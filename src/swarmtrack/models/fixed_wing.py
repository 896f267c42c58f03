"""Fixed-wing UAV kinematics at constant speed and altitude, steered by its yaw acceleration (IB21 Sec. 6).

The one copy of these equations: the world integrates them (:mod:`swarmtrack.vehicles.fixed_wing`) and the
set-membership MPC predicts its own UAV and its neighbours with them (:mod:`swarmtrack.control.sm_mpc`, IB21 eq. 1:
``x^u_{k+1} = f^u(x^u_k, u_k)``), so the prediction and the truth cannot drift apart. Batched over any leading axes:
:func:`step` pure numpy, :func:`rollout` numpy's trig with compiled loops (:func:`rollout_reference` its numpy
twin, the same numbers).

State ``(..., 7)`` = ``[x1, x2, x3, x4, x5, x6, x7]`` = ``[x, y, z, γ, ψ, ψ̇, ψ̈]``: ground position (m), altitude (m),
flight-path angle (rad), heading (rad, not wrapped), yaw rate (rad/s), yaw acceleration (rad/s²). One Euler tick of
``T_d`` (IB21 Sec. 6, the UAV rows; rows 5-6 are printed with superscript t, read u):

* ``x1⁺ = x1 + T_d·V·cos x4·cos x5``
* ``x2⁺ = x2 + T_d·V·cos x4·sin x5``
* ``x3⁺ = x3 + T_d·V·sin x4``
* ``x4⁺ = x4``
* ``x5⁺ = x5 + T_d·x6``
* ``x6⁺ = sat(x6 + T_d·x7)``, ``sat`` the clip to ``±yaw_rate_max`` (ours, see :class:`FixedWingParams`)
* ``x7⁺ = u``

The input ``u`` is the *new* yaw acceleration ("the control input is applied to x7"): every row reads the state at
``k``, so ``u_k`` is stored in ``x7`` at ``k+1``, changes the yaw rate at ``k+2`` and the heading at ``k+3``, and the
position from ``k+4``. This one-tick delay is the equations' own, kept as printed. ``x7`` keeps the commanded value
even while the yaw rate is saturated (it is the input, not an achieved acceleration).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

X, Y, Z, GAMMA, PSI, PSI_DOT, PSI_DDOT = range(7)
STATE_DIM = 7
STATE_NAMES = ("x", "y", "z", "gamma", "psi", "psi_dot", "psi_ddot")
#: IB21 Sec. 6: T_d = 0.05 s.
T_D = 0.05


@dataclass(frozen=True)
class FixedWingParams:
    """IB21 Sec. 6 UAV constants.

    * ``speed`` V^u = 16.6 m/s and ``altitude`` x3 = 100 m: the paper's (γ = x4 = 0 is the initial state's).
    * ``yaw_rate_max`` = 0.6 rad/s: **ours**; the paper bounds no yaw rate (only "u ∈ U"). A coordinated turn at
      bank φ has ψ̇ = g·tan φ / V: 0.6 rad/s is ≈ 45° of bank at 16.6 m/s (0.59 rad/s), a turn radius of ≈ 28 m.
      Without it a greedy MPC can wind the yaw rate up without bound. ``inf`` switches it off.
    """

    speed: float = 16.6
    altitude: float = 100.0
    yaw_rate_max: float = 0.6


#: The paper's UAV (and our yaw-rate bound).
DEFAULT_PARAMS = FixedWingParams()


def step(state, u, params: FixedWingParams = DEFAULT_PARAMS, dt: float = T_D, trig=None) -> np.ndarray:
    """One tick of the IB21 Sec. 6 UAV rows: returns a new ``(..., 7)`` array.

    ``u`` is the new yaw acceleration in rad/s², shape ``(...)`` or ``(..., 1)`` (broadcast against the state's
    leading axes), stored in x7 (one-tick delay, see the module docstring); the yaw rate is saturated at
    ``±params.yaw_rate_max``. ``trig``: the ``(cos ψ, sin ψ)`` of the state's heading x5 if the caller has them
    (the world computes them once per tick; the same numbers).
    """
    s = np.asarray(state, dtype=float)
    u = np.asarray(u, dtype=float)
    if u.ndim == s.ndim and u.ndim > 0 and u.shape[-1] == 1:
        u = u[..., 0]
    lead = s.shape[:-1] if u.shape == s.shape[:-1] else np.broadcast_shapes(s.shape[:-1], u.shape)
    if s.shape[:-1] != lead:
        s = np.broadcast_to(s, lead + (STATE_DIM,))
        trig = None
    cos_psi, sin_psi = (np.cos(s[..., PSI]), np.sin(s[..., PSI])) if trig is None else trig
    v_dt = dt * params.speed
    horizontal = v_dt * np.cos(s[..., GAMMA])
    out = np.empty(lead + (STATE_DIM,))
    out[..., X] = s[..., X] + horizontal * cos_psi
    out[..., Y] = s[..., Y] + horizontal * sin_psi
    out[..., Z] = s[..., Z] + v_dt * np.sin(s[..., GAMMA])
    out[..., GAMMA] = s[..., GAMMA]
    out[..., PSI] = s[..., PSI] + dt * s[..., PSI_DOT]
    # np.clip as min(max(·)), as :func:`rollout`: the same numbers with less overhead
    out[..., PSI_DOT] = np.minimum(np.maximum(s[..., PSI_DOT] + dt * s[..., PSI_DDOT], -params.yaw_rate_max),
                                   params.yaw_rate_max)
    out[..., PSI_DDOT] = u
    return out


def rollout(state, inputs, ticks: int, params: FixedWingParams = DEFAULT_PARAMS,
            dt: float = T_D) -> np.ndarray:
    """The states at the end of each held input: ``inputs`` (..., h) yaw accelerations, each held for ``ticks``
    ticks of :func:`step` (IB21 Sec. 5: the input is held over the control period ``T^c = ticks·T_d``), from
    ``state`` (..., 7) (leading axes broadcast). Returns ``(..., h, 7)``: x at ``k+1, …, k+h`` control periods.

    The same numbers as :func:`rollout_reference` (the rows of :func:`step` tick by tick), in three passes: the
    rows x5-x7 do not read the position, so every tick's heading comes first (:func:`_headings`, compiled), then
    the cosines and sines of all of them in one numpy call each (numpy's own trig, as the reference), then the
    position rows x1-x3 (:func:`_positions`, compiled, the same sums in the same order)."""
    inputs = np.asarray(inputs, dtype=float)
    s = np.asarray(state, dtype=float)
    lead = np.broadcast_shapes(s.shape[:-1], inputs.shape[:-1])
    h = inputs.shape[-1]
    flat = np.ascontiguousarray(np.broadcast_to(s, lead + (STATE_DIM,)).reshape(-1, STATE_DIM))
    u_all = np.ascontiguousarray(np.broadcast_to(inputs, lead + (h,)).reshape(-1, h))
    out = np.empty((flat.shape[0], h, STATE_DIM))
    psi = _headings(flat, u_all, ticks, dt, params.yaw_rate_max, out)  # (h·ticks, M): ψ at the start of each tick
    v_dt = dt * params.speed
    g = flat[:, GAMMA]
    _positions(flat, v_dt * np.cos(g), v_dt * np.sin(g), np.cos(psi), np.sin(psi), ticks, out)
    return out.reshape(lead + (h, STATE_DIM))


@numba.njit(cache=True)
def _headings(flat, u_all, ticks, dt, rate_max, out):
    """Rows x5-x7 of :func:`step` (x4 kept) for ``ticks`` ticks per input: writes them into ``out`` (M, h, 7) at the
    end of each input and returns the heading at the start of every tick (h·ticks, M). The saturation is written
    as ``np.minimum(np.maximum(·))`` behaves (a NaN stays NaN)."""
    m, h = u_all.shape
    psis = np.empty((h * ticks, m))
    lo, hi = -rate_max, rate_max
    for q in range(m):
        psi, rate, acc = flat[q, PSI], flat[q, PSI_DOT], flat[q, PSI_DDOT]
        for k in range(h):
            u = u_all[q, k]
            for t in range(ticks):
                psis[k * ticks + t, q] = psi
                nxt = rate + dt * acc
                if nxt < lo:
                    nxt = lo
                if nxt > hi:
                    nxt = hi
                psi, rate, acc = psi + dt * rate, nxt, u
            out[q, k, GAMMA], out[q, k, PSI], out[q, k, PSI_DOT], out[q, k, PSI_DDOT] = flat[q, GAMMA], psi, rate, acc
    return psis


@numba.njit(cache=True)
def _positions(flat, horizontal, climb, cos_psi, sin_psi, ticks, out):
    """Rows x1-x3 of :func:`step` from the headings' cosines and sines (h·ticks, M) (:func:`_headings`): writes the
    position at the end of each input into ``out`` (M, h, 7)."""
    m, h = out.shape[0], out.shape[1]
    for q in range(m):
        x, y, z = flat[q, X], flat[q, Y], flat[q, Z]
        for k in range(h):
            for t in range(k * ticks, (k + 1) * ticks):
                x, y, z = x + horizontal[q] * cos_psi[t, q], y + horizontal[q] * sin_psi[t, q], z + climb[q]
            out[q, k, X], out[q, k, Y], out[q, k, Z] = x, y, z


def rollout_reference(state, inputs, ticks: int, params: FixedWingParams = DEFAULT_PARAMS,
            dt: float = T_D) -> np.ndarray:
    """The states at the end of each held input: ``inputs`` (..., h) yaw accelerations, each held for ``ticks``
    ticks of :func:`step` (IB21 Sec. 5: the input is held over the control period ``T^c = ticks·T_d``), from
    ``state`` (..., 7) (leading axes broadcast). Returns ``(..., h, 7)``: x at ``k+1, …, k+h`` control periods.
    The readable reference of :func:`rollout` (numpy, tick by tick)."""
    inputs = np.asarray(inputs, dtype=float)
    s = np.asarray(state, dtype=float)
    lead = np.broadcast_shapes(s.shape[:-1], inputs.shape[:-1])
    h = inputs.shape[-1]
    # the rows of :func:`step`, written on flat columns (same operations in the same order: the same numbers)
    x, y, z, g, psi, rate, acc = (np.array(np.broadcast_to(s[..., j], lead), dtype=float).ravel()
                                  for j in range(STATE_DIM))
    u_all = np.broadcast_to(inputs, lead + (h,)).reshape(-1, h)
    v_dt = dt * params.speed
    out = np.empty((x.size, h, STATE_DIM))
    # γ (x4) never changes: its terms are the same numbers every tick, computed once; np.clip as min(max(·)),
    # the same numbers with less overhead
    horizontal, climb = v_dt * np.cos(g), v_dt * np.sin(g)
    lo, hi = -params.yaw_rate_max, params.yaw_rate_max
    for m in range(h):
        u = np.ascontiguousarray(u_all[:, m])
        for _ in range(ticks):
            x, y, z, psi, rate, acc = (x + horizontal * np.cos(psi), y + horizontal * np.sin(psi),
                                       z + climb, psi + dt * rate,
                                       np.minimum(np.maximum(rate + dt * acc, lo), hi), u)
        out[:, m] = np.stack([x, y, z, g, psi, rate, acc], axis=-1)
    return out.reshape(lead + (h, STATE_DIM))
