"""The area term of eq. 47 on raster sets, compiled (IB21 eqs. 44, 46, 49; the raster SM-MPC,
:mod:`swarmtrack.control.sm_mpc_raster`, whose docstring derives it): per footprint and row the intervals where its
term can raise v and where it empties a cell (:func:`_spans`), the base B on the window R with its row prefix sums of
``cell_area(B)`` (:func:`_base_window`), and per candidate what its terms remove from them (:func:`_removed_area`,
:func:`_areas`).

The kernels take the plan's footprints as one tuple ``feet = (lines, lag, spans, t0, t1)`` (edge lines, the rounds
after each footprint's step, the per-row intervals on the rows ``[t0, t1)``), the window R as ``window = (win, base,
prefix)`` and the grid as the array ``geo = [x0, y0, c, r, slack]`` (origin, cell side, dilation per round,
c/√2).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from swarmtrack.control.sm_mpc_raster_members import _g_row
from swarmtrack.estimation import raster as rs

DELTA = rs.DELTA


#: Margin (m) of the interval guesses on a footprint's depth: a cell within it of an interval's threshold is
#: evaluated exactly (round-off is ~1e-13 m at these coordinates).
EPS = 1e-7


@numba.njit(cache=True, inline="always")
def _term(lines, lag, f, x, y, r):
    """A footprint's term at (x, y): its depth (:func:`raster.depth`) − DELTA, lowered by r per later round."""
    d = np.inf
    for e in range(lines.shape[1]):
        v = (y - lines[f, e, 1]) * lines[f, e, 3] + (x - lines[f, e, 0]) * lines[f, e, 2]
        if v < d:
            d = v
    d = d - DELTA
    for _ in range(lag[f]):
        d = d - r
    return d


@numba.njit(cache=True, inline="always")
def _cell_area(v, c, slack):
    """:func:`raster.cell_area` of one value."""
    if v >= slack - DELTA:
        return 0.0
    if v <= 0.0:  # the formula gives exactly c² here
        return c * c
    r = min(max(v, 0.0), slack)
    a = c / 2
    if r <= a:  # the disc lies in the square (the segments' term is 0)
        return c * c - (math.pi * r ** 2 - 0.0)
    ra = max(r, a)
    seg = 4 * (ra ** 2 * math.acos(min(a / ra, 1.0)) - a * math.sqrt(max(ra ** 2 - a ** 2, 0.0)))
    return c * c - (math.pi * r ** 2 - seg)


@numba.njit(cache=True)
def _spans(lines, lag, geo, t0, t1, nx):
    """(F, t1 − t0, 4) per footprint and row: ``[ua, ub)`` a superset of the cells where its term is > 0 (it may
    raise v where v > 0) and ``[da, db)`` a subset of those where it is > c/√2 + 2·DELTA (the cell is empty); only
    the rows whose centres lie within the footprint's y-extent are visited (the others stay empty). The row at y
    meets each edge's half-plane ``(y − py)·ny + (x − px)·nx ≥ τ`` in a half-line of columns ``j ≥ k + τ·s`` (or
    ≤, as nx > 0 or < 0), so both intervals come from one pass; the thresholds are widened or narrowed by EPS for
    the round-off."""
    x0, y0, c, r, slack = geo[0], geo[1], geo[2], geo[3], geo[4]
    n_f, n_e = lines.shape[0], lines.shape[1]
    out = np.zeros((n_f, max(t1 - t0, 0), 4), dtype=np.int32)
    inv, k0 = np.empty(n_e), np.empty(n_e)
    for f in range(n_f):
        shift = DELTA + lag[f] * r
        tau_u, tau_d = shift - EPS, shift + slack + 2 * DELTA + EPS
        ymin, ymax = np.inf, -np.inf
        for e in range(n_e):
            ymin, ymax = min(ymin, lines[f, e, 1]), max(ymax, lines[f, e, 1])
            inv[e] = 1.0 / (lines[f, e, 2] * c) if lines[f, e, 2] != 0.0 else 0.0
            k0[e] = (lines[f, e, 0] - x0) / c - 0.5
        a0 = max(t0, int(math.floor((ymin - y0) / c - 0.5)))
        b0 = min(t1, int(math.ceil((ymax - y0) / c - 0.5)) + 1)
        for i in range(a0, b0):
            y = y0 + (i + 0.5) * c
            ulo, uhi, dlo, dhi = 0.0, nx - 1.0, 0.0, nx - 1.0
            for e in range(n_e):
                a = (y - lines[f, e, 1]) * lines[f, e, 3]
                if inv[e] != 0.0:
                    k = k0[e] - a * inv[e]
                    ju, jd = k + tau_u * inv[e], k + tau_d * inv[e]
                    if inv[e] > 0:
                        ulo, dlo = max(ulo, ju), max(dlo, jd)
                    else:
                        uhi, dhi = min(uhi, ju), min(dhi, jd)
                elif a < tau_u:
                    ulo, uhi = 1.0, 0.0
                elif a < tau_d:
                    dlo, dhi = 1.0, 0.0
            if ulo <= uhi:
                ua, ub = int(math.ceil(ulo)), int(math.floor(uhi)) + 1
                out[f, i - t0, 0], out[f, i - t0, 1] = ua, ub
                if dlo <= dhi:
                    da, db = max(int(math.ceil(dlo)), ua), min(int(math.floor(dhi)) + 1, ub)
                    out[f, i - t0, 2], out[f, i - t0, 3] = da, max(da, db)
    return out


@numba.njit(cache=True)
def _base_window(g, geo, win, feet, steady):
    """On R (the cells ``win``): ``B`` (v without the candidates' terms: G, :func:`_g_row`, raised by the ``steady``
    footprints of ``feet``) and the row prefix sums of ``cell_area(B)``. In a steady
    footprint's deep interval (:func:`_spans`: its term exceeds c/√2 + 2·DELTA, the cell is empty) ``B`` is set to
    ``+inf`` without evaluating the term: every use of B there (``cell_area(B) = 0``, not a member, no area left to
    remove) gives the same numbers."""
    x0, y0, c, r = geo[0], geo[1], geo[2], geo[3]
    lines, lag, spans, t0 = feet[0], feet[1], feet[2], feet[3]
    i0, j0, i1, j1 = win[0], win[1], win[2], win[3]
    slack = c / math.sqrt(2.0)
    base = np.empty((i1 - i0, j1 - j0))
    prefix = np.zeros((i1 - i0, j1 - j0 + 1))
    for i in range(i0, i1):
        _g_row(g, i, j0, j1, base[i - i0])
        y = y0 + (i + 0.5) * c
        for f in steady:
            a, b = max(spans[f, i - t0, 0], j0), min(spans[f, i - t0, 1], j1)
            da, db = max(spans[f, i - t0, 2], a), min(spans[f, i - t0, 3], b)
            if da >= db:
                da = db = b
            for j in range(a, da):
                t = _term(lines, lag, f, x0 + (j + 0.5) * c, y, r)
                if t > base[i - i0, j - j0]:
                    base[i - i0, j - j0] = t
            for j in range(da, db):
                base[i - i0, j - j0] = np.inf
            for j in range(db, b):
                t = _term(lines, lag, f, x0 + (j + 0.5) * c, y, r)
                if t > base[i - i0, j - j0]:
                    base[i - i0, j - j0] = t
        acc = 0.0
        for j in range(j0, j1):
            acc += _cell_area(base[i - i0, j - j0], c, slack)
            prefix[i - i0, j - j0 + 1] = acc
    return base, prefix


@numba.njit(cache=True, inline="always")
def _merge2(lo, hi):
    """:func:`_merge` of two intervals (the usual row: the UAV's own footprints at k+1 and k+2)."""
    a0, b0, a1, b1 = lo[0], hi[0], lo[1], hi[1]
    if a0 >= b0:
        lo[0], hi[0] = a1, b1
        return 1 if a1 < b1 else 0
    if a1 >= b1:
        return 1
    if a1 < a0:
        a0, b0, a1, b1 = a1, b1, a0, b0
    if a1 <= b0:
        lo[0], hi[0] = a0, max(b0, b1)
        return 1
    lo[0], hi[0], lo[1], hi[1] = a0, b0, a1, b1
    return 2


@numba.njit(cache=True)
def _merge(lo, hi, n):
    """Sort the intervals [lo[k], hi[k]) k < n by start and merge the overlapping ones in place; returns their
    number."""
    for a in range(1, n):
        x, y = lo[a], hi[a]
        b = a - 1
        while b >= 0 and lo[b] > x:
            lo[b + 1], hi[b + 1] = lo[b], hi[b]
            b -= 1
        lo[b + 1], hi[b + 1] = x, y
    m = 0
    for a in range(n):
        if lo[a] >= hi[a]:
            continue
        if m and lo[a] <= hi[m - 1]:
            if hi[a] > hi[m - 1]:
                hi[m - 1] = hi[a]
        else:
            lo[m], hi[m] = lo[a], hi[a]
            m += 1
    return m


@numba.njit(cache=True)
def _removed_area(ids, nid, feet, window, geo, room):
    """``Σ_R cell_area(B) − Σ_R cell_area(v_c)`` for the candidate whose terms are ``ids[:nid]`` (footprints of
    ``feet``), ``window`` R with B and its prefix sums: per row, the empty cells' share by prefix sums over the union
    of the deep intervals, and the band between it and the union of the liberal intervals cell by cell. ``room``:
    ``(ulo, uhi, dlo, dhi)``, space for a row's liberal and deep intervals (one per term)."""
    x0, y0, c, r, slack = geo[0], geo[1], geo[2], geo[3], geo[4]
    lines, lag, spans, t0 = feet[0], feet[1], feet[2], feet[3]
    win, base, prefix = window
    ulo, uhi, dlo, dhi = room
    i0, j0, i1, j1 = win[0], win[1], win[2], win[3]
    out = 0.0
    for i in range(i0, i1):
        n = 0
        for q in range(nid):
            f = ids[q]
            ua, ub = max(spans[f, i - t0, 0], j0), min(spans[f, i - t0, 1], j1)
            if ua < ub:
                ulo[n], uhi[n] = ua, ub
                dlo[n], dhi[n] = max(spans[f, i - t0, 2], j0), min(spans[f, i - t0, 3], j1)
                n += 1
        if n == 0:
            continue
        if n == 1:
            mu = md = 1
            if dlo[0] >= dhi[0]:
                md = 0
        elif n == 2:
            mu = _merge2(ulo, uhi)
            md = _merge2(dlo, dhi)
        else:
            mu = _merge(ulo, uhi, n)
            md = _merge(dlo, dhi, n)
        row = i - i0
        for q in range(md):
            out += prefix[row, dhi[q] - j0] - prefix[row, dlo[q] - j0]
        y = y0 + (i + 0.5) * c
        w = 0  # the merged deep intervals lie in the merged liberal ones, both sorted: walk the gaps
        for q in range(mu):
            j = ulo[q]
            while j < uhi[q]:
                while w < md and dhi[w] <= j:
                    w += 1
                if w < md and dlo[w] <= j:
                    j = dhi[w]
                    continue
                v = b0 = base[row, j - j0]
                a = _cell_area(b0, c, slack)
                if a > 0.0:
                    x = x0 + (j + 0.5) * c
                    for p in range(nid):
                        f = ids[p]
                        if spans[f, i - t0, 0] <= j < spans[f, i - t0, 1]:
                            t = _term(lines, lag, f, x, y, r)
                            if t > v:
                                v = t
                    if v > b0:
                        out += a - _cell_area(v, c, slack)
                j += 1
    return out


@numba.njit(cache=True)
def _candidate_ids(terms, cand, ids):
    """The footprint ids of a candidate's terms into ``ids``; returns their number."""
    nid = 0
    for q in range(terms.shape[1]):
        if terms[cand, q] >= 0:
            ids[nid] = terms[cand, q]
            nid += 1
    return nid


@numba.njit(cache=True)
def _areas(terms, feet, window, geo):
    """Per candidate (its footprints of ``feet`` in a row of ``terms``), the area over R: ``Σ_R cell_area(B)`` less
    what its terms remove (``window``: R, B on it and the row prefix sums of ``cell_area(B)``)."""
    prefix = window[2]
    n, width = terms.shape
    total = 0.0
    for row in range(prefix.shape[0]):
        total += prefix[row, prefix.shape[1] - 1]
    ids = np.empty(width, dtype=np.int64)
    room = (np.empty(width, dtype=np.int64), np.empty(width, dtype=np.int64), np.empty(width, dtype=np.int64),
            np.empty(width, dtype=np.int64))
    areas = np.empty(n)
    for cand in range(n):
        nid = _candidate_ids(terms, cand, ids)
        areas[cand] = total - _removed_area(ids, nid, feet, window, geo, room)
    return areas
