"""Fixed-wing UAV at constant speed and altitude, steered by its yaw acceleration (IB21 Sec. 6): the truth side.

The kinematics (state ``(n, 7)`` = ``[x, y, z, γ, ψ, ψ̇, ψ̈]``, the Sec. 6 rows, the input applied through x7 with its
one-tick delay, the yaw-rate saturation) live in :mod:`swarmtrack.models.fixed_wing`, shared with the onboard MPC
that predicts them (one copy); this module re-exports them and adds what only the world needs: the initial state
and the ``[x, y, vx, vy]`` truth.
"""

from __future__ import annotations

import numba
import numpy as np

from swarmtrack.models.fixed_wing import (  # noqa: F401 (re-exported: the vehicle's kinematics)
    DEFAULT_PARAMS,
    GAMMA,
    PSI,
    PSI_DDOT,
    PSI_DOT,
    STATE_DIM,
    STATE_NAMES,
    T_D,
    FixedWingParams,
    X,
    Y,
    Z,
    step,
)

#: The state's heading column (ψ), under the name :mod:`swarmtrack.vehicles.ground_walker` gives its own.
HEADING = PSI


def initial_state(xy, heading, params: FixedWingParams = DEFAULT_PARAMS) -> np.ndarray:
    """``(n, 7)`` states at ``xy`` (n, 2) with heading ``heading`` (n,), level (γ = 0) at ``params.altitude``,
    zero yaw rate and yaw acceleration (IB21 Sec. 6 gives only the altitude and γ; the rest is our choice)."""
    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    state = np.zeros((len(xy), STATE_DIM))
    state[:, X:Y + 1] = xy
    state[:, Z] = params.altitude
    state[:, PSI] = heading
    return state


def truth4(state, params: FixedWingParams = DEFAULT_PARAMS, trig=None) -> np.ndarray:
    """``(n, 4)`` ``[x, y, vx, vy]``: the ground position and the ground velocity ``V·cos γ·(cos ψ, sin ψ)`` the
    next tick flies (the speed is a parameter, not part of the state). ``trig``: the ``(cos ψ, sin ψ)`` of the
    heading if the caller has them (as :func:`step` takes them)."""
    s = np.asarray(state, dtype=float)
    cos_psi, sin_psi = (np.cos(s[:, PSI]), np.sin(s[:, PSI])) if trig is None else trig
    horizontal = params.speed * np.cos(s[:, GAMMA])
    out = np.empty((len(s), 4))
    out[:, :2] = s[:, X:Y + 1]
    out[:, 2] = horizontal * cos_psi
    out[:, 3] = horizontal * sin_psi
    return out


def step_compiled(state, u, params: FixedWingParams = DEFAULT_PARAMS, dt: float = T_D, trig=None) -> np.ndarray:
    """:func:`step` (the readable reference, :mod:`swarmtrack.models.fixed_wing`; tested equal) of ``n`` UAVs in one
    compiled pass (:func:`_step_kernel`) with its products, sums and saturation in its order; the sines and cosines
    are numpy's (``trig``, the ``(cos ψ, sin ψ)`` the caller has, or computed here), so the numbers are the same.
    ``state`` (n, 7), ``u`` (n,) or (n, 1); no broadcasting (the world's own use)."""
    s = np.ascontiguousarray(state, dtype=float)
    if trig is None:
        trig = np.cos(s[:, PSI]), np.sin(s[:, PSI])
    gamma = s[:, GAMMA]
    out = np.empty_like(s)
    _step_kernel(s, np.asarray(u, dtype=float).reshape(len(s)), np.cos(gamma), np.sin(gamma), *trig,
                 dt * params.speed, dt, params.yaw_rate_max, out)
    return out


@numba.njit(cache=True)
def _step_kernel(s, u, cos_gamma, sin_gamma, cos_psi, sin_psi, v_dt, dt, rate_max, out):  # pragma: no cover
    """:func:`step`'s rows, one UAV at a time, into ``out``."""
    for i in range(len(s)):
        horizontal = v_dt * cos_gamma[i]
        out[i, X] = s[i, X] + horizontal * cos_psi[i]
        out[i, Y] = s[i, Y] + horizontal * sin_psi[i]
        out[i, Z] = s[i, Z] + v_dt * sin_gamma[i]
        out[i, GAMMA] = s[i, GAMMA]
        out[i, PSI] = s[i, PSI] + dt * s[i, PSI_DOT]
        rate = s[i, PSI_DOT] + dt * s[i, PSI_DDOT]
        if rate < -rate_max:  # np.minimum(np.maximum(·)): NaN stays NaN
            rate = -rate_max
        elif rate > rate_max:
            rate = rate_max
        out[i, PSI_DOT] = rate
        out[i, PSI_DDOT] = u[i]
