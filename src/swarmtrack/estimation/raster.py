"""Planar sets as grids of distance lower bounds: the raster representation of IB21's guaranteed sets, an outer
approximation that needs no polygon overlay.

A set A in the area X0 is held as a :class:`Field` on a :class:`Grid` of square cells of side c covering X0: at
every cell centre g a number ``v(g) ≤ d(g, A)``, a *lower bound* of the Euclidean distance from g to A (0 inside or
no information; ``+inf`` far from an empty set). Every operation IB21 Secs. 4-5 needs maps lower bounds to lower
bounds, exactly and cell by cell:

* **dilation** by a disc of radius r (eqs. 13-15, 44): ``d(g, A ⊕ D(r)) = max(d(g, A) − r, 0)``, so ``v − r``;
* **intersection** ``d(g, A ∩ B) ≥ max(d(g, A), d(g, B))``: ``max(v_A, v_B)``; **union**: ``min(v_A, v_B)``, exact;
* **removal of an explored region** F (eqs. 21, 26, 28): ``A \\ F`` lies outside F, so ``d(g, A \\ F) ≥ depth_F(g)``,
  the distance from g to F's boundary when g is inside F (for the convex footprint: the least distance to an edge's
  line); ``max(v_A, depth_F − DELTA)``, F shrunk by :data:`DELTA` (an inner approximation of what was explored);
* **measurement boxes**: their exact distance.

**The guarantee carries over**: a point p of A lies in the square of some cell g, so ``v(g) ≤ d(g, A) ≤ |p − g| ≤
c/√2``. Hence A lies in the union of the squares of the *member* cells, ``v(g) ≤ c/√2`` (:attr:`Grid.slack`): that
union is the outer approximation the estimator reports (its area is φ, :func:`area`), and a true target at p must
satisfy ``v(g) ≤ |p − g|`` at its own cell (:func:`holds`, what the truth-side monitor checks).

**Windows** keep small sets small: a field stores its values on a window of cells ``[i0, i0 + h) × [j0, j0 + w)``
around its *core*, the cells whose squares hold A; beyond the window a coarser lower bound is computed when needed
(:func:`values`: the distance to the core's rectangle and to 16 supporting lines of the member cells). After every
operation the core is cut to the member cells' bounding window (:func:`trim`); the window keeps a band of cells about
it where the bounds are the operations' own, and is remade (:data:`MARGIN`) only when the set comes near its edge or
has shrunk well inside it. An empty set is a field with an empty window.

Compared with polygons (:mod:`swarmtrack.estimation.polygons`): no overlay and no vertex growth, every operation a
few numpy passes over a window; the price is resolution: the reported sets are unions of squares, wider than the
exact sets by up to c/√2 along their edges.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

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
    :func:`_beyond`'s. Immutable: operations return new fields."""

    i0: int
    j0: int
    data: np.ndarray
    core: tuple[int, int, int, int] | None = None  # None: the window itself

    def __post_init__(self) -> None:
        if self.core is None:
            object.__setattr__(self, "core", self.window)

    @property
    def is_empty(self) -> bool:
        return self.data.size == 0

    @property
    def window(self) -> tuple[int, int, int, int]:
        """``(i0, j0, i1, j1)``, the cells ``[i0, i1) × [j0, j1)``."""
        return self.i0, self.j0, self.i0 + self.data.shape[0], self.j0 + self.data.shape[1]


EMPTY = Field(0, 0, np.zeros((0, 0)))
#: Cells a window keeps beyond its core when it is (re)made, and the fewest before it is remade: the bounds in the
#: band are the operations' own, while a remade window's new cells get the coarser :func:`_beyond` (which can count
#: a cell as a member up to about a cell early), so windows are remade rarely: once per MARGIN − KEEP cells of growth.
MARGIN, KEEP = 16, 2


def full(grid: Grid) -> Field:
    """X0 itself (IB21 Sec. 4: X̄ = X0 initially): 0 at every cell, or the distance to X0 where it is not the grid."""
    data = np.zeros((grid.ny, grid.nx)) if grid.outside is None else grid.outside.copy()
    return trim(grid, Field(0, 0, data, (0, 0, grid.ny, grid.nx)))


def values(grid: Grid, f: Field, window: tuple[int, int, int, int]) -> np.ndarray:
    """The lower bounds of ``f`` on the cells ``window`` = ``(i0, j0, i1, j1)``: its stored values where it has them,
    the distance to its core's rectangle elsewhere (``+inf`` for an empty set)."""
    i0, j0, i1, j1 = window
    if f.is_empty:
        return np.full((i1 - i0, j1 - j0), np.inf)
    fi0, fj0, fi1, fj1 = f.window
    if fi0 <= i0 and fj0 <= j0 and i1 <= fi1 and j1 <= fj1:  # inside the stored window: a view
        return f.data[i0 - fi0:i1 - fi0, j0 - fj0:j1 - fj0]
    out = _beyond(grid, f, window)
    a0, b0, a1, b1 = max(i0, fi0), max(j0, fj0), min(i1, fi1), min(j1, fj1)
    if a0 < a1 and b0 < b1:
        out[a0 - i0:a1 - i0, b0 - j0:b1 - j0] = f.data[a0 - fi0:a1 - fi0, b0 - fj0:b1 - fj0]
    return out


#: Directions of the supporting lines :func:`_beyond` bounds a set with (a 16-gon about it: a disc-shaped set is
#: within 2 % of it, against 41 % at the corners of its bounding rectangle).
_NORMALS = np.column_stack([np.cos(np.arange(16) * np.pi / 8), np.sin(np.arange(16) * np.pi / 8)])


def _beyond(grid: Grid, f: Field, window: tuple[int, int, int, int]) -> np.ndarray:
    """Lower bounds of the distance from the centres of ``window`` to the set of ``f``, from outside: the greater of
    the distance to its core's rectangle and to each of 16 supporting half-planes of its member cells' squares
    (the set lies in each, so the distance to it is at least the distance to any)."""
    i0, j0, i1, j1 = window
    c = grid.cell
    ci0, cj0, ci1, cj1 = f.core
    y = (np.arange(i0, i1) + 0.5) * c
    x = (np.arange(j0, j1) + 0.5) * c
    dy = np.maximum(np.maximum(ci0 * c - y, y - ci1 * c), 0.0)
    dx = np.maximum(np.maximum(cj0 * c - x, x - cj1 * c), 0.0)
    out = np.hypot(dy[:, None], dx[None, :])
    mi, mj = np.nonzero(members(grid, f))
    if len(mi):
        py, px = (f.i0 + mi + 0.5) * c, (f.j0 + mj + 0.5) * c
        corner = c / 2 * (np.abs(_NORMALS[:, 0]) + np.abs(_NORMALS[:, 1]))
        support = (np.outer(_NORMALS[:, 0], px) + np.outer(_NORMALS[:, 1], py)).max(axis=1) + corner
        for (nx_, ny_), h in zip(_NORMALS, support, strict=True):
            np.maximum(out, y[:, None] * ny_ + x[None, :] * nx_ - h, out=out)
    return out


def trim(grid: Grid, f: Field) -> Field:
    """``f`` with its core cut to the bounding window of its member cells (``v ≤ c/√2``; the set lies in their
    squares, module docstring), or :data:`EMPTY` if it has none. Its window stays while it holds the core with
    :data:`KEEP` cells to spare and is not more than :data:`MARGIN` cells wider than that on a side; otherwise it is
    remade as the core with :data:`MARGIN` cells about it (:func:`_window`)."""
    if f.is_empty:
        return EMPTY
    member = members(grid, f)
    rows, cols = np.flatnonzero(member.any(axis=1)), np.flatnonzero(member.any(axis=0))
    if not len(rows):
        return EMPTY
    core = (f.i0 + int(rows[0]), f.j0 + int(cols[0]), f.i0 + int(rows[-1]) + 1, f.j0 + int(cols[-1]) + 1)
    win = _window(grid, core, f.window)
    if win == f.window and core == f.core:
        return f
    return Field(win[0], win[1], values(grid, f, win), core)


def _grown(grid: Grid, box: tuple[int, int, int, int], m: int) -> tuple[int, int, int, int]:
    return max(0, box[0] - m), max(0, box[1] - m), min(grid.ny, box[2] + m), min(grid.nx, box[3] + m)


def _window(grid: Grid, core: tuple[int, int, int, int], window: tuple[int, int, int, int]):
    """The window for ``core``: ``window`` if it holds the core grown by :data:`KEEP` and lies in the core grown by
    2·:data:`MARGIN`, else the core grown by :data:`MARGIN` (all within the grid)."""
    need, most = _grown(grid, core, KEEP), _grown(grid, core, 2 * MARGIN)
    if (window[0] <= need[0] and window[1] <= need[1] and window[2] >= need[2] and window[3] >= need[3]
            and window[0] >= most[0] and window[1] >= most[1] and window[2] <= most[2] and window[3] <= most[3]):
        return window
    return _grown(grid, core, MARGIN)


def _cover(boxes) -> tuple[int, int, int, int] | None:
    """The smallest window holding every given window (None if there are none)."""
    if not boxes:
        return None
    w = np.array(boxes)
    return int(w[:, 0].min()), int(w[:, 1].min()), int(w[:, 2].max()), int(w[:, 3].max())


def union(grid: Grid, fields) -> Field:
    """``∪ fields``: the least bound, on the window holding them all (exact). A single non-empty field (or the same
    object several times) is returned as it is."""
    live = list({id(f): f for f in fields if not f.is_empty}.values())
    if len(live) <= 1:
        return live[0] if live else EMPTY
    win = _cover([f.window for f in live])
    out = values(grid, live[0], win).copy()
    for f in live[1:]:
        np.minimum(out, values(grid, f, win), out=out)
    return Field(win[0], win[1], out, _cover([f.core for f in live]))


def meet(grid: Grid, small: Field, *holders) -> Field:
    """``small ∩ (∪ holders)``, evaluated on ``small``'s window only (the result lies in it): eqs. 18-20, 24-25's
    ``Y ∩ (Xᵁ ∪ X̄)``. If ``small`` is one of the holders (the same object) it is the result, exactly."""
    if small.is_empty or any(h is small for h in holders):
        return small
    live = [h for h in holders if not h.is_empty]
    if not live:
        return EMPTY
    win = small.window
    held = values(grid, live[0], win).copy()
    for h in live[1:]:
        np.minimum(held, values(grid, h, win), out=held)
    return trim(grid, Field(small.i0, small.j0, np.maximum(small.data, held), small.core))


def held_by_all(grid: Grid, candidate: Field, holders: list[list[Field]]) -> Field:
    """``candidate ∩ ⋂_ℓ (∪ holders[ℓ])`` on the candidate's window (eqs. 34, 36 without complements): one pass per
    holder list."""
    if candidate.is_empty:
        return candidate
    win = candidate.window
    out = candidate.data.copy()
    for parts in holders:
        if any(p is candidate for p in parts):
            continue
        live = [p for p in parts if not p.is_empty]
        if not live:
            return EMPTY
        held = values(grid, live[0], win).copy()
        for p in live[1:]:
            np.minimum(held, values(grid, p, win), out=held)
        np.maximum(out, held, out=out)
    return trim(grid, Field(candidate.i0, candidate.j0, out, candidate.core))


def intersect_all(grid: Grid, fields) -> Field:
    """``⋂ fields`` (non-empty sequence): the greatest bound, on the overlap of their windows (eq. 37)."""
    fields = list({id(f): f for f in fields}.values())
    if len(fields) == 1:
        return fields[0]
    if any(f.is_empty for f in fields):
        return EMPTY
    w, k = np.array([f.window for f in fields]), np.array([f.core for f in fields])
    win = (int(w[:, 0].max()), int(w[:, 1].max()), int(w[:, 2].min()), int(w[:, 3].min()))
    core = (int(k[:, 0].max()), int(k[:, 1].max()), int(k[:, 2].min()), int(k[:, 3].min()))
    if core[0] >= core[2] or core[1] >= core[3]:
        return EMPTY
    out = values(grid, fields[0], win).copy()
    for f in fields[1:]:
        np.maximum(out, values(grid, f, win), out=out)
    return trim(grid, Field(win[0], win[1], out, core))


def dilate(grid: Grid, f: Field, r: float) -> Field:
    """``(A ⊕ D(r)) ∩ X0`` (eqs. 13-15): the window grown by r (to whole cells, within the grid) and every bound
    lowered by r, exactly; then clipped to X0 where it is not the grid's rectangle."""
    if f.is_empty or r == 0:
        return f
    if r < 0:
        raise ValueError("a dilation radius must not be negative")
    core = _grown(grid, f.core, math.ceil(r / grid.cell))  # the dilated set lies in it
    win = _window(grid, core, f.window)
    out = values(grid, f, win) - r
    if grid.outside is not None:
        np.maximum(out, grid.outside[win[0]:win[2], win[1]:win[3]], out=out)
    return trim(grid, Field(win[0], win[1], out, core))


def box(grid: Grid, b) -> Field:
    """The box ``[x0, x1] × [y0, y1]`` (a measurement's ``y − [w]``, IB21 Sec. 6): the exact distance from each
    centre, on the cells whose squares meet it (within the grid)."""
    x0, y0, x1, y1 = (float(v) for v in b)
    ci0, ci1 = grid.span(y0, y1, 0)
    cj0, cj1 = grid.span(x0, x1, 1)
    if ci0 >= ci1 or cj0 >= cj1:
        return EMPTY
    i0, j0, i1, j1 = _grown(grid, (ci0, cj0, ci1, cj1), MARGIN)
    y = grid.y0 + (np.arange(i0, i1) + 0.5) * grid.cell
    x = grid.x0 + (np.arange(j0, j1) + 0.5) * grid.cell
    dy = np.maximum(np.maximum(y0 - y, y - y1), 0.0)
    dx = np.maximum(np.maximum(x0 - x, x - x1), 0.0)
    return trim(grid, Field(i0, j0, np.hypot(dy[:, None], dx[None, :]), (ci0, cj0, ci1, cj1)))


def boxes(grid: Grid, z: np.ndarray, bound) -> list[Field]:
    """The measurement boxes ``B(y) = y − [w]`` of detections ``z`` (M, 2), half-widths ``bound``."""
    wx, wy = bound
    return [box(grid, (x - wx, y - wy, x + wx, y + wy)) for x, y in np.asarray(z, dtype=float).reshape(-1, 2)]


def depth(grid: Grid, corners: np.ndarray, window: tuple[int, int, int, int]) -> np.ndarray:
    """For the convex polygon ``corners`` (K, 2) (in either order), the distance from each centre of ``window`` to its
    boundary inside it (the least distance to an edge's line) and a non-positive number outside."""
    i0, j0, i1, j1 = window
    c = np.asarray(corners, dtype=float)
    y = grid.y0 + (np.arange(i0, i1) + 0.5) * grid.cell
    x = grid.x0 + (np.arange(j0, j1) + 0.5) * grid.cell
    edge = np.roll(c, -1, axis=0) - c
    turn = np.sign(np.sum(c[:, 0] * np.roll(c[:, 1], -1) - np.roll(c[:, 0], -1) * c[:, 1]))  # +1: counter-clockwise
    normal = turn * np.column_stack([-edge[:, 1], edge[:, 0]]) / np.hypot(edge[:, 0], edge[:, 1])[:, None]  # inward
    out = np.full((i1 - i0, j1 - j0), np.inf)
    for (px, py), (nx_, ny_) in zip(c, normal, strict=True):
        np.minimum(out, (y[:, None] - py) * ny_ + (x[None, :] - px) * nx_, out=out)
    return out


def remove(grid: Grid, f: Field, corners: np.ndarray) -> Field:
    """``A \\ F`` for the convex footprint F (``corners`` (K, 2)), shrunk by :data:`DELTA` (eqs. 21, 26, 28): the bound
    raised to F's depth inside F. A footprint that misses the window changes nothing (the same object back)."""
    if f.is_empty:
        return f
    c = np.asarray(corners, dtype=float)
    i0, i1 = grid.span(c[:, 1].min(), c[:, 1].max(), 0)
    j0, j1 = grid.span(c[:, 0].min(), c[:, 0].max(), 1)
    fi0, fj0, fi1, fj1 = f.window
    a0, b0, a1, b1 = max(i0, fi0), max(j0, fj0), min(i1, fi1), min(j1, fj1)
    if a0 >= a1 or b0 >= b1:
        return f
    d = depth(grid, c, (a0, b0, a1, b1)) - DELTA
    part = f.data[a0 - fi0:a1 - fi0, b0 - fj0:b1 - fj0]
    if not (d > part).any():
        return f
    data = f.data.copy()
    np.maximum(part, d, out=data[a0 - fi0:a1 - fi0, b0 - fj0:b1 - fj0])
    return trim(grid, Field(f.i0, f.j0, data, f.core))


def redistance(grid: Grid, f: Field, block: int = 4) -> Field:
    """``f`` with its bounds raised to the distance from each centre to the set's member cells, measured on blocks of
    ``block`` × ``block`` cells: local updates (a footprint's depth, a maximum at fusion) cannot see that a point on
    the seam of two explored regions is far from anything unexplored, this can.

    Why it is a lower bound: every point a of the set lies in the square of a member cell, inside the square of that
    cell's block B (side ``b = block·c``). For a cell g in block B', ``|g − a| ≥ |B'·B| − |g − B'| − |B − a|``
    (block centres) ``≥ E(B') − (block − 1)·c/√2 − b/√2``, E(B') the distance from B''s centre to the nearest member
    block's (:func:`scipy.ndimage.distance_transform_edt` on the blocks, times b). Outside the window no point lies.
    The result is ``max(v, that)``: never looser than ``f``."""
    if f.is_empty:
        return f
    from scipy import ndimage

    h, w = f.data.shape
    H, W = -(-h // block), -(-w // block)
    m = np.zeros((H * block, W * block), dtype=bool)
    m[:h, :w] = members(grid, f)
    coarse = m.reshape(H, block, W, block).any(axis=(1, 3))
    if coarse.all():
        return f
    far = ndimage.distance_transform_edt(~coarse) * (block * grid.cell) - (2 * block - 1) * grid.slack
    lift = np.repeat(np.repeat(far, block, axis=0), block, axis=1)[:h, :w]
    if not (lift > f.data).any():
        return f
    return Field(f.i0, f.j0, np.maximum(f.data, lift), f.core)


def members(grid: Grid, f: Field) -> np.ndarray:
    """Whether each cell of ``f``'s window is a member (its square may meet the set)."""
    return f.data <= grid.slack + DELTA


def area(grid: Grid, f: Field) -> float:
    """φ of the outer approximation (m², 0 for an empty set): in each cell's square, the points p with
    ``|p − g| ≥ v(g)`` (the others are nearer the centre than the set is), so the square's area less that of its
    intersection with the disc of radius ``v(g)`` about the centre (:func:`cell_area`)."""
    return 0.0 if f.is_empty else float(cell_area(f.data, grid.cell).sum())


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
    """(P,) whether each point may lie in the set: inside the window's rectangle and ``v(g) ≤ |p − g|`` at the cell g
    whose square holds it (a point of the set always passes, module docstring): the guarantee's check."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    if f.is_empty:
        return np.zeros(len(p), dtype=bool)
    i0, j0, i1, j1 = f.core
    c = grid.cell
    inside = ((p[:, 0] >= grid.x0 + j0 * c - tolerance) & (p[:, 0] <= grid.x0 + j1 * c + tolerance)
              & (p[:, 1] >= grid.y0 + i0 * c - tolerance) & (p[:, 1] <= grid.y0 + i1 * c + tolerance))
    i, j = grid.cells(p)
    i, j = np.clip(i, i0, i1 - 1), np.clip(j, j0, j1 - 1)
    gx, gy = grid.x0 + (j + 0.5) * c, grid.y0 + (i + 0.5) * c
    v = f.data[i - f.i0, j - f.j0]
    return inside & (v <= np.hypot(p[:, 0] - gx, p[:, 1] - gy) + tolerance)


def centroid(grid: Grid, f: Field) -> np.ndarray:
    """The centroid (2,) of the member cells (NaN for an empty set)."""
    if f.is_empty:
        return np.full(2, np.nan)
    i, j = np.nonzero(members(grid, f))
    return np.array([grid.x0 + (f.j0 + j.mean() + 0.5) * grid.cell, grid.y0 + (f.i0 + i.mean() + 0.5) * grid.cell])


def to_polygon(grid: Grid, f: Field) -> shapely.Geometry:
    """The outer approximation as a polygon (the union of the member cells' squares): for drawing."""
    if f.is_empty:
        return shapely.Polygon()
    i, j = np.nonzero(members(grid, f))
    x0, y0 = grid.x0 + (f.j0 + j) * grid.cell, grid.y0 + (f.i0 + i) * grid.cell
    return shapely.union_all(shapely.box(x0, y0, x0 + grid.cell, y0 + grid.cell))
