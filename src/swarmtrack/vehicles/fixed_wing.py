"""Fixed-wing UAV at constant speed and altitude, steered by its yaw acceleration (IB21 Sec. 6): the truth side.

The kinematics (state ``(n, 7)`` = ``[x, y, z, γ, ψ, ψ̇, ψ̈]``, the Sec. 6 rows, the input applied through x7 with its
one-tick delay, the yaw-rate saturation) live in :mod:`swarmtrack.models.fixed_wing`, shared with the onboard MPC
that predicts them (one copy); this module re-exports them and adds what only the world needs: the initial state
and the ``[x, y, vx, vy]`` truth.
"""

from __future__ import annotations

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


def initial_state(xy, heading, params: FixedWingParams = DEFAULT_PARAMS) -> np.ndarray:
    """``(n, 7)`` states at ``xy`` (n, 2) with heading ``heading`` (n,), level (γ = 0) at ``params.altitude``,
    zero yaw rate and yaw acceleration (IB21 Sec. 6 gives only the altitude and γ; the rest is our choice)."""
    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    state = np.zeros((len(xy), STATE_DIM))
    state[:, X:Y + 1] = xy
    state[:, Z] = params.altitude
    state[:, PSI] = heading
    return state


def truth4(state, params: FixedWingParams = DEFAULT_PARAMS) -> np.ndarray:
    """``(n, 4)`` ``[x, y, vx, vy]``: the ground position and the ground velocity ``V·cos γ·(cos ψ, sin ψ)`` the
    next tick flies (the speed is a parameter, not part of the state)."""
    s = np.asarray(state, dtype=float)
    horizontal = params.speed * np.cos(s[:, GAMMA])
    return np.stack([s[:, X], s[:, Y], horizontal * np.cos(s[:, PSI]), horizontal * np.sin(s[:, PSI])], axis=-1)
