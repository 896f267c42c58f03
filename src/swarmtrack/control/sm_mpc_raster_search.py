"""The distance term d of eq. 47 on raster sets, compiled (IB21 eq. 47; the raster SM-MPC,
:mod:`swarmtrack.control.sm_mpc_raster`, whose docstring describes the searches): the nearest member square of a
candidate's predicted set by rows in order of their gap to p, over the grid's lazy member rows (:func:`_nearest`) or
over the listed members (:func:`_nearest_listed`), and the farthest (:func:`_farthest`, Hausdorff).

The kernels take a candidate's terms as one tuple ``cover = (ids, nid, feet, thr)`` (the footprints ``ids[:nid]`` of
``feet``, :mod:`swarmtrack.control.sm_mpc_raster_areas`, and the member threshold), a row's member columns as
``members = (nxt, prv, row, a, b)`` (next/previous member column tables, their row, the columns ``[a, b)``), the
merged deep intervals of a row as ``deep = (lo, hi, m)`` and where a search stands as ``probe = (i, px, dy, best)``
(the grid row, p's x, the row's gap to p, the best distance so far).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from swarmtrack.control.sm_mpc_raster_areas import _candidate_ids, _merge, _term
from swarmtrack.control.sm_mpc_raster_members import ROW_BLOCK, _ensure_block, _ensure_row
from swarmtrack.estimation import raster as rs

DELTA = rs.DELTA


@numba.njit(cache=True)
def _terms_of(terms, steady, cand, ids):
    """The footprint ids of a candidate's terms and the steady ones into ``ids``; returns their number."""
    nid = _candidate_ids(terms, cand, ids)
    for p in range(len(steady)):
        ids[nid + p] = steady[p]
    return nid + len(steady)


@numba.njit(cache=True, inline="always")
def _covered(cover, geo, i, j):
    """Whether some term of the candidate (``cover``, module docstring) makes cell (i, j) a non-member (exactly)."""
    ids, nid, feet, thr = cover
    lines, lag, spans, t0, t1 = feet
    if i < t0 or i >= t1:
        return False
    x0, y0, c, r = geo[0], geo[1], geo[2], geo[3]
    x, y = x0 + (j + 0.5) * c, y0 + (i + 0.5) * c
    for q in range(nid):
        f = ids[q]
        if spans[f, i - t0, 0] <= j < spans[f, i - t0, 1] and _term(lines, lag, f, x, y, r) > thr:
            return True
    return False


@numba.njit(cache=True)
def _row_covers(cover, i, lo, hi):
    """The deep intervals of the candidate's terms (``cover``) on row i (sorted, merged) into lo/hi; returns their
    number."""
    ids, nid, feet, _ = cover
    spans, t0, t1 = feet[2], feet[3], feet[4]
    if i < t0 or i >= t1:
        return 0
    n = 0
    for q in range(nid):
        f = ids[q]
        if spans[f, i - t0, 2] < spans[f, i - t0, 3]:
            lo[n], hi[n] = spans[f, i - t0, 2], spans[f, i - t0, 3]
            n += 1
    return _merge(lo, hi, n)


@numba.njit(cache=True)
def _first_free(members, j, step, cover, deep, geo, probe):
    """From column j of grid row i (``probe``) in direction ``step`` (±1), the first member not covered by a term
    (``cover``; ``deep`` the row's merged deep intervals, :func:`_row_covers`), searched in columns [a, b) with the
    next/previous member columns of that range (``members = (nxt, prv, row, a, b)``: their row ``row``, column
    j − a; b and a − 1 when none). Returns (column, 0), or (−1, 0) if there is none before the range's end, or
    (−1, 1) if none is nearer than ``best`` (``probe = (i, px, dy, best)``, ``dy`` the row's gap to p; ``best``
    inf: no bound)."""
    nxt, prv, row, a, b = members
    lo, hi, m = deep
    i, px, dy, best = probe
    x0, c = geo[0], geo[2]
    bound = best * best * (1 + 1e-9) - dy * dy  # dx² beyond which the distance is surely ≥ best (no hypot)
    while a <= j < b:
        j = nxt[row, j - a] if step > 0 else prv[row, j - a]
        if j < a or j >= b:
            return -1, 0
        xl = x0 + j * c
        dx = max(max(xl - px, px - (xl + c)), 0.0)
        if dx * dx > bound:
            return -1, 1
        jumped = False
        for q in range(m):
            if lo[q] <= j < hi[q]:
                j = hi[q] if step > 0 else lo[q] - 1
                jumped = True
                break
        if jumped:
            continue
        if _covered(cover, geo, i, j):
            j += step
            continue
        return j, 0
    return -1, 0


@numba.njit(cache=True)
def _nearest(p, cover, room, geo, g, lazy, inner, warm):
    """Nearest distance from p = (px, py) to the member squares of one candidate (``cover``; 0 if none): rows in
    order of their gap to p, stopping at the best distance found; in each row the nearest free member on either
    side, first within R (``inner = (win, wnxt, wprv)``: R and its members from the plan's base values) when p's
    column is in it, then beyond it with the lazy rows of the grid (``g``, ``lazy``: :mod:`swarmtrack.control.
    sm_mpc_raster_members`, built only if a member there could still be nearer). ``room``: ``(lo, hi)``, space for a
    row's deep intervals. Returns the distance and the cell (i, j) that gives it ((−1, −1) if none).

    Warm start: ``warm = (wi, wj)``, a member cell of G (the previous candidate's nearest; −1: none), when this
    candidate's terms leave it free, bounds the search from the start (its distance by the same arithmetic); and the
    rest of a block of ROW_BLOCK grid rows in the search's direction is skipped when it has no member of G or the
    distance to its members' columns (``bmin``/``bmax``, :func:`_ensure_block`) at the current row's gap is not
    below the best (with a relative margin of 1e-9). The minimum is the same, found over fewer rows."""
    px, py = p
    lo, hi = room
    win, wnxt, wprv = inner
    wi, wj = warm
    fw = g[1]
    nxt, prv, has, bmin, bmax, bready = lazy[0], lazy[1], lazy[3], lazy[4], lazy[5], lazy[6]
    x0, y0, c = geo[0], geo[1], geo[2]
    nx = nxt.shape[1]
    ip = int(math.floor((py - y0) / c))
    jp = int(math.floor((px - x0) / c))
    in_cols = win[1] <= jp < win[3]
    dn, up = min(ip, fw[6] - 1), max(ip + 1, fw[4])
    best = np.inf
    bi = bj = -1
    if wi >= 0 and not _covered(cover, geo, wi, wj):
        xl = x0 + wj * c
        dy = max(max(y0 + wi * c - py, py - (y0 + (wi + 1) * c)), 0.0)
        best = math.hypot(max(max(xl - px, px - (xl + c)), 0.0), dy)
        bi, bj = wi, wj
    while True:
        gdn = max(max(y0 + dn * c - py, py - (y0 + (dn + 1) * c)), 0.0) if dn >= fw[4] else np.inf
        gup = max(max(y0 + up * c - py, py - (y0 + (up + 1) * c)), 0.0) if up < fw[6] else np.inf
        if min(gdn, gup) >= best:
            break
        if gdn <= gup:
            i, dy, rising = dn, gdn, False
            dn -= 1
        else:
            i, dy, rising = up, gup, True
            up += 1
        blk = i // ROW_BLOCK  # its rows farther from p than this one have a gap of at least dy
        if not bready[blk]:
            _ensure_block(blk, g, lazy)
        if bmin[blk] > bmax[blk] or _block_beyond(bmin[blk], bmax[blk], px, dy, best, x0, c):
            up, dn = _past_block(blk, rising, up, dn)
            continue
        deep = (lo, hi, _row_covers(cover, i, lo, hi))
        for step in (1, -1):
            start = jp if step > 0 else jp - 1
            found, cut = -1, 0
            if in_cols and win[0] <= i < win[2]:
                found, cut = _first_free((wnxt, wprv, i - win[0], win[1], win[3]), start, step, cover, deep, geo,
                                         (i, px, dy, best))
                start = win[3] if step > 0 else win[1] - 1
            elif not 0 <= start < nx:
                start = max(start, 0) if step > 0 else min(start, nx - 1)
            if found < 0 and cut == 0 and 0 <= start < nx:
                xl = x0 + start * c
                if math.hypot(max(max(xl - px, px - (xl + c)), 0.0), dy) < best:
                    _ensure_row(i, g, lazy)
                    if has[i]:
                        found, cut = _first_free((nxt, prv, i, 0, nx), start, step, cover, deep, geo,
                                                 (i, px, dy, best))
            if found >= 0:
                xl = x0 + found * c
                d = math.hypot(max(max(xl - px, px - (xl + c)), 0.0), dy)
                if d < best:
                    best, bi, bj = d, i, found
    return (0.0 if best == np.inf else best), bi, bj


@numba.njit(cache=True)
def _farthest(p, cover, room, geo, g, lazy):
    """Farthest distance from p = (px, py) to the member squares (their farthest corners) of one candidate
    (``cover``; 0 if none): per row, the first free member from either end; rows whose raw extreme members cannot
    beat the best are skipped. ``g``, ``lazy`` and ``room`` as :func:`_nearest`'s."""
    px, py = p
    lo, hi = room
    fw = g[1]
    nxt, prv, has = lazy[0], lazy[1], lazy[3]
    x0, y0, c = geo[0], geo[1], geo[2]
    nx = nxt.shape[1]
    best = -1.0
    for i in range(fw[4], fw[6]):
        _ensure_row(i, g, lazy)
        if not has[i]:
            continue
        yl = y0 + i * c
        dy = max(abs(yl - py), abs(yl + c - py))
        a, b = nxt[i, 0], prv[i, nx - 1]
        bound = math.hypot(max(abs(x0 + a * c - px), abs(x0 + (b + 1) * c - px)), dy)
        if bound <= best:
            continue
        deep = (lo, hi, _row_covers(cover, i, lo, hi))
        for start, step in ((0, 1), (nx - 1, -1)):
            j, _ = _first_free((nxt, prv, i, 0, nx), start, step, cover, deep, geo, (i, px, 0.0, np.inf))
            if j >= 0:
                xl = x0 + j * c
                best = max(best, math.hypot(max(abs(xl - px), abs(xl + c - px)), dy))
    return max(best, 0.0)


@numba.njit(cache=True)
def _distances(which, cands, feet, geo, hausdorff, g, lazy, inner):
    """d of eq. 47 for the candidates ``which`` (``cands = (terms, steady, xy)``: each candidate's footprints of
    ``feet``, the steady ones, the ends p): nearest (:func:`_nearest`) or farthest member square, with the steady
    terms."""
    terms, steady, xy = cands
    k = terms.shape[1] + len(steady)
    ids = np.empty(k, dtype=np.int64)
    room = (np.empty(k, dtype=np.int64), np.empty(k, dtype=np.int64))
    out = np.empty(len(which))
    thr = g[6]
    wi = wj = -1  # the previous candidate's nearest cell, the next one's warm start (:func:`_nearest`)
    for q in range(len(which)):
        cand = which[q]
        cover = (ids, _terms_of(terms, steady, cand, ids), feet, thr)
        p = (xy[cand, 0], xy[cand, 1])
        if hausdorff:
            out[q] = _farthest(p, cover, room, geo, g, lazy)
        else:
            out[q], bi, bj = _nearest(p, cover, room, geo, g, lazy, inner, (wi, wj))
            if bi >= 0:
                wi, wj = bi, bj
    return out


@numba.njit(cache=True)
def _nearest_listed(which, cands, feet, geo, listing):
    """The nearest distance of :func:`_nearest` (0 if no member is left) over the listed member cells of G
    (``listing = (rows, starts, cols, blo, bhi)``, :func:`_member_list` and :func:`_listed_blocks`), those the terms
    of the candidate and the steady ones cover left out (``cands`` as :func:`_distances`'): the member rows in
    order of their gap to p, stopping at the best distance found; in each, the nearest uncovered member on either
    side of p's column (found by bisection, jumping over the deep intervals). The same minimum as testing every
    listed cell, by the same arithmetic: along a row the distance only grows away from p.

    Warm start: the cell nearest to the previous candidate's p (the candidates' ends lie close together), when
    this candidate's terms leave it free, bounds the search from the start (its distance by the same arithmetic);
    and the rest of a block of listed rows (``blo``/``bhi`` its column extents, :func:`_listed_blocks`) in the
    search's direction is skipped when the distance to its columns at the current row's gap is not below the best
    (with a relative margin of 1e-9: a bound, the others' arithmetic need not agree with it to the last bit). The
    minimum is the same, found over fewer rows and cells."""
    terms, steady, xy = cands
    rows, starts, cols, blo, bhi = listing
    x0, y0, c, slack = geo[0], geo[1], geo[2], geo[4]
    k = terms.shape[1] + len(steady)
    ids = np.empty(k, dtype=np.int64)
    lo, hi = np.empty(k, dtype=np.int64), np.empty(k, dtype=np.int64)
    thr = slack + DELTA
    out = np.empty(len(which))
    wi = wj = -1  # the previous candidate's nearest cell (none yet)
    for q in range(len(which)):
        cand = which[q]
        cover = (ids, _terms_of(terms, steady, cand, ids), feet, thr)
        px, py = xy[cand, 0], xy[cand, 1]
        ip = int(math.floor((py - y0) / c))
        jp = int(math.floor((px - x0) / c))
        up = np.searchsorted(rows, ip)  # member rows ≥ ip from here, those below from up − 1 down
        dn = up - 1
        best = np.inf
        bi = bj = -1
        if wi >= 0 and not _covered(cover, geo, wi, wj):
            best = math.hypot(_gap(x0 + wj * c, px, c), _gap(y0 + wi * c, py, c))
            bi, bj = wi, wj
        while True:
            gdn = _gap(y0 + rows[dn] * c, py, c) if dn >= 0 else np.inf
            gup = _gap(y0 + rows[up] * c, py, c) if up < len(rows) else np.inf
            if min(gdn, gup) >= best:
                break
            if gdn <= gup:
                at, dy, rising = dn, gdn, False
                dn -= 1
            else:
                at, dy, rising = up, gup, True
                up += 1
            blk = at // ROW_BLOCK  # its rows farther from p than this one have a gap of at least dy
            if _block_beyond(blo[blk], bhi[blk], px, dy, best, x0, c):
                up, dn = _past_block(blk, rising, up, dn)
                continue
            i = rows[at]
            a, b = starts[at], starts[at + 1]
            deep = (lo, hi, _row_covers(cover, i, lo, hi))
            first = a + np.searchsorted(cols[a:b], jp)  # the first member column ≥ jp
            for step in (1, -1):
                e = _first_listed((cols, a, b), first if step > 0 else first - 1, step, cover, deep, geo,
                                  (i, px, dy, best))
                if e >= 0:
                    d = math.hypot(_gap(x0 + cols[e] * c, px, c), dy)
                    if d < best:
                        best, bi, bj = d, i, cols[e]
        out[q] = 0.0 if best == np.inf else best
        if bi >= 0:
            wi, wj = bi, bj
    return out


@numba.njit(cache=True)
def _first_listed(listed, e, step, cover, deep, geo, probe):
    """From entry e of the listed member columns ``cols[a:b]`` of grid row i (``listed = (cols, a, b)``, ``probe =
    (i, px, dy, best)``) in direction ``step`` (±1), the first one not covered by a term (``cover``; ``deep`` the
    row's merged deep intervals, :func:`_row_covers`), or −1 if there is none or none nearer than ``best`` (``dy``
    the row's gap to p)."""
    cols, a, b = listed
    lo, hi, m = deep
    i, px, dy, best = probe
    x0, c = geo[0], geo[2]
    bound = best * best * (1 + 1e-9) - dy * dy  # dx² beyond which the distance is surely ≥ best (no hypot)
    while a <= e < b:
        j = cols[e]
        dx = _gap(x0 + j * c, px, c)
        if dx * dx > bound:
            return -1
        jumped = False
        for q in range(m):
            if lo[q] <= j < hi[q]:  # to the first entry past the interval
                e = a + np.searchsorted(cols[a:b], hi[q]) if step > 0 else a + np.searchsorted(cols[a:b], lo[q]) - 1
                jumped = True
                break
        if jumped:
            continue
        if _covered(cover, geo, i, j):
            e += step
            continue
        return e
    return -1


@numba.njit(cache=True, inline="always")
def _block_beyond(lo, hi, px, dy, best, x0, c):
    """Whether a block of rows whose members lie in the columns ``[lo, hi]``, each row at a gap of at least ``dy``
    from p, cannot hold a member nearer than ``best`` (with a relative margin of 1e-9: a bound, the searches'
    own arithmetic need not agree with it to the last bit). Both nearest searches skip such a block."""
    wide = max(max(x0 + lo * c - px, px - (x0 + hi * c + c)), 0.0)
    return math.hypot(wide, dy) >= best * (1 + 1e-9)


@numba.njit(cache=True, inline="always")
def _past_block(blk, rising, up, dn):
    """The outward search's next rows ``(up, dn)`` once block ``blk`` is skipped in its direction."""
    if rising:
        return (blk + 1) * ROW_BLOCK, dn
    return up, blk * ROW_BLOCK - 1


@numba.njit(cache=True, inline="always")
def _gap(lower, p, c):
    """Distance from coordinate p to the cell side ``[lower, lower + c]`` (0 inside)."""
    return max(max(lower - p, p - (lower + c)), 0.0)
