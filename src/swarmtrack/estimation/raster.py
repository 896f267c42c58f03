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

import numba
import numpy as np

# The representation and a field's measures (raster_field) and redistancing (raster_distance) have their own
# modules; their names are this module's too (__all__), the one raster API for callers.
from swarmtrack.estimation.raster_distance import block_distances, redistance, redistance_reference
from swarmtrack.estimation.raster_field import (
    DELTA,
    EMPTY,
    Field,
    Grid,
    _core_array,
    area,
    cell_area,
    centroid,
    holds,
    members,
    to_polygon,
)

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


__all__ = [
    "DELTA",
    "EMPTY",
    "KEEP",
    "MARGIN",
    "Convex",
    "Field",
    "Grid",
    "area",
    "block_distances",
    "box",
    "boxes",
    "cell_area",
    "centroid",
    "convex",
    "convex_all",
    "depth",
    "dilate",
    "full",
    "held_by_all",
    "holds",
    "intersect_all",
    "lower",
    "meet",
    "meets",
    "members",
    "redistance",
    "redistance_reference",
    "remove",
    "support_reference",
    "to_polygon",
    "trim",
    "union",
    "union_near",
    "values",
]
