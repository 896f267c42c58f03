"""The members of G, the Field after the h rounds of eq. 44 without removals (IB21 eqs. 44, 47; the raster SM-MPC,
:mod:`swarmtrack.control.sm_mpc_raster`): the only cells that can be members of a candidate's predicted set, since
removals only raise the values. Per row of the grid, filled lazily as the distance searches reach it
(:class:`MemberRows`, the compiled :func:`_ensure_row` and :func:`_ensure_block`), or listed row by row when they are
few (:func:`_member_list`, :func:`_listed_blocks`); and the members of the window R from the plan's base values
(:func:`_range_members`).

The kernels take G as one tuple ``g = (src, fw, h, r, outside, clip, thr)`` (:attr:`MemberRows.g`: the Field's
stored values and strips, its window and box, the rounds h, the dilation r per round, X0's outside bounds and whether
to clip to them, and the member threshold c/√2 + DELTA), and the lazily filled member columns as one tuple ``lazy =
(nxt, prv, ready, has, bmin, bmax, bready)`` (:attr:`MemberRows.lazy`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from swarmtrack.control.sm_mpc_problem import SMMPCSettings
from swarmtrack.estimation import raster as rs

DELTA = rs.DELTA


#: Listed member rows per block of :func:`_listed_blocks` (the listed search skips a block that cannot be nearer).
ROW_BLOCK = 8


@dataclass
class MemberRows:
    """The Field's values where members of a candidate's set can be, and per row of the grid the columns of the
    cells of ``G = max(v0 − h·r, outside)`` that are members (the only cells that can be members of a candidate's
    set: removals only raise v): ``nxt[i, j]`` the first member column ≥ j (nx if none), ``prv[i, j]`` the last ≤ j
    (−1), ``has[i]``; filled by the kernel row by row as the searches reach them (``ready[i]``).

    Members lie in the *box*, the Field's window grown by the reach of the h dilations (off its window, the Field's
    bound is at least the distance to the window's rectangle). ``src`` holds the Field's stored values and
    :func:`raster.values` on the four strips of the box about them (so the kernel asks the raster module for the
    bounds off the window rather than recomputing them), ``fw`` the window and the box ``(i0, j0, i1, j1)`` × 2;
    ``g`` what the kernels need to evaluate G (module docstring)."""

    field: rs.Field
    src: tuple
    fw: np.ndarray
    g: tuple
    nxt: np.ndarray
    prv: np.ndarray
    ready: np.ndarray
    has: np.ndarray
    #: per block of ROW_BLOCK grid rows, the least and greatest member column (``bmin > bmax``: none), filled with
    #: its rows when a search first reaches it (``bready``; :func:`_ensure_block`)
    bmin: np.ndarray
    bmax: np.ndarray
    bready: np.ndarray
    members: tuple | None = None  # (rows, starts, columns, complete) of G's members, if few (:func:`_member_list`)
    blocks: tuple | None = None  # the listed rows' column extents per block of ROW_BLOCK (:func:`_listed_blocks`)

    @property
    def lazy(self) -> tuple:
        """The member columns as the kernels take them, ``(nxt, prv, ready, has, bmin, bmax, bready)``."""
        return self.nxt, self.prv, self.ready, self.has, self.bmin, self.bmax, self.bready


def member_rows(grid: rs.Grid, region: rs.Field, s: SMMPCSettings, shared: dict | None = None) -> MemberRows:
    """The (lazy) :class:`MemberRows` of ``region`` for these settings, kept in ``shared`` per Field object (so the
    UAVs of one fleet plan holding the same Field fill it once)."""
    r = 0.0 if s.baseline else s.target_speed * s.period
    key = ("raster-members", id(region), id(grid), s.horizon, r, s.baseline)
    hit = None if shared is None else shared.get(key)
    if hit is not None and hit.field is region:
        return hit
    limit = grid.slack + 2 * DELTA + s.horizon * r  # a value above it gives no member after the h dilations
    m = math.ceil((s.horizon * r + grid.slack + 2 * DELTA) / grid.cell + 0.5) + 1
    i0, j0, i1, j1 = region.window
    b0, b1, b2, b3 = max(0, i0 - m), max(0, j0 - m), min(grid.ny, i1 + m), min(grid.nx, j1 + m)
    ci0, cj0, ci1, cj1 = region.core
    src = (region.data, _strip(grid, region, (b0, b1, i0, b3), ci0 - i0, limit),
           _strip(grid, region, (i1, b1, b2, b3), i1 - ci1, limit),
           _strip(grid, region, (i0, b1, i1, j0), cj0 - j0, limit),
           _strip(grid, region, (i0, j1, i1, b3), j1 - cj1, limit))
    fw = np.array([i0, j0, i1, j1, b0, b1, b2, b3], dtype=np.int64)
    clip = not s.baseline and grid.outside is not None  # eq. 44's clip to X0 (the baseline does not dilate)
    g = (src, fw, s.horizon, r, grid.outside if clip else np.zeros((1, 1)), clip, grid.slack + DELTA)
    blocks = (grid.ny + ROW_BLOCK - 1) // ROW_BLOCK
    rows = MemberRows(region, src, fw, g, np.empty((grid.ny, grid.nx), dtype=np.int32),
                      np.empty((grid.ny, grid.nx), dtype=np.int32), np.zeros(grid.ny, dtype=np.uint8),
                      np.zeros(grid.ny, dtype=np.uint8), np.empty(blocks, dtype=np.int64),
                      np.empty(blocks, dtype=np.int64), np.zeros(blocks, dtype=np.uint8))
    # rows where no value is low enough to give a member after the h dilations are done already (no member), so
    # the searches never evaluate them: far from small sets, most rows of the box are such
    _rows_without_members(src, fw, limit, rows.ready, rows.has)
    if shared is not None:
        shared[key] = rows
    return rows


def _strip(grid: rs.Grid, region: rs.Field, window: tuple[int, int, int, int], gap: int = 0,
           limit: float = math.inf) -> np.ndarray:
    """:func:`raster.values` on ``window`` (a part of the box off the Field's stored window, on the side where
    ``gap`` cells lie between the window's edge and the core's), C-ordered floats; or ``+inf`` everywhere when no
    value there can be at most ``limit``. Off the stored window a value is at least the distance from the cell's
    centre to the core's rectangle (:func:`raster.values`), here at least ``(gap + 1/2)·c``; so when that exceeds
    ``limit`` (with a margin for round-off) the strip gives no member after the h dilations, no area (``cell_area``
    0) and nothing to remove, as ``+inf`` gives: the same numbers in every use of :class:`MemberRows`' values."""
    i0, j0, i1, j1 = window
    if i0 >= i1 or j0 >= j1:
        return np.zeros((max(i1 - i0, 0), max(j1 - j0, 0)))
    if (gap + 0.5) * grid.cell > limit + 1e-6:
        return np.full((i1 - i0, j1 - j0), np.inf)
    return np.ascontiguousarray(rs.values(grid, region, window), dtype=float)


@numba.njit(cache=True)
def _g_row(g, i, j0, j1, out):
    """``G`` on cells (i, j0 … j1−1) into ``out[:j1 − j0]``: the Field's values after h rounds of eq. 44 without
    removals. ``g`` (module docstring): ``src`` (stored values, top, bottom, left and right strips of
    :func:`raster.values` about them) and ``fw`` (stored window, box) as :class:`MemberRows`, the h rounds of r and
    of the clip to ``outside``; ``+inf`` off the box (no member there)."""
    src, fw, h, r, outside, clip = g[0], g[1], g[2], g[3], g[4], g[5]
    data, top, bottom, left, right = src
    fi0, fj0, fi1, fj1, b0, b1, b2, b3 = fw[0], fw[1], fw[2], fw[3], fw[4], fw[5], fw[6], fw[7]
    for j in range(j1 - j0):
        out[j] = np.inf
    if b0 <= i < b2:
        ja, jb = max(j0, b1), min(j1, b3)
        if i < fi0 or i >= fi1:
            strip, row = (top, i - b0) if i < fi0 else (bottom, i - fi1)
            for j in range(ja, jb):
                out[j - j0] = strip[row, j - b1]
        else:
            for j in range(ja, min(jb, fj0)):
                out[j - j0] = left[i - fi0, j - b1]
            for j in range(max(ja, fj0), min(jb, fj1)):
                out[j - j0] = data[i - fi0, j - fj0]
            for j in range(max(ja, fj1), jb):
                out[j - j0] = right[i - fi0, j - fj1]
    if r != 0.0 or clip:
        for _ in range(h):
            for j in range(j1 - j0):
                out[j] = out[j] - r
            if clip:
                for j in range(j1 - j0):
                    out[j] = max(out[j], outside[i, j0 + j])


@numba.njit(cache=True)
def _rows_without_members(src, fw, limit, ready, has):
    """Mark ready, with no member, every grid row whose values in ``src`` (as :class:`MemberRows`) are all above
    ``limit`` (G = v − h·r, raised by the clip, is then above the member threshold) or that lies off the box."""
    data, top, bottom, left, right = src
    fi0, fi1, b0, b2 = fw[0], fw[2], fw[4], fw[6]
    for i in range(len(ready)):
        if i < b0 or i >= b2:
            low = False
        elif i < fi0:
            low = _any_at_most(top[i - b0], limit)
        elif i >= fi1:
            low = _any_at_most(bottom[i - fi1], limit)
        else:
            k = i - fi0
            low = _any_at_most(data[k], limit) or _any_at_most(left[k], limit) or _any_at_most(right[k], limit)
        if not low:
            ready[i] = 1
            has[i] = 0


@numba.njit(cache=True, inline="always")
def _any_at_most(row, limit):
    """Whether some value of ``row`` is at most ``limit`` (stops at the first)."""
    for v in row:
        if v <= limit:
            return True
    return False


@numba.njit(cache=True)
def _member_list(g, ready, has, most):
    """The cells where G is a member, row by row: the rows holding some (ascending), ``starts`` (one more) where
    each row's columns begin in ``cols`` (ascending within a row), and True; or empty arrays and False if there are
    more than ``most``. Rows marked ready without a member (:func:`_rows_without_members`) are not evaluated."""
    fw, thr = g[1], g[6]
    rows, starts = np.empty(fw[6] - fw[4], dtype=np.int64), np.zeros(fw[6] - fw[4] + 1, dtype=np.int64)
    cols = np.empty(most, dtype=np.int64)
    n = nr = 0
    width = fw[7] - fw[5]
    vals = np.empty(max(width, 0))
    for i in range(fw[4], fw[6]):
        if ready[i] and not has[i]:
            continue
        _g_row(g, i, fw[5], fw[7], vals)
        for j in range(width):
            if vals[j] <= thr:
                if n == most:
                    return rows[:0], starts[:1], cols[:0], False
                cols[n] = fw[5] + j
                n += 1
        if n > starts[nr]:
            rows[nr] = i
            nr += 1
            starts[nr] = n
    return rows[:nr], starts[:nr + 1], cols[:n], True


def listed_blocks_reference(starts: np.ndarray, cols: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_listed_blocks` in numpy: per block of ``size`` listed rows, the least of their first member columns
    and the greatest of their last ones."""
    first, last = cols[starts[:-1]], cols[starts[1:] - 1]
    at = np.arange(0, len(first), size)
    return np.minimum.reduceat(first, at), np.maximum.reduceat(last, at)


@numba.njit(cache=True)
def _listed_blocks(starts, cols, size):
    """The least and greatest member column of each block of ``size`` consecutive listed rows (:func:`_member_list`;
    the columns ascend within a row)."""
    n = len(starts) - 1
    nb = (n + size - 1) // size
    lo, hi = np.empty(nb, dtype=np.int64), np.empty(nb, dtype=np.int64)
    for b in range(nb):
        a, z = b * size, min(n, (b + 1) * size)
        lo[b], hi[b] = cols[starts[a]], cols[starts[a + 1] - 1]
        for e in range(a + 1, z):
            lo[b], hi[b] = min(lo[b], cols[starts[e]]), max(hi[b], cols[starts[e + 1] - 1])
    return lo, hi


@numba.njit(cache=True)
def _ensure_block(blk, g, lazy):
    """Fill the rows of block ``blk`` (ROW_BLOCK grid rows) of the G-member columns ``lazy`` (:func:`_ensure_row`)
    and its members' column extent (``bmin > bmax`` when it has none)."""
    nxt, prv, has, bmin, bmax, bready = lazy[0], lazy[1], lazy[3], lazy[4], lazy[5], lazy[6]
    ny, nx = nxt.shape
    lo, hi = nx, -1
    for i in range(blk * ROW_BLOCK, min((blk + 1) * ROW_BLOCK, ny)):
        _ensure_row(i, g, lazy)
        if has[i]:
            lo, hi = min(lo, nxt[i, 0]), max(hi, prv[i, nx - 1])
    bmin[blk], bmax[blk] = lo, hi
    bready[blk] = 1


@numba.njit(cache=True)
def _ensure_row(i, g, lazy):
    """Fill row i of the G-member columns ``lazy`` (:attr:`MemberRows.lazy`) if not done yet."""
    nxt, prv, ready, has = lazy[0], lazy[1], lazy[2], lazy[3]
    if ready[i]:
        return
    fw, thr = g[1], g[6]
    nx = nxt.shape[1]
    last = -1
    b0, b1 = (fw[5], fw[7]) if fw[4] <= i < fw[6] else (nx, nx)
    for j in range(b0):
        prv[i, j] = -1
    if b0 < b1:
        vals = np.empty(b1 - b0)
        _g_row(g, i, b0, b1, vals)
        for j in range(b0, b1):
            if vals[j - b0] <= thr:
                last = j
            prv[i, j] = last
    for j in range(b1, nx):
        prv[i, j] = last
    has[i] = 1 if last >= 0 else 0
    following = nx
    for j in range(nx - 1, -1, -1):
        if prv[i, j] == j:
            following = j
        nxt[i, j] = following
    ready[i] = 1


@numba.njit(cache=True)
def _range_members(base, thr, j0):
    """Next/previous member columns (absolute; j1 and j0 − 1 when none) of each row of the window values
    ``base`` whose first column is j0: the members of R without the lazy rows."""
    n, w = base.shape
    nxt, prv = np.empty((n, w), dtype=np.int32), np.empty((n, w), dtype=np.int32)
    for i in range(n):
        last = j0 - 1
        for j in range(w):
            if base[i, j] <= thr:
                last = j0 + j
            prv[i, j] = last
        following = j0 + w
        for j in range(w - 1, -1, -1):
            if prv[i, j] == j0 + j:
                following = j0 + j
            nxt[i, j] = following
    return nxt, prv
