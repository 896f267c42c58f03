"""Fixed-wing UAV at constant speed and altitude, steered by its yaw acceleration (IB21 Sec. 6).

State ``(n, 7)`` = ``[x1, x2, x3, x4, x5, x6, x7]`` = ``[x, y, z, γ, ψ, ψ̇, ψ̈]``: ground position (m), altitude (m),
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


def initial_state(xy, heading, params: FixedWingParams = FixedWingParams()) -> np.ndarray:
    """``(n, 7)`` states at ``xy`` (n, 2) with heading ``heading`` (n,), level (γ = 0) at ``params.altitude``,
    zero yaw rate and yaw acceleration (IB21 Sec. 6 gives only the altitude and γ; the rest is our choice)."""
    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    state = np.zeros((len(xy), STATE_DIM))
    state[:, X:Y + 1] = xy
    state[:, Z] = params.altitude
    state[:, PSI] = heading
    return state


def step(state, u, params: FixedWingParams = FixedWingParams(), dt: float = T_D) -> np.ndarray:
    """One tick of the IB21 Sec. 6 UAV rows for ``n`` UAVs: returns a new ``(n, 7)`` array.

    ``u`` (n,) (or (n, 1)) is the new yaw acceleration in rad/s², stored in x7 (one-tick delay, see the module
    docstring); the yaw rate is saturated at ``±params.yaw_rate_max``.
    """
    s = np.asarray(state, dtype=float)
    u = np.asarray(u, dtype=float).reshape(len(s))
    v_dt = dt * params.speed
    horizontal = v_dt * np.cos(s[:, GAMMA])
    out = np.empty_like(s)
    out[:, X] = s[:, X] + horizontal * np.cos(s[:, PSI])
    out[:, Y] = s[:, Y] + horizontal * np.sin(s[:, PSI])
    out[:, Z] = s[:, Z] + v_dt * np.sin(s[:, GAMMA])
    out[:, GAMMA] = s[:, GAMMA]
    out[:, PSI] = s[:, PSI] + dt * s[:, PSI_DOT]
    out[:, PSI_DOT] = np.clip(s[:, PSI_DOT] + dt * s[:, PSI_DDOT], -params.yaw_rate_max, params.yaw_rate_max)
    out[:, PSI_DDOT] = u
    return out


def truth4(state, params: FixedWingParams = FixedWingParams()) -> np.ndarray:
    """``(n, 4)`` ``[x, y, vx, vy]``: the ground position and the ground velocity ``V·cos γ·(cos ψ, sin ψ)`` the
    next tick flies (the speed is a parameter, not part of the state)."""
    s = np.asarray(state, dtype=float)
    horizontal = params.speed * np.cos(s[:, GAMMA])
    return np.stack([s[:, X], s[:, Y], horizontal * np.cos(s[:, PSI]), horizontal * np.sin(s[:, PSI])], axis=-1)
