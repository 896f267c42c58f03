"""A point moving at nearly constant velocity in a box: the targets of issue 40's multi-target benchmark (ten of
them in a 200 m x 200 m box, after the bouncing-box scenarios of the multi-sensor LMB filter libraries).

State ``(n, 5)`` = ``[x, y, vx, vy, heading]`` (m, m/s, rad). One tick of ``dt``: the velocity takes a white-noise
acceleration of power spectral density ``q`` (m²/s³: its variance grows by ``q`` a second), then the position moves
along it (semi-implicit Euler)::

    v⁺ = v + √(q·dt)·w,   w ~ N(0, I₂) drawn afresh every tick (:func:`draw_inputs`)
    p⁺ = p + dt·v⁺

folded back into the closed box ``area`` by specular reflection at every wall the tick's path crosses, the
velocity's component across that wall reversed (:func:`swarmtrack.vehicles.ground_walker.fold`, the walkers'
reflection). ``heading`` is the direction of the velocity, kept for the world (it reads every kinematic vehicle's
heading). A member starts at rest on its heading's line with speed ``speed``: ``v = speed·(cos h, sin h)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.vehicles.ground_walker import fold

X, Y, VX, VY, HEADING = range(5)
STATE_DIM = 5
STATE_NAMES = ("x", "y", "vx", "vy", "heading")


@dataclass(frozen=True)
class NearlyCVParams:
    """``speed`` each member's initial speed (m/s), ``accel_noise`` the acceleration's power spectral density q
    (m²/s³), ``area`` the box (x_min, y_min, x_max, y_max), m."""

    speed: float = 3.0
    accel_noise: float = 0.25
    area: tuple[float, float, float, float] = (-100.0, -100.0, 100.0, 100.0)

    def __post_init__(self) -> None:
        x0, y0, x1, y1 = self.area
        if not (x1 > x0 and y1 > y0):
            raise ValueError(f"area {self.area} is not a box (x_min, y_min, x_max, y_max)")


def initial_state(xy, heading, params: NearlyCVParams = NearlyCVParams()) -> np.ndarray:
    """``(n, 5)`` states at ``xy`` (n, 2) moving at ``params.speed`` along ``heading`` (n,)."""
    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    heading = np.broadcast_to(np.asarray(heading, dtype=float), (len(xy),))
    state = np.zeros((len(xy), STATE_DIM))
    state[:, X:Y + 1] = xy
    state[:, VX] = params.speed * np.cos(heading)
    state[:, VY] = params.speed * np.sin(heading)
    state[:, HEADING] = heading
    return state


def draw_inputs(rng: np.random.Generator, n_ticks: int, n: int, params: NearlyCVParams = NearlyCVParams()
                ) -> np.ndarray:
    """``(n_ticks, n, 2)`` standard normal draws, one pair per member and tick (scaled by :func:`step`)."""
    return rng.standard_normal((n_ticks, n, 2))


def step(state, w, params: NearlyCVParams = NearlyCVParams(), dt: float = 0.01, trig=None) -> np.ndarray:
    """One tick (module docstring) for ``n`` members; ``w`` (n, 2) this tick's standard normal draws. ``trig`` is
    not read (the signature every kinematic vehicle shares)."""
    s = np.asarray(state, dtype=float)
    v = s[:, VX:VY + 1] + np.sqrt(params.accel_noise * dt) * np.asarray(w, dtype=float).reshape(len(s), 2)
    p = s[:, X:Y + 1] + dt * v
    lo, hi = np.array(params.area[:2]), np.array(params.area[2:])
    crossed = (p < lo) | (p > hi)
    if crossed.any():
        folded, flip = fold(p, lo, hi)
        p = np.where(crossed, folded, p)
        v = np.where(crossed & flip, -v, v)
    out = np.empty_like(s)
    out[:, X:Y + 1] = p
    out[:, VX:VY + 1] = v
    out[:, HEADING] = np.arctan2(v[:, 1], v[:, 0])
    return out


#: Its own numbers are cheap (a few members): the compiled path is the reference.
step_compiled = step


def truth4(state, params: NearlyCVParams = NearlyCVParams(), trig=None) -> np.ndarray:
    """``(n, 4)`` ``[x, y, vx, vy]``."""
    return np.asarray(state, dtype=float)[:, :4].copy()
