"""Ground object at constant speed with a randomly wandering heading: IB21's targets and decoys (IB21 Sec. 6).

State ``(n, 5)`` = ``[x1, x2, x3, x4, x5]`` = ``[x, y, heading, yaw rate, yaw acceleration]`` (m, m, rad, rad/s,
rad/s²). One Euler tick of ``T_d`` (IB21 Sec. 6, the target rows; "the false targets evolve according to the same
dynamics"):

* ``x1⁺ = x1 + T_d·V·cos x3``, ``x2⁺ = x2 + T_d·V·sin x3``
* ``x3⁺ = x3 + T_d·x4``
* ``x4⁺ = x4 + T_d·x5``
* ``x5⁺ = v``, ``v ~ U(−π/8, π/8)`` s⁻² drawn afresh every tick (:func:`draw_inputs`).

**Text versus equation.** The text says "the yaw rate derivative x5 follows a random walk with input v"; the
equation sets ``x5⁺ = v``, so x5 is white and the *yaw rate* x4 is the random walk. We follow the equation: the
yaw-rate increments have std ``T_d·(π/8)/√3``, so after ``t`` s its std is ``≈ 0.0507·√t`` rad/s (≈ 1 rad/s at
400 s; the yaw rate is not bounded). The text's reading would give a yaw acceleration of std ≈ 20 rad/s² at 400 s.

**Staying in the area** (the paper clips its sets to X0, so its targets never leave it; it does not say how).
Ours: specular reflection at the border of the closed box ``area = (x_min, y_min, x_max, y_max)``. The tick's
straight path of length ``V·T_d`` is folded back into the box at every wall it crosses (any number of walls, also
in a box thinner than ``V·T_d``), and the new heading ``x3⁺`` is mirrored with it: ``x3⁺ → π − x3⁺`` per crossing of a
vertical wall, ``x3⁺ → −x3⁺`` per horizontal one (a reflected heading is wrapped to (−π, π]). The folding is
1-Lipschitz per axis and the identity inside the box, so the displacement per tick stays ≤ ``V·T_d`` (the disc
prediction of IB21 eqs. 13-15 stays valid) and an object inside the closed box stays inside it. The yaw rate and
yaw acceleration are not mirrored (the mirrored walk is still a walk of the same law). The state must start inside
the area.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

X, Y, HEADING, YAW_RATE, YAW_ACCEL = range(5)
STATE_DIM = 5
STATE_NAMES = ("x", "y", "heading", "yaw_rate", "yaw_accel")
#: IB21 Sec. 6: T_d = 0.05 s.
T_D = 0.05


@dataclass(frozen=True)
class WalkerParams:
    """IB21 Sec. 6 target (and decoy) constants: ``speed`` V^t = 1 m/s (1.0-1.8 in Fig. 9), ``yaw_accel_bound``
    π/8 s⁻² (the half-width of v's uniform law), ``area`` X0 = (x_min, y_min, x_max, y_max) in m, a 400 × 400 m
    square (its placement at [0, 400]² is ours)."""

    speed: float = 1.0
    yaw_accel_bound: float = math.pi / 8
    area: tuple[float, float, float, float] = (0.0, 0.0, 400.0, 400.0)

    def __post_init__(self) -> None:
        x0, y0, x1, y1 = self.area
        if not (x1 > x0 and y1 > y0):
            raise ValueError(f"area {self.area} is not a box (x_min, y_min, x_max, y_max)")


def initial_state(xy, heading, params: WalkerParams | None = None) -> np.ndarray:
    """``(n, 5)`` states at ``xy`` (n, 2) with heading ``heading`` (n,), zero yaw rate and yaw acceleration (ours:
    the paper gives no initial heading or rates). ``params`` is not read (the signature every kinematic vehicle
    shares, :class:`swarmtrack.vehicles.base.KinematicModel`)."""
    xy = np.atleast_2d(np.asarray(xy, dtype=float))
    state = np.zeros((len(xy), STATE_DIM))
    state[:, X:Y + 1] = xy
    state[:, HEADING] = heading
    return state


def draw_inputs(rng: np.random.Generator, n_ticks: int, n: int, params: WalkerParams = WalkerParams()) -> np.ndarray:
    """``(n_ticks, n)`` yaw-acceleration draws ``v ~ U(−bound, bound)`` (IB21 Sec. 6), one row per tick."""
    b = params.yaw_accel_bound
    return rng.uniform(-b, b, size=(n_ticks, n))


def fold(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``p`` (..., 2) folded into the box ``[lo, hi]`` by specular reflection at its walls, and per axis whether it
    crossed an odd number of walls (its direction along that axis is reversed)."""
    width = hi - lo
    k = np.floor((p - lo) / width)
    q = (p - lo) - k * width  # in [0, width) up to rounding
    odd = np.mod(k, 2.0) != 0.0
    # the projection on the box is non-expansive, so it cannot undo the displacement bound
    return np.clip(lo + np.where(odd, width - q, q), lo, hi), odd


def _wrap(a: np.ndarray) -> np.ndarray:
    return math.pi - np.mod(math.pi - a, 2.0 * math.pi)


def step(state, v, params: WalkerParams = WalkerParams(), dt: float = T_D, trig=None) -> np.ndarray:
    """One tick of the IB21 Sec. 6 target rows for ``n`` objects, reflected at the area's border (module
    docstring); ``v`` (n,) is this tick's yaw-acceleration draw. Returns a new ``(n, 5)`` array. ``trig``: the
    ``(cos, sin)`` of the heading x3 if the caller has them (the world computes them once per tick; the same
    numbers)."""
    s = np.asarray(state, dtype=float)
    cos_h, sin_h = _trig(s) if trig is None else trig
    v_dt = dt * params.speed
    out = np.empty_like(s)
    p = np.empty((len(s), 2))
    np.multiply(cos_h, v_dt, out=p[:, 0])
    np.multiply(sin_h, v_dt, out=p[:, 1])
    p += s[:, X:Y + 1]
    heading = s[:, HEADING] + dt * s[:, YAW_RATE]
    lo, hi = np.array(params.area[:2]), np.array(params.area[2:])
    crossed = (p < lo) | (p > hi)
    if crossed.any():  # most ticks of most objects cross no wall: they skip the folding (and its rounding)
        folded, flip = fold(p, lo, hi)
        p = np.where(crossed, folded, p)
        flip &= crossed
        mirrored = np.where(flip[:, 1], -heading, heading)
        mirrored = np.where(flip[:, 0], math.pi - mirrored, mirrored)
        heading = np.where(flip.any(axis=1), _wrap(mirrored), heading)
    out[:, X:Y + 1] = p
    out[:, HEADING] = heading
    out[:, YAW_RATE] = s[:, YAW_RATE] + dt * s[:, YAW_ACCEL]
    out[:, YAW_ACCEL] = np.asarray(v, dtype=float).reshape(len(s))
    return out


def _trig(state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(cos x3, sin x3)`` (n,) of the states' headings: what :func:`step` and :func:`truth4` move along."""
    heading = state[:, HEADING]
    return np.cos(heading), np.sin(heading)


def step_compiled(state, v, params: WalkerParams = WalkerParams(), dt: float = T_D, trig=None) -> np.ndarray:
    """:func:`step` (its readable reference; tested equal), in one compiled pass (:func:`_step_inside`) when no
    object crosses a wall this tick, else :func:`step` itself. The pass does the reference's products and sums in its
    order (no math library: the sines and cosines are numpy's, given as ``trig`` or computed here), so it gives the
    same numbers. ``state`` (n, 5), ``v`` (n,)."""
    s = np.ascontiguousarray(state, dtype=float)
    if trig is None:
        trig = _trig(s)
    out = np.empty_like(s)
    x0, y0, x1, y1 = params.area
    if _step_inside(s, *trig, np.asarray(v, dtype=float).reshape(len(s)), dt * params.speed, dt, float(x0),
                    float(y0), float(x1), float(y1), out):
        return out
    return step(s, v, params, dt, trig)


@numba.njit(cache=True)
def _step_inside(s, cos_h, sin_h, v, v_dt, dt, x0, y0, x1, y1, out):  # pragma: no cover (compiled)
    """:func:`step`'s rows into ``out`` while no object crosses a wall; False as soon as one does."""
    for i in range(len(s)):
        x = cos_h[i] * v_dt + s[i, X]
        y = sin_h[i] * v_dt + s[i, Y]
        if x < x0 or x > x1 or y < y0 or y > y1:
            return False
        out[i, X] = x
        out[i, Y] = y
        out[i, HEADING] = s[i, HEADING] + dt * s[i, YAW_RATE]
        out[i, YAW_RATE] = s[i, YAW_RATE] + dt * s[i, YAW_ACCEL]
        out[i, YAW_ACCEL] = v[i]
    return True


def truth4(state, params: WalkerParams = WalkerParams(), trig=None) -> np.ndarray:
    """``(n, 4)`` ``[x, y, vx, vy]``: the position and the velocity ``V·(cos x3, sin x3)`` the next tick moves
    along (before any reflection). ``trig``: as in :func:`step`."""
    s = np.asarray(state, dtype=float)
    cos_h, sin_h = _trig(s) if trig is None else trig
    out = np.empty((len(s), 4))
    out[:, :2] = s[:, X:Y + 1]
    out[:, 2] = params.speed * cos_h
    out[:, 3] = params.speed * sin_h
    return out
