"""Redistancing of raster sets (IB21's guaranteed sets held as fields, :mod:`swarmtrack.estimation.raster`):
:func:`redistance` raises a field's bounds to the distance from each cell to the set's member cells, measured on
blocks of cells by an exact Euclidean distance transform (:func:`block_distances`, Meijster, Roerdink & Hesselink
2000), compiled, beside its numpy reference :func:`redistance_reference` (tested equal). ``raster`` re-exports these
names.
"""

from __future__ import annotations

import numba
import numpy as np

from swarmtrack.estimation.raster_field import DELTA, Field, Grid


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
