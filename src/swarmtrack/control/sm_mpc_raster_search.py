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
def _covered(ids, nid, lines, lag, spans, t0, t1, i, j, x, y, r, thr):
    """Whether some term of ``ids[:nid]`` makes cell (i, j) a non-member (exactly)."""
    if i < t0 or i >= t1:
        return False
    for q in range(nid):
        f = ids[q]
        if spans[f, i - t0, 0] <= j < spans[f, i - t0, 1] and _term(lines, lag, f, x, y, r) > thr:
            return True
    return False


@numba.njit(cache=True)
def _row_covers(ids, nid, spans, t0, t1, i, lo, hi):
    """The deep intervals of ``ids[:nid]`` on row i (sorted, merged) into lo/hi; returns their number."""
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
def _first_free(i, row, j, step, nxt, prv, a, b, ids, nid, lines, lag, spans, t0, t1, lo, hi, m, geo, thr, px, dy,
                best):
    """From column j of grid row i in direction ``step`` (±1), the first member not covered by a term, searched in
    columns [a, b) with the next/previous member columns of that range ``nxt``/``prv`` (their row ``row``, column
    j − a; b and a − 1 when none). Returns (column, 0), or (−1, 0) if there is none before the range's end, or
    (−1, 1) if none is nearer than ``best`` (``dy`` the row's gap to p; ``best`` inf: no bound)."""
    x0, y0, c, r = geo[0], geo[1], geo[2], geo[3]
    y = y0 + (i + 0.5) * c
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
        if _covered(ids, nid, lines, lag, spans, t0, t1, i, j, x0 + (j + 0.5) * c, y, r, thr):
            j += step
            continue
        return j, 0
    return -1, 0


@numba.njit(cache=True)
def _nearest(px, py, ids, nid, lines, lag, spans, t0, t1, geo, thr, src, fw, h, outside, clip, nxt, prv, ready,
             has, bmin, bmax, bready, lo, hi, win, wnxt, wprv, wi, wj):
    """Nearest distance from (px, py) to the member squares of one candidate (0 if none): rows in order of their
    gap to p, stopping at the best distance found; in each row the nearest free member on either side, first
    within R (``win``, its members ``wnxt``/``wprv`` from the plan's base values) when p's column is in it, then
    beyond it with the lazy rows of the grid (built only if a member there could still be nearer). Returns the
    distance and the cell (i, j) that gives it ((−1, −1) if none).

    Warm start: ``(wi, wj)``, a member cell of G (the previous candidate's nearest; −1: none), when this candidate's
    terms leave it free, bounds the search from the start (its distance by the same arithmetic); and the rest of a
    block of ROW_BLOCK grid rows in the search's direction is skipped when it has no member of G or the distance to
    its members' columns (``bmin``/``bmax``, :func:`_ensure_block`) at the current row's gap is not below the best
    (with a relative margin of 1e-9). The minimum is the same, found over fewer rows."""
    x0, y0, c, r = geo[0], geo[1], geo[2], geo[3]
    nx = nxt.shape[1]
    ip = int(math.floor((py - y0) / c))
    jp = int(math.floor((px - x0) / c))
    in_cols = win[1] <= jp < win[3]
    dn, up = min(ip, fw[6] - 1), max(ip + 1, fw[4])
    best = np.inf
    bi = bj = -1
    if wi >= 0 and not _covered(ids, nid, lines, lag, spans, t0, t1, wi, wj, x0 + (wj + 0.5) * c,
                                y0 + (wi + 0.5) * c, r, thr):
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
            _ensure_block(blk, src, fw, h, r, outside, clip, thr, nxt, prv, ready, has, bmin, bmax, bready)
        if bmin[blk] > bmax[blk] or _block_beyond(bmin[blk], bmax[blk], px, dy, best, x0, c):
            up, dn = _past_block(blk, rising, up, dn)
            continue
        m = _row_covers(ids, nid, spans, t0, t1, i, lo, hi)
        for step in (1, -1):
            start = jp if step > 0 else jp - 1
            found, cut = -1, 0
            if in_cols and win[0] <= i < win[2]:
                found, cut = _first_free(i, i - win[0], start, step, wnxt, wprv, win[1], win[3], ids, nid, lines,
                                         lag, spans, t0, t1, lo, hi, m, geo, thr, px, dy, best)
                start = win[3] if step > 0 else win[1] - 1
            elif not 0 <= start < nx:
                start = max(start, 0) if step > 0 else min(start, nx - 1)
            if found < 0 and cut == 0 and 0 <= start < nx:
                xl = x0 + start * c
                if math.hypot(max(max(xl - px, px - (xl + c)), 0.0), dy) < best:
                    _ensure_row(i, src, fw, h, r, outside, clip, thr, nxt, prv, ready, has)
                    if has[i]:
                        found, cut = _first_free(i, i, start, step, nxt, prv, 0, nx, ids, nid, lines, lag, spans,
                                                 t0, t1, lo, hi, m, geo, thr, px, dy, best)
            if found >= 0:
                xl = x0 + found * c
                d = math.hypot(max(max(xl - px, px - (xl + c)), 0.0), dy)
                if d < best:
                    best, bi, bj = d, i, found
    return (0.0 if best == np.inf else best), bi, bj


@numba.njit(cache=True)
def _farthest(px, py, ids, nid, lines, lag, spans, t0, t1, geo, thr, src, fw, h, outside, clip, nxt, prv, ready,
              has, lo, hi):
    """Farthest distance from (px, py) to the member squares (their farthest corners) of one candidate (0 if
    none): per row, the first free member from either end; rows whose raw extreme members cannot beat the best
    are skipped."""
    x0, y0, c, r = geo[0], geo[1], geo[2], geo[3]
    nx = nxt.shape[1]
    best = -1.0
    for i in range(fw[4], fw[6]):
        _ensure_row(i, src, fw, h, r, outside, clip, thr, nxt, prv, ready, has)
        if not has[i]:
            continue
        yl = y0 + i * c
        dy = max(abs(yl - py), abs(yl + c - py))
        a, b = nxt[i, 0], prv[i, nx - 1]
        bound = math.hypot(max(abs(x0 + a * c - px), abs(x0 + (b + 1) * c - px)), dy)
        if bound <= best:
            continue
        m = _row_covers(ids, nid, spans, t0, t1, i, lo, hi)
        for start, step in ((0, 1), (nx - 1, -1)):
            j, _ = _first_free(i, i, start, step, nxt, prv, 0, nx, ids, nid, lines, lag, spans, t0, t1, lo, hi, m,
                               geo, thr, px, 0.0, np.inf)
            if j >= 0:
                xl = x0 + j * c
                best = max(best, math.hypot(max(abs(xl - px), abs(xl + c - px)), dy))
    return max(best, 0.0)


@numba.njit(cache=True)
def _distances(which, terms, steady, lines, lag, spans, t0, t1, geo, slack, xy, hausdorff, src, fw, h, outside,
               clip, nxt, prv, ready, has, bmin, bmax, bready, win, wnxt, wprv):
    """d of eq. 47 for the candidates ``which``: nearest or farthest member square, with the steady terms."""
    k = terms.shape[1] + len(steady)
    ids = np.empty(k, dtype=np.int64)
    lo, hi = np.empty(k, dtype=np.int64), np.empty(k, dtype=np.int64)
    out = np.empty(len(which))
    thr = slack + DELTA
    wi = wj = -1  # the previous candidate's nearest cell, the next one's warm start (:func:`_nearest`)
    for q in range(len(which)):
        cand = which[q]
        nid = _terms_of(terms, steady, cand, ids)
        if hausdorff:
            out[q] = _farthest(xy[cand, 0], xy[cand, 1], ids, nid, lines, lag, spans, t0, t1, geo, thr, src, fw, h,
                               outside, clip, nxt, prv, ready, has, lo, hi)
        else:
            out[q], bi, bj = _nearest(xy[cand, 0], xy[cand, 1], ids, nid, lines, lag, spans, t0, t1, geo, thr, src,
                                      fw, h, outside, clip, nxt, prv, ready, has, bmin, bmax, bready, lo, hi, win,
                                      wnxt, wprv, wi, wj)
            if bi >= 0:
                wi, wj = bi, bj
    return out


@numba.njit(cache=True)
def _nearest_listed(which, terms, steady, lines, lag, spans, t0, t1, geo, slack, xy, rows, starts, cols, blo, bhi):
    """The nearest distance of :func:`_nearest` (0 if no member is left) over the listed member cells of G
    (:func:`_member_list`), those the terms of the candidate and the steady ones cover left out: the member rows in
    order of their gap to p, stopping at the best distance found; in each, the nearest uncovered member on either
    side of p's column (found by bisection, jumping over the deep intervals). The same minimum as testing every
    listed cell, by the same arithmetic: along a row the distance only grows away from p.

    Warm start: the cell nearest to the previous candidate's p (the candidates' ends lie close together), when
    this candidate's terms leave it free, bounds the search from the start (its distance by the same arithmetic);
    and the rest of a block of listed rows (``blo``/``bhi`` its column extents, :func:`_listed_blocks`) in the
    search's direction is skipped when the distance to its columns at the current row's gap is not below the best
    (with a relative margin of 1e-9: a bound, the others' arithmetic need not agree with it to the last bit). The
    minimum is the same, found over fewer rows and cells."""
    x0, y0, c, r = geo[0], geo[1], geo[2], geo[3]
    k = terms.shape[1] + len(steady)
    ids = np.empty(k, dtype=np.int64)
    lo, hi = np.empty(k, dtype=np.int64), np.empty(k, dtype=np.int64)
    thr = slack + DELTA
    out = np.empty(len(which))
    wi = wj = -1  # the previous candidate's nearest cell (none yet)
    for q in range(len(which)):
        cand = which[q]
        nid = _terms_of(terms, steady, cand, ids)
        px, py = xy[cand, 0], xy[cand, 1]
        ip = int(math.floor((py - y0) / c))
        jp = int(math.floor((px - x0) / c))
        up = np.searchsorted(rows, ip)  # member rows ≥ ip from here, those below from up − 1 down
        dn = up - 1
        best = np.inf
        bi = bj = -1
        if wi >= 0 and not _covered(ids, nid, lines, lag, spans, t0, t1, wi, wj, x0 + (wj + 0.5) * c,
                                    y0 + (wi + 0.5) * c, r, thr):
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
            m = _row_covers(ids, nid, spans, t0, t1, i, lo, hi)
            first = a + np.searchsorted(cols[a:b], jp)  # the first member column ≥ jp
            for step in (1, -1):
                e = _first_listed(cols, first if step > 0 else first - 1, step, a, b, i, ids, nid, lines, lag,
                                  spans, t0, t1, lo, hi, m, geo, thr, px, dy, best)
                if e >= 0:
                    d = math.hypot(_gap(x0 + cols[e] * c, px, c), dy)
                    if d < best:
                        best, bi, bj = d, i, cols[e]
        out[q] = 0.0 if best == np.inf else best
        if bi >= 0:
            wi, wj = bi, bj
    return out


@numba.njit(cache=True)
def _first_listed(cols, e, step, a, b, i, ids, nid, lines, lag, spans, t0, t1, lo, hi, m, geo, thr, px, dy, best):
    """From entry e of the listed member columns ``cols[a:b]`` of grid row i in direction ``step`` (±1), the first
    one not covered by a term (``lo``/``hi`` its ``m`` merged deep intervals, :func:`_row_covers`), or −1 if there
    is none or none nearer than ``best`` (``dy`` the row's gap to p)."""
    x0, y0, c, r = geo[0], geo[1], geo[2], geo[3]
    y = y0 + (i + 0.5) * c
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
        if _covered(ids, nid, lines, lag, spans, t0, t1, i, j, x0 + (j + 0.5) * c, y, r, thr):
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
