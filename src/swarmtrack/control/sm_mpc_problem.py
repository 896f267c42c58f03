"""The SM-MPC's problem (IB21 Sec. 5, eqs. 38-49), shared by its two planners (:mod:`swarmtrack.control.sm_mpc` on
polygon sets, :mod:`swarmtrack.control.sm_mpc_raster` on raster sets): the constants (:class:`SMMPCSettings`), the
candidates U_d^h in tie order, the predicted states x^P (eq. 1) and their footprints, what each round removes
(eqs. 46, 48-49, :func:`removals`), and the choice of eq. 47's minimiser with the tie rule (:func:`choose`).

Below both planners, so neither imports the other for these (the polygon planner hands raster sets to the raster
one); read :mod:`swarmtrack.control.sm_mpc`'s docstring for the controller they make.
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass, field

import numpy as np
import shapely

from swarmtrack.estimation import polygons as pg
from swarmtrack.models import fixed_wing as fw
from swarmtrack.sensors.footprint import OPENING, footprint_corners, footprint_polygons, tan_half

DISTANCES = ("nearest", "hausdorff")


@dataclass(frozen=True)
class SMMPCSettings:
    """IB21 Sec. 5-6 SM-MPC constants and our choices (brief §2.6, A8, A10):

    * ``inputs`` U_d (rad/s², yaw accelerations; ours: {0, ±0.25, ±0.5}), ``horizon`` h = 2, ``period`` T^c = 0.5 s,
      ``tick`` T_d = 0.05 s (the prediction step), ``alpha`` α = 1e-4 (Sec. 6), ``distance`` (A10);
    * ``target_speed`` V^t (m/s, the dilation per period is V^t·T^c), ``comm_range`` d^c = 200 m (eq. 48);
    * ``uav`` the fixed-wing constants of the prediction model; the footprint: ``tan_half`` (full π/4 opening),
      ``orientation`` (as :mod:`swarmtrack.sensors.footprint`);
    * ``baseline`` (SimpleBaselineMPC), ``exact`` (reference cost on the full sets), ``quad_segs`` of the dilation.
    """

    inputs: tuple[float, ...] = (0.0, 0.25, -0.25, 0.5, -0.5)
    horizon: int = 2
    period: float = 0.5
    tick: float = fw.T_D
    alpha: float = 1e-4
    distance: str = "nearest"
    target_speed: float = 1.0
    comm_range: float = 200.0
    uav: fw.FixedWingParams = fw.DEFAULT_PARAMS
    tan_half: float = field(default=tan_half(OPENING, "full"))
    orientation: str = "heading"
    baseline: bool = False
    exact: bool = False
    quad_segs: int = pg.QUAD_SEGS

    def __post_init__(self) -> None:
        if self.distance not in DISTANCES:
            raise ValueError(f"distance must be one of {DISTANCES}, not {self.distance!r}")
        if not len(self.inputs):
            raise ValueError("inputs must not be empty")
        if self.horizon < 1:
            raise ValueError("horizon must be at least 1")
        if abs(self.period / self.tick - round(self.period / self.tick)) > 1e-9 or self.period < self.tick:
            raise ValueError(f"period {self.period} s must be a whole multiple of the tick {self.tick} s")

    @property
    def ticks(self) -> int:
        """Prediction ticks per control period."""
        return int(round(self.period / self.tick))

    @property
    def reach(self) -> float:
        """ρ: the buffer distance of one eq. 44 dilation (circumscribing the disc of radius V^t·T^c)."""
        return pg.circumscribed(self.target_speed * self.period, self.quad_segs)


DEFAULT_SETTINGS = SMMPCSettings()


# --- candidates and predictions ----------------------------------------------------------------------------------


def input_order(inputs) -> np.ndarray:
    """U_d in tie-breaking order: increasing ``|u|`` (so 0 first), equal ``|u|`` in the order given."""
    u = np.asarray(inputs, dtype=float)
    return u[np.argsort(np.abs(u), kind="stable")]


def candidates(inputs, horizon: int) -> np.ndarray:
    """All sequences of U_d^h (C, h), C = |U_d|^h, lexicographic over :func:`input_order`, first input major (so
    candidates sharing a prefix of length κ are contiguous blocks of ``|U_d|^(h−κ)``). A fresh copy of a table built
    once per (inputs, horizon)."""
    return _candidates(tuple(float(u) for u in np.atleast_1d(inputs)), int(horizon)).copy()


@functools.lru_cache(maxsize=64)
def _candidates(inputs: tuple[float, ...], horizon: int) -> np.ndarray:
    order = input_order(inputs)
    return np.array(list(itertools.product(order, repeat=horizon)), dtype=float).reshape(-1, horizon)


def predict(state, plans, s: SMMPCSettings = DEFAULT_SETTINGS) -> np.ndarray:
    """x^P at k+1 … k+h (eq. 1 with the Sec. 6 model): ``state`` (..., 7) and ``plans`` (..., h) broadcast,
    returns (..., h, 7)."""
    return fw.rollout(state, plans, s.ticks, s.uav, s.tick)


def footprints(states, s: SMMPCSettings = DEFAULT_SETTINGS) -> np.ndarray:
    """Footprint corners (..., 4, 2) of predicted states (..., 7) (:func:`swarmtrack.sensors.footprint.
    footprint_corners`, the sensor's own geometry, at the predicted altitude x3 and heading x5)."""
    st = np.asarray(states, dtype=float)
    flat = st.reshape(-1, fw.STATE_DIM)
    c = footprint_corners(flat[:, :2], flat[:, fw.PSI], flat[:, fw.Z], s.tan_half, s.orientation)
    return c.reshape(st.shape[:-1] + (4, 2))


# --- the rounds of eqs. 44-49 ------------------------------------------------------------------------------------


@dataclass
class Removals:
    """What each round removes (eqs. 46, 49), per level κ = 1 … h over the nodes of that level (the prefixes of
    length κ, |U_d|^κ of them): ``own`` (n_κ,) footprint polygons, ``xy`` (n_κ, 2) the UAV's predicted position,
    ``nb`` (L,) the neighbours' footprint polygons at step κ and ``kept`` (n_κ, L) eq. 48."""

    own: list[np.ndarray]
    xy: list[np.ndarray]
    nb: list[np.ndarray]
    kept: list[np.ndarray]
    corners: list[np.ndarray]  # own footprint corners per level (n_κ, 4, 2)
    nb_corners: np.ndarray  # (L, h, 4, 2)

    def neighbours(self, level: int, kept: np.ndarray) -> shapely.Geometry:
        """The union of the neighbours' footprints at ``level`` selected by ``kept`` (L,) bool."""
        return pg.union_all(self.nb[level][kept])


def removals(own_states: np.ndarray, nb_states: np.ndarray, s: SMMPCSettings,
             neighbours: bool = True, polygons: bool = True,
             corners: tuple[np.ndarray, np.ndarray | None] | None = None) -> Removals:
    """The per-level removals of one UAV: ``own_states`` (C, h, 7) its predicted states for every candidate,
    ``nb_states`` (L, h, 7) its lower-indexed neighbours' predicted states (eq. 48 with ``c = d^c − ‖Δp‖ ≥ 0``).
    ``polygons`` False: the corners only (``own`` and ``nb`` empty), for a planner that needs no shapely polygon.
    ``corners``: the footprints' corners (:func:`footprints`) of ``own_states`` and of ``nb_states`` (None: not
    known), when the caller has them already (:func:`plan_all` computes them once for the fleet)."""
    h = s.horizon
    branch = len(s.inputs)
    nb_states = nb_states if neighbours else nb_states[:0]
    own_corners, nb_corners = (None, None) if corners is None else corners
    if own_corners is None:
        own_corners = footprints(own_states, s)
    n_nb = len(nb_states)
    if not n_nb:  # no neighbour: no footprint to compute, nothing eq. 48 can keep
        nb_corners = np.zeros((0, h, 4, 2))
    elif nb_corners is None:
        nb_corners = footprints(nb_states, s)
    else:
        nb_corners = nb_corners[:n_nb]
    none = pg.empty(0)
    own, xy, nb, kept, corners = [], [], [], [], []
    for k in range(h):
        stride = branch ** (h - k - 1)  # the first candidate of every prefix of length k+1
        nodes = own_states[::stride, k]
        c = own_corners[::stride, k]
        corners.append(c)
        own.append(footprint_polygons(c) if polygons else none)
        xy.append(nodes[:, :2])
        nb.append(footprint_polygons(nb_corners[:, k]) if n_nb and polygons else none)
        if n_nb:
            gap = nodes[:, None, :2] - nb_states[None, :, k, :2]
            kept.append(np.einsum("nli,nli->nl", gap, gap) <= s.comm_range ** 2)
        else:
            kept.append(np.zeros((len(nodes), 0), dtype=bool))
    return Removals(own, xy, nb, kept, corners, nb_corners)


@dataclass
class Choice:
    """One UAV's plan: ``index`` of the chosen candidate, its ``plan`` (h,), ``cost`` (C,) eq. 47 per candidate
    (local: up to a constant), ``area`` (C,) and ``distance`` (C,) its terms, ``ops`` the set operations used."""

    index: int
    plan: np.ndarray
    cost: np.ndarray
    area: np.ndarray
    distance: np.ndarray
    ops: int = 0
    window: tuple[float, float, float, float] | None = None


def choose(cost: np.ndarray, rel: float = 1e-12, abs_tol: float = 1e-9) -> int:
    """The first candidate within round-off of the minimum (the tie order is the candidates' order)."""
    cost = np.asarray(cost)
    best = cost.min()
    near = cost <= best + abs_tol + rel * abs(best)
    first = int(near.argmax())  # the first True (argmax of a bool array stops at it)
    if not near[first]:
        raise ValueError("no candidate is within round-off of the minimum (NaN costs?)")
    return first

