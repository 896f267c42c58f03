"""The raster representation of IB21's guaranteed sets (:mod:`swarmtrack.estimation.raster` explains it): the
:class:`Grid` of square cells over the area, the :class:`Field` of distance lower bounds that holds one set on it, and
what a single field gives: its member cells, its area φ, its centroid, the guarantee's check :func:`holds` and a
polygon to draw. The set operations (:mod:`swarmtrack.estimation.raster`) and redistancing
(:mod:`swarmtrack.estimation.raster_distance`) build on these; ``raster`` re-exports every name here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np
import shapely

#: Inner margin (m) of a removed footprint, and the round-off allowance of the member test.
DELTA = 1e-6


@dataclass(frozen=True)
class Grid:
    """Square cells of side ``cell`` (m), ``ny`` rows by ``nx`` columns, the first cell's lower-left corner at
    ``(x0, y0)``: cell (i, j) is the square ``[x0 + j c, x0 + (j+1) c] × [y0 + i c, y0 + (i+1) c]``, its centre
    the point where its value is a lower bound. ``outside`` (ny, nx) or None: the distance from each centre to X0
    when X0 is not the grid's own rectangle (a clip is then ``max(v, outside)``)."""

    x0: float
    y0: float
    cell: float
    nx: int
    ny: int
    outside: np.ndarray | None = None

    @classmethod
    def over(cls, area, cell: float) -> Grid:
        """The grid of cells of side ``cell`` covering the area X0 (a shapely polygon) from its lower-left corner."""
        if not cell > 0:
            raise ValueError(f"the cell size must be positive, not {cell}")
        x0, y0, x1, y1 = area.bounds
        nx, ny = max(1, math.ceil((x1 - x0) / cell - 1e-9)), max(1, math.ceil((y1 - y0) / cell - 1e-9))
        grid = cls(float(x0), float(y0), float(cell), nx, ny)
        if shapely.equals(area, shapely.box(x0, y0, x0 + nx * cell, y0 + ny * cell)):
            return grid
        xx, yy = np.meshgrid(grid.xs, grid.ys)
        outside = shapely.distance(shapely.points(xx.ravel(), yy.ravel()), area).reshape(ny, nx)
        return cls(grid.x0, grid.y0, grid.cell, nx, ny, outside)

    @property
    def slack(self) -> float:
        """c/√2: a cell's square meets A only if its value is at most this (module docstring)."""
        return self.cell / math.sqrt(2.0)

    @property
    def xs(self) -> np.ndarray:
        """The centres' x (nx,)."""
        return self.x0 + (np.arange(self.nx) + 0.5) * self.cell

    @property
    def ys(self) -> np.ndarray:
        """The centres' y (ny,)."""
        return self.y0 + (np.arange(self.ny) + 0.5) * self.cell

    def span(self, lo: float, hi: float, axis: int) -> tuple[int, int]:
        """The cells ``[a, b)`` along ``axis`` (0: rows, y; 1: columns, x) whose squares meet ``[lo, hi]``, clipped to
        the grid (``a == b`` when none)."""
        origin, n = (self.y0, self.ny) if axis == 0 else (self.x0, self.nx)
        a = max(0, math.floor((lo - origin) / self.cell))
        b = min(n, math.floor((hi - origin) / self.cell) + 1)
        return a, max(a, b)

    def cells(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The cell (i, j) whose square holds each point (P, 2), clipped to the grid."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        j = np.clip(np.floor((p[:, 0] - self.x0) / self.cell).astype(np.int64), 0, self.nx - 1)
        i = np.clip(np.floor((p[:, 1] - self.y0) / self.cell).astype(np.int64), 0, self.ny - 1)
        return i, j


@dataclass(frozen=True)
class Field:
    """A set as lower bounds ``data`` (h, w) of the distance from the centres of the cells ``[i0, i0+h) × [j0, j0+w)``
    (the window) to it. The set lies in the squares of the cells ``core`` = ``(ci0, cj0, ci1, cj1)``, which the
    window holds with a band of cells where the bounds are kept too; outside the window the bound is
    :func:`swarmtrack.estimation.raster._beyond`'s. Immutable: operations return new fields."""

    i0: int
    j0: int
    data: np.ndarray
    # None: the window itself (__post_init__ replaces it, so the field is always a tuple after construction)
    core: tuple[int, int, int, int] = None  # type: ignore[assignment]
    #: ``(i0, j0, i1, j1)``, the cells ``[i0, i1) × [j0, j1)`` (set from the data's shape).
    window: tuple[int, int, int, int] = field(init=False, repr=False, compare=False)
    #: Whether the set is empty (an empty window).
    is_empty: bool = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        h, w = self.data.shape
        window = (self.i0, self.j0, self.i0 + h, self.j0 + w)
        object.__setattr__(self, "window", window)
        object.__setattr__(self, "is_empty", h * w == 0)
        if self.core is None:
            object.__setattr__(self, "core", window)


EMPTY = Field(0, 0, np.zeros((0, 0)))


def _core_array(f: Field) -> np.ndarray:
    """The core as an int64 array (4,) for the kernels, kept on the field (it is immutable)."""
    hit = f.__dict__.get("_core")
    if hit is None:
        hit = f.__dict__["_core"] = np.asarray(f.core, dtype=np.int64)
    return hit


def members(grid: Grid, f: Field) -> np.ndarray:
    """Whether each cell of ``f``'s window is a member (its square may meet the set)."""
    return f.data <= grid.slack + DELTA


def area(grid: Grid, f: Field) -> float:
    """φ of the outer approximation (m², 0 for an empty set): in each cell's square, the points p with
    ``|p − g| ≥ v(g)`` (the others are nearer the centre than the set is), so the square's area less that of its
    intersection with the disc of radius ``v(g)`` about the centre (:func:`cell_area`, summed by :func:`_measure`)."""
    return 0.0 if f.is_empty else _measured(grid, f)[0]


def _measured(grid: Grid, f: Field) -> tuple[float, float, float]:
    """:func:`_measure` of a non-empty field (its area, mean member row and column), kept on the field (immutable):
    the area and the centroid of a set (X^A: both) take one pass."""
    hit = f.__dict__.get("_measured")
    if hit is None or hit[0] != grid.cell:
        hit = f.__dict__["_measured"] = (grid.cell, *_measure(f.data, grid.cell))
    return hit[1:]


@numba.njit(cache=True)
def _measure(data, c):  # pragma: no cover (compiled)
    """Σ :func:`cell_area` over ``data`` (whole cells for ``v ≤ 0``, nothing from ``c/√2``) and the mean row and
    column of the member cells (``v ≤ c/√2 + DELTA``; NaN if none), one pass in memory order (the member indices
    summed as integers: exact, as a float sum of them would be)."""
    a, slack, full = c / 2, c / math.sqrt(2.0), 0
    member = slack + DELTA
    part = 0.0
    n, si, sj = 0, 0, 0
    h, w = data.shape
    for i in range(h):
        for j in range(w):
            v = data[i, j]
            if v <= 0.0:
                full += 1
            elif v <= member:
                if v < slack - DELTA:
                    disc = math.pi * v * v
                    if v > a:
                        disc -= 4 * (v * v * math.acos(a / v) - a * math.sqrt(v * v - a * a))
                    part += c * c - disc
            else:
                continue
            n += 1
            si += i
            sj += j
    mi, mj = (si / n, sj / n) if n else (np.nan, np.nan)
    return full * c * c + part, mi, mj


def cell_area(v: np.ndarray, c: float) -> np.ndarray:
    """``c² − φ(D(g, v) ∩ square(g))`` for bounds ``v`` on cells of side c: c² for ``v ≤ 0``, 0 from ``v ≥ c/√2``;
    between, the disc less the four circular segments beyond the square's sides (at distance ``a = c/2``)."""
    r = np.clip(v, 0.0, c / math.sqrt(2.0))
    a = c / 2
    ra = np.maximum(r, a)
    segments = 4 * (ra ** 2 * np.arccos(np.minimum(a / ra, 1.0)) - a * np.sqrt(np.maximum(ra ** 2 - a ** 2, 0.0)))
    disc = np.pi * r ** 2 - np.where(r > a, segments, 0.0)
    return np.where(v >= c / math.sqrt(2.0) - DELTA, 0.0, c * c - disc)


def holds(grid: Grid, f: Field, points: np.ndarray, tolerance: float = 1e-6) -> np.ndarray:
    """(P,) whether each point may lie in the set: inside the core's rectangle and ``v(g) ≤ |p − g|`` at the cell g
    whose square holds it (a point of the set always passes, module docstring): the guarantee's check."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    if f.is_empty:
        return np.zeros(len(p), dtype=bool)
    return _holds(f.data, f.i0, f.j0, _core_array(f), grid.x0, grid.y0, grid.cell, p, tolerance)


@numba.njit(cache=True)
def _holds(data, i0, j0, core, x0, y0, c, p, tol):  # pragma: no cover (compiled)
    out = np.zeros(len(p), dtype=np.bool_)
    for k in range(len(p)):
        x, y = p[k, 0], p[k, 1]
        if not (x0 + core[1] * c - tol <= x <= x0 + core[3] * c + tol
                and y0 + core[0] * c - tol <= y <= y0 + core[2] * c + tol):
            continue
        j = min(max(int(math.floor((x - x0) / c)), core[1]), core[3] - 1)
        i = min(max(int(math.floor((y - y0) / c)), core[0]), core[2] - 1)
        gx, gy = x0 + (j + 0.5) * c, y0 + (i + 0.5) * c
        out[k] = data[i - i0, j - j0] <= math.sqrt((x - gx) ** 2 + (y - gy) ** 2) + tol
    return out


def centroid(grid: Grid, f: Field) -> np.ndarray:
    """The centroid (2,) of the member cells (NaN for an empty set; :func:`_measure`)."""
    if f.is_empty:
        return np.full(2, np.nan)
    _, i, j = _measured(grid, f)
    return np.array([grid.x0 + (f.j0 + j + 0.5) * grid.cell, grid.y0 + (f.i0 + i + 0.5) * grid.cell])


def to_polygon(grid: Grid, f: Field) -> shapely.Geometry:
    """The outer approximation as a polygon (the union of the member cells' squares, one box per run of members in
    a row): for drawing."""
    if f.is_empty:
        return shapely.Polygon()
    m = np.zeros((f.data.shape[0], f.data.shape[1] + 2), dtype=np.int8)
    m[:, 1:-1] = members(grid, f)
    step = np.diff(m, axis=1)  # +1 where a run starts, −1 one past where it ends
    rows, starts = np.nonzero(step == 1)
    _, ends = np.nonzero(step == -1)  # the same rows in the same order
    c = grid.cell
    x0, x1 = grid.x0 + (f.j0 + starts) * c, grid.x0 + (f.j0 + ends) * c
    y0 = grid.y0 + (f.i0 + rows) * c
    return shapely.union_all(shapely.box(x0, y0, x1, y0 + c))
