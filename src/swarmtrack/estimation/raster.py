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
    :func:`_beyond`'s. Immutable: operations return new fields."""

    i0: int
    j0: int
    data: np.ndarray
    core: tuple[int, int, int, int] | None = None  # None: the window itself
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
    :func:`_beyond`'s elsewhere (``+inf`` for an empty set). Inside the stored window: a view."""
    i0, j0, i1, j1 = window
    fi0, fj0, fi1, fj1 = f.window
    if not f.is_empty and fi0 <= i0 and fj0 <= j0 and i1 <= fi1 and j1 <= fj1:
        return f.data[i0 - fi0:i1 - fi0, j0 - fj0:j1 - fj0]
    out = np.full((i1 - i0, j1 - j0), np.inf)
    lower(grid, out, window, [f])
    return out


def lower(grid: Grid, acc: np.ndarray, window: tuple[int, int, int, int], fields: list[Field],
          floor: np.ndarray | None = None) -> None:
    """``acc ← min(acc, values(f, window))`` in place for each of ``fields`` (the union's step):
    first every field's stored values, then the coarse bounds off each field's stored window (:func:`_lower_into`),
    which are left as soon as they reach ``acc`` (a minimum is exact in any order, and what is stored lowers ``acc``
    first). With ``floor``, the coarse bounds are skipped where ``acc ≤ floor`` already: a maximum with ``floor``
    that follows (an intersection with it) gives ``floor`` there whatever the bound. The same numbers as the
    minimum with :func:`values`, wherever they count."""
    i0, j0, i1, j1 = window
    beyond = []
    for f in fields:
        if f.is_empty:
            continue
        fi0, fj0, fi1, fj1 = f.window
        a0, b0, a1, b1 = max(i0, fi0), max(j0, fj0), min(i1, fi1), min(j1, fj1)
        if a0 < a1 and b0 < b1:
            part = acc[a0 - i0:a1 - i0, b0 - j0:b1 - j0]
            np.minimum(part, f.data[a0 - fi0:a1 - fi0, b0 - fj0:b1 - fj0], out=part)
        if not (fi0 <= i0 and fj0 <= j0 and i1 <= fi1 and j1 <= fj1):
            beyond.append(f)
    for f in beyond:
        _lower_into(acc, i0, j0, f.data.shape, f.i0, f.j0, _core_array(f), _support(grid, f),
                    _NORMALS, grid.cell, acc if floor is None else floor, floor is not None)


@numba.njit(cache=True)
def _lower_into(acc, i0, j0, shape, fi0, fj0, core, support, normals, c, floor, use_floor):  # pragma: no cover
    """:func:`lower`'s coarse part, one pass: per cell of ``acc`` (cell (i0, j0) first) off the stored window
    (``shape`` at ``(fi0, fj0)``), skipped if ``acc ≤ floor`` (with ``use_floor``), else the minimum with the greater
    of the distance to the core's rectangle and to each supporting half-plane (:func:`_beyond`, its readable
    reference), left as soon as that reaches ``acc`` (a greater bound cannot lower it; the row's and the column's
    distance to the rectangle, parts of it, are tried first)."""
    h, w = shape
    width = acc.shape[1]
    for a in range(acc.shape[0]):
        i = i0 + a
        y = (i + 0.5) * c
        dy = max(core[0] * c - y, y - core[2] * c, 0.0)
        if fi0 <= i < fi0 + h:  # the stored columns [s0, s1) of this row are not touched
            s0, s1 = min(max(fj0 - j0, 0), width), min(max(fj0 + w - j0, 0), width)
        else:
            s0, s1 = width, width
        for b in range(width):
            if s0 <= b < s1:
                continue
            cur = acc[a, b]
            if dy >= cur or (use_floor and cur <= floor[a, b]):
                continue
            x = (j0 + b + 0.5) * c
            dx = max(core[1] * c - x, x - core[3] * c, 0.0)
            if dx >= cur:  # so is the distance to the rectangle, √(dx² + dy²) ≥ dx exactly
                continue
            v = math.sqrt(dx * dx + dy * dy)
            for k in range(len(support)):
                if v >= cur:
                    break
                v = max(v, x * normals[k, 0] + y * normals[k, 1] - support[k])
            if v < cur:
                acc[a, b] = v


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
    for (nx_, ny_), h in zip(_NORMALS, _support(grid, f), strict=True):
        np.maximum(out, y[:, None] * ny_ + x[None, :] * nx_ - h, out=out)
    return out


def _core_array(f: Field) -> np.ndarray:
    """The core as an int64 array (4,) for the kernels, kept on the field (it is immutable)."""
    hit = f.__dict__.get("_core")
    if hit is None:
        hit = f.__dict__["_core"] = np.asarray(f.core, dtype=np.int64)
    return hit


def _support(grid: Grid, f: Field) -> np.ndarray:
    """(16,) the support of the member cells' squares along :data:`_NORMALS` (grid coordinates from the corner),
    kept on the field (it is immutable): :func:`_support_kernel`, beside its readable reference
    :func:`support_reference`."""
    hit = f.__dict__.get("_support")
    if hit is None:
        hit = _support_kernel(f.data, f.i0, f.j0, grid.cell, grid.slack + DELTA, _NORMALS)
        f.__dict__["_support"] = hit
    return hit


def support_reference(grid: Grid, f: Field) -> np.ndarray:
    """:func:`_support` in numpy: a linear function's maximum over a row's member cells is at its first or last."""
    member = members(grid, f)
    rows = np.flatnonzero(member.any(axis=1))  # non-empty: f has members after trim
    first = member[rows].argmax(axis=1)
    last = member.shape[1] - 1 - member[rows, ::-1].argmax(axis=1)
    c = grid.cell
    py = (f.i0 + np.concatenate([rows, rows]) + 0.5) * c
    px = (f.j0 + np.concatenate([first, last]) + 0.5) * c
    corner = c / 2 * (np.abs(_NORMALS[:, 0]) + np.abs(_NORMALS[:, 1]))
    return (np.outer(_NORMALS[:, 0], px) + np.outer(_NORMALS[:, 1], py)).max(axis=1) + corner


@numba.njit(cache=True)
def _support_kernel(data, i0, j0, c, member, normals):  # pragma: no cover (compiled)
    """:func:`support_reference` in one pass over the rows."""
    n = len(normals)
    best = np.full(n, -np.inf)
    for i in range(data.shape[0]):
        first, last = _row_members(data[i], member)
        if first < 0:
            continue
        py = (i0 + i + 0.5) * c
        for j in (first, last):
            px = (j0 + j + 0.5) * c
            for k in range(n):
                best[k] = max(best[k], normals[k, 0] * px + normals[k, 1] * py)
    for k in range(n):
        best[k] += c / 2 * (abs(normals[k, 0]) + abs(normals[k, 1]))
    return best


def trim(grid: Grid, f: Field) -> Field:
    """``f`` with its core cut to the bounding window of its member cells (``v ≤ c/√2``; the set lies in their
    squares, module docstring), or :data:`EMPTY` if it has none. Its window stays while it holds the core with
    :data:`KEEP` cells to spare and lies within the core grown by 2·:data:`MARGIN`; otherwise it is remade as the
    core with :data:`MARGIN` cells about it (:func:`_window`)."""
    if f.is_empty:
        return EMPTY
    r0, c0, r1, c1 = _bbox(f.data, grid.slack + DELTA)
    if r0 >= r1:
        return EMPTY
    core = (f.i0 + r0, f.j0 + c0, f.i0 + r1, f.j0 + c1)
    win = _window(grid, core, f.window)
    if win == f.window and core == f.core:
        return f
    return Field(win[0], win[1], values(grid, f, win), core)


@numba.njit(cache=True)
def _bbox(data, member):  # pragma: no cover (compiled)
    """The rows ``[r0, r1)`` and columns ``[c0, c1)`` holding every value ``≤ member`` (``r0 ≥ r1`` when none)."""
    h, w = data.shape
    r0, c0, r1, c1 = h, w, 0, 0
    for i in range(h):
        lo, hi = _row_members(data[i], member)
        if lo < 0:
            continue
        r0, r1 = min(r0, i), i + 1
        c0, c1 = min(c0, lo), max(c1, hi + 1)
    return r0, c0, r1, c1


@numba.njit(cache=True)
def _row_members(row, member):  # pragma: no cover (compiled)
    """The first and last index of a value ``≤ member`` in ``row``, (−1, −1) when none: the row scan that
    :func:`_bbox` and :func:`_support_kernel` share."""
    for lo in range(len(row)):
        if row[lo] <= member:
            for hi in range(len(row) - 1, lo - 1, -1):
                if row[hi] <= member:
                    return lo, hi
    return -1, -1


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
    i0, j0, i1, j1 = zip(*boxes, strict=True)
    return int(min(i0)), int(min(j0)), int(max(i1)), int(max(j1))


def _overlap(boxes) -> tuple[int, int, int, int]:
    """The overlap of the given windows (empty when a lower corner passes an upper one)."""
    i0, j0, i1, j1 = zip(*boxes, strict=True)
    return int(max(i0)), int(max(j0)), int(min(i1)), int(min(j1))


def union(grid: Grid, fields) -> Field:
    """``∪ fields``: the least bound, on the window holding them all (exact). A single non-empty field (or the same
    object several times) is returned as it is."""
    live = list({id(f): f for f in fields if not f.is_empty}.values())
    if len(live) <= 1:
        return live[0] if live else EMPTY
    win = _cover([f.window for f in live])
    out, rest = _start_on(live, win)
    lower(grid, out, win, rest)
    return Field(win[0], win[1], out, _cover([f.core for f in live]))


def _start_on(fields: list[Field], window: tuple[int, int, int, int]) -> tuple[np.ndarray, list[Field]]:
    """A new array on ``window`` to take the minimum of ``fields`` in, and the fields still to take: a copy of the
    values of one whose stored window holds it (the minimum with ``+inf`` is that copy), or ``+inf`` and all."""
    i0, j0, i1, j1 = window
    for k, f in enumerate(fields):
        fi0, fj0, fi1, fj1 = f.window
        if fi0 <= i0 and fj0 <= j0 and i1 <= fi1 and j1 <= fj1:
            return f.data[i0 - fi0:i1 - fi0, j0 - fj0:j1 - fj0].copy(), fields[:k] + fields[k + 1:]
    return np.full((i1 - i0, j1 - j0), np.inf), fields


def union_near(grid: Grid, fields) -> Field:
    """``∪ fields`` for a set that is measured and searched but not predicted further (X^A, eq. 43): the least bound
    on each field's own window, ``+inf`` on the cells of the cover that none holds. The member cells are those of the
    exact union, and so are the bounds within each field's band of kept cells (a dilation by less than that band,
    e.g. the SM-MPC's h·V^t·T^c, finds the same members); farther off, the values are not lower bounds."""
    live = list({id(f): f for f in fields if not f.is_empty}.values())
    if len(live) <= 1:
        return live[0] if live else EMPTY
    win = _cover([f.window for f in live])
    out, rest = _start_on(live, win)
    for f in rest:
        i0, j0, i1, j1 = f.window
        part = out[i0 - win[0]:i1 - win[0], j0 - win[1]:j1 - win[1]]
        np.minimum(part, f.data, out=part)
    return Field(win[0], win[1], out, _cover([f.core for f in live]))


def _holding(grid: Grid, holders, window: tuple[int, int, int, int], floor: np.ndarray) -> np.ndarray | None:
    """``∪ holders`` on ``window`` where it can exceed ``floor`` (:func:`lower`: elsewhere some value ``≤ floor``),
    a new array, for a maximum with ``floor``; None if every holder is empty."""
    live = [h for h in holders if not h.is_empty]
    if not live:
        return None
    held, rest = _start_on(live, window)
    lower(grid, held, window, rest, floor)
    return held


def meet(grid: Grid, small: Field, *holders) -> Field:
    """``small ∩ (∪ holders)``, evaluated on ``small``'s window only (the result lies in it): eqs. 18-20, 24-25's
    ``Y ∩ (Xᵁ ∪ X̄)``. If ``small`` is one of the holders (the same object) it is the result, exactly."""
    if small.is_empty or any(h is small for h in holders):
        return small
    held = _holding(grid, holders, small.window, small.data)
    if held is None:
        return EMPTY
    return trim(grid, Field(small.i0, small.j0, np.maximum(small.data, held, out=held), small.core))


def meets(grid: Grid, small: Field, *holders) -> bool:
    """Whether ``small ∩ (∪ holders)`` has a member cell (:func:`meet` without building it)."""
    if small.is_empty:
        return False
    if any(h is small for h in holders):
        return True
    r0, c0, r1, c1 = _bbox(small.data, grid.slack + DELTA)  # a member of the meet is one of small's: look there only
    if r0 >= r1:
        return False
    part = small.data[r0:r1, c0:c1]
    held = _holding(grid, holders, (small.i0 + r0, small.j0 + c0, small.i0 + r1, small.j0 + c1), part)
    return held is not None and bool((np.maximum(part, held, out=held) <= grid.slack + DELTA).any())


def held_by_all(grid: Grid, candidate: Field, holders: list[list[Field]]) -> Field:
    """``candidate ∩ ⋂_ℓ (∪ holders[ℓ])`` on the candidate's window (eqs. 34, 36 without complements): one pass per
    holder list."""
    if candidate.is_empty:
        return candidate
    out = candidate.data  # replaced by the first maximum, in the new array that _holding made
    for parts in holders:
        if any(p is candidate for p in parts):
            continue
        held = _holding(grid, parts, candidate.window, out)
        if held is None:
            return EMPTY
        out = np.maximum(out, held, out=held if out is candidate.data else out)
    return trim(grid, Field(candidate.i0, candidate.j0, out, candidate.core))


def intersect_all(grid: Grid, fields) -> Field:
    """``⋂ fields`` (non-empty sequence): the greatest bound, on the overlap of their windows (eq. 37)."""
    fields = list({id(f): f for f in fields}.values())
    if len(fields) == 1:
        return fields[0]
    if any(f.is_empty for f in fields):
        return EMPTY
    win, core = _overlap([f.window for f in fields]), _overlap([f.core for f in fields])
    if core[0] >= core[2] or core[1] >= core[3]:
        return EMPTY
    out = np.maximum(values(grid, fields[0], win), values(grid, fields[1], win))
    for f in fields[2:]:
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
    return Field(win[0], win[1], out, core)  # no member is lost: the grown core holds the set, untrimmed


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
    boundary inside it (the least distance to an edge's line) and a non-positive number outside: the readable
    reference of :func:`_raise`."""
    i0, j0, i1, j1 = window
    c, normal = _inward(corners)
    y = grid.y0 + (np.arange(i0, i1) + 0.5) * grid.cell
    x = grid.x0 + (np.arange(j0, j1) + 0.5) * grid.cell
    out = np.full((i1 - i0, j1 - j0), np.inf)
    for (px, py), (nx_, ny_) in zip(c, normal, strict=True):
        np.minimum(out, (y[:, None] - py) * ny_ + (x[None, :] - px) * nx_, out=out)
    return out


def _inward(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The corners (..., K, 2) as floats and the inward unit normals (..., K, 2) of the edges that start at them."""
    c = np.asarray(corners, dtype=float)
    nxt = np.concatenate([c[..., 1:, :], c[..., :1, :]], axis=-2)
    edge = nxt - c
    turn = np.where(np.sum(c[..., 0] * nxt[..., 1] - nxt[..., 0] * c[..., 1], axis=-1) > 0, 1.0, -1.0)  # ccw: +1
    normal = np.stack([-edge[..., 1], edge[..., 0]], axis=-1)
    return c, turn[..., None, None] * normal / np.hypot(edge[..., 0], edge[..., 1])[..., None]


@dataclass(frozen=True)
class Convex:
    """A convex region prepared for :func:`remove` on one grid: ``corners`` (K, 2), the inward unit ``normals`` of
    the edges starting at them, and the cells ``[i0, i1) × [j0, j1)`` whose squares meet its bounding box."""

    corners: np.ndarray
    normals: np.ndarray
    i0: int
    j0: int
    i1: int
    j1: int


def convex(grid: Grid, corners: np.ndarray) -> Convex:
    """:class:`Convex` of the polygon ``corners`` (K, 2), in either order (once for the several sets it cuts)."""
    return convex_all(grid, np.asarray(corners, dtype=float)[None])[0]


def convex_all(grid: Grid, corners: np.ndarray) -> list[Convex]:
    """:func:`convex` of each polygon of ``corners`` (n, K, 2), computed together (every UAV's footprint at once)."""
    c, normal = _inward(corners)
    lo, hi = c.min(axis=-2).tolist(), c.max(axis=-2).tolist()
    return [Convex(c[q], normal[q], *_spans(grid, lo[q], hi[q])) for q in range(len(c))]


def _spans(grid: Grid, lo: list[float], hi: list[float]) -> tuple[int, int, int, int]:
    """``(i0, j0, i1, j1)``: the cells whose squares meet the box ``[lo, hi]`` (x, y each)."""
    i0, i1 = grid.span(lo[1], hi[1], 0)
    j0, j1 = grid.span(lo[0], hi[0], 1)
    return i0, j0, i1, j1


def remove(grid: Grid, f: Field, region) -> Field:
    """``A \\ F`` for the convex footprint F (``region``: its corners (K, 2) or a :class:`Convex`), shrunk by
    :data:`DELTA` (eqs. 21, 26, 28): the bound raised to F's depth inside F (:func:`depth`, compiled in
    :func:`_raise`). A footprint that changes nothing gives the same object back; the core is recut only if a member
    cell stopped being one."""
    if f.is_empty:
        return f
    F = region if isinstance(region, Convex) else convex(grid, region)
    fi0, fj0, fi1, fj1 = f.window
    a0, b0, a1, b1 = max(F.i0, fi0), max(F.j0, fj0), min(F.i1, fi1), min(F.j1, fj1)
    if a0 >= a1 or b0 >= b1:
        return f
    args = ((a0 - fi0, b0 - fj0, a1 - fi0, b1 - fj0), grid.y0 + (a0 + 0.5) * grid.cell,
            grid.x0 + (b0 + 0.5) * grid.cell, grid.cell, F.corners, F.normals, DELTA, grid.slack + DELTA)
    if _raise(f.data, *args, False) == 0:
        return f
    data = f.data.copy()
    lost = _raise(data, *args, True)
    out = Field(f.i0, f.j0, data, f.core)
    return trim(grid, out) if lost == 2 else out


@numba.njit(cache=True)
def _raise(data, cells, y0, x0, c, corners, normals, delta, member, write):  # pragma: no cover (compiled)
    """``data[r0:r1, c0:c1] = max(data, depth − delta)`` on the ``cells`` = ``(r0, c0, r1, c1)`` of ``data``, cell
    (r0, c0)'s centre at ``(x0, y0)``, cells of side ``c`` (``write`` False: only look); the depth in the convex region
    of ``corners`` and inward ``normals`` (:func:`depth`, its readable reference). Returns 0 if nothing rises, 1 if
    something does, 2 if a member cell (``≤ member``) stops being one."""
    r0, c0, r1, c1 = cells
    out = 0
    for a in range(r1 - r0):
        y = y0 + a * c
        for b in range(c1 - c0):
            x = x0 + b * c
            d = np.inf
            for k in range(len(corners)):
                d = min(d, (y - corners[k, 1]) * normals[k, 1] + (x - corners[k, 0]) * normals[k, 0])
            d -= delta
            v = data[r0 + a, c0 + b]
            if d > v:
                if not write:
                    return 1
                out = max(out, 2 if (v <= member < d) else 1)
                data[r0 + a, c0 + b] = d
    return out


def redistance(grid: Grid, f: Field, block: int = 4) -> Field:
    """``f`` with its bounds raised to the distance from each centre to the set's member cells, measured on blocks of
    ``block`` × ``block`` cells: local updates (a footprint's depth, a maximum at fusion) cannot see that a point on
    the seam of two explored regions is far from anything unexplored, this can.

    Why it is a lower bound: every point a of the set lies in the square of a member cell, inside the square of that
    cell's block B (side ``b = block·c``). For a cell g in block B', ``|g − a| ≥ |B'·B| − |g − B'| − |B − a|``
    (block centres) ``≥ E(B') − (block − 1)·c/√2 − b/√2``, E(B') the distance from B''s centre to the nearest member
    block's (:func:`block_distances`, times b). Outside the window no point lies.
    The result is ``max(v, that)``: never looser than ``f``."""
    if f.is_empty:
        return f
    coarse = _blocks(f.data, block, grid.slack + DELTA)
    if coarse.all():
        return f
    far = block_distances(coarse) * (block * grid.cell) - (2 * block - 1) * grid.slack
    data = _lift(f.data, far, block)
    return f if data is None else Field(f.i0, f.j0, data, f.core)


def block_distances(coarse: np.ndarray) -> np.ndarray:
    """The distance from each block to the nearest member block (``coarse`` True), in blocks: the exact Euclidean
    distance transform of :func:`_squared_distances`, the square root of an integer sum of squares (the same numbers
    as :func:`scipy.ndimage.distance_transform_edt` of ``~coarse``, tested equal), without scipy's call overhead of
    tens of microseconds on the small windows of most sets. ``coarse`` must have a member."""
    return np.sqrt(_squared_distances(coarse).astype(float))


@numba.njit(cache=True)
def _squared_distances(coarse):  # pragma: no cover (compiled)
    """(H, W) the least squared distance (integer) from each cell to a ``True`` one: Meijster, Roerdink & Hesselink
    (2000), "A general algorithm for computing distance transforms in linear time", with the Euclidean f and Sep.
    Phase 1: per column, the distance to the nearest member in it (``H + W`` for none, farther than any member);
    phase 2: per row, the lower envelope of the parabolas ``(x − u)² + g(u)²``, scanned left to right."""
    h, w = coarse.shape
    far = h + w
    g = np.empty((h, w), dtype=np.int64)
    for x in range(w):  # phase 1, down and up every column, row by row (in memory order)
        g[0, x] = 0 if coarse[0, x] else far
    for y in range(1, h):
        for x in range(w):
            g[y, x] = 0 if coarse[y, x] else g[y - 1, x] + 1
    for y in range(h - 2, -1, -1):
        for x in range(w):
            if g[y + 1, x] < g[y, x]:
                g[y, x] = g[y + 1, x] + 1
    out = np.empty((h, w), dtype=np.int64)
    s = np.empty(w, dtype=np.int64)  # the envelope's parabolas (their columns u)
    t = np.empty(w, dtype=np.int64)  # where each starts to be the least
    g2 = np.empty(w, dtype=np.int64)
    for y in range(h):
        for x in range(w):
            g2[x] = g[y, x] * g[y, x]
        q = 0
        s[0], t[0] = 0, 0
        for u in range(1, w):
            while q >= 0:
                a, b = t[q] - s[q], t[q] - u
                if a * a + g2[s[q]] <= b * b + g2[u]:
                    break
                q -= 1
            if q < 0:
                q = 0
                s[0] = u
            else:
                # Sep(s_q, u): the first column where u's parabola is at most s_q's, by integer division
                sq = s[q]
                sep = 1 + (u * u - sq * sq + g2[u] - g2[sq]) // (2 * (u - sq))
                if sep < w:
                    q += 1
                    s[q], t[q] = u, sep
        for x in range(w - 1, -1, -1):
            d = x - s[q]
            out[y, x] = d * d + g2[s[q]]
            if x == t[q]:
                q -= 1
    return out


def redistance_reference(grid: Grid, f: Field, block: int = 4) -> Field:
    """:func:`redistance` in numpy (the readable reference of its kernels :func:`_blocks` and :func:`_lift`)."""
    if f.is_empty:
        return f
    from scipy import ndimage

    h, w = f.data.shape
    H, W = -(-h // block), -(-w // block)
    padded = np.full((H * block, W * block), np.inf)
    padded[:h, :w] = f.data
    coarse = (padded <= grid.slack + DELTA).reshape(H, block, W, block).any(axis=(1, 3))
    if coarse.all():
        return f
    far = ndimage.distance_transform_edt(~coarse) * (block * grid.cell) - (2 * block - 1) * grid.slack
    lifted = np.maximum(f.data, np.repeat(np.repeat(far, block, axis=0), block, axis=1)[:h, :w])
    return f if (lifted == f.data).all() else Field(f.i0, f.j0, lifted, f.core)


@numba.njit(cache=True)
def _blocks(data, block, member):  # pragma: no cover (compiled)
    """(H, W) whether each ``block`` × ``block`` block of ``data`` holds a value ``≤ member``, block by block: a
    block's scan stops at its first member (inside a large set, at its first cell)."""
    h, w = data.shape
    out = np.zeros(((h + block - 1) // block, (w + block - 1) // block), dtype=np.bool_)
    for bi in range(out.shape[0]):
        for bj in range(out.shape[1]):
            for i in range(bi * block, min(h, (bi + 1) * block)):
                for j in range(bj * block, min(w, (bj + 1) * block)):
                    if data[i, j] <= member:
                        out[bi, bj] = True
                        break
                if out[bi, bj]:
                    break
    return out


@numba.njit(cache=True)
def _lift(data, far, block):  # pragma: no cover (compiled)
    """``max(data, far)`` with ``far`` per block, or None if it changes nothing (one pass, a block's ``far`` read
    once per row)."""
    h, w = data.shape
    out = np.empty_like(data)
    changed = False
    for i in range(h):
        row = far[i // block]
        for bj in range(len(row)):
            lift = row[bj]
            for j in range(bj * block, min(w, (bj + 1) * block)):
                v = data[i, j]
                if lift > v:
                    out[i, j] = lift
                    changed = True
                else:
                    out[i, j] = v
    return out if changed else None


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
