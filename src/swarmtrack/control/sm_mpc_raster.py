"""Set-membership MPC (IB21 Sec. 5, eqs. 44-49) on raster sets (:mod:`swarmtrack.estimation.raster`).

The same controller as :mod:`swarmtrack.control.sm_mpc` (read its docstring: eq. 47's cost, the candidates, the
prediction, eq. 48's neighbours, the baseline, the ties), with X^A held as a :class:`~swarmtrack.estimation.raster.
Field` v of distance lower bounds on a :class:`~swarmtrack.estimation.raster.Grid` of cells of side c. Per candidate
(the semantics, :func:`reference_costs`)::

    v ← values(X^A)
    for k = 1 … h:
        v ← v − V^t·T^c,  v ← max(v, outside)           eq. 44 (dilation, exact for a distance field; clip to X0)
        v ← max(v, depth(F_ℓ(x^P_{ℓ,k})) − DELTA)  for each neighbour ℓ kept by eq. 48      eq. 49
        v ← max(v, depth(F_i(x^P_{i,k})) − DELTA)                                          eq. 46
    φ = Σ_g cell_area(v(g)),   d = distance from p_{i,k+h} to the member squares (v ≤ c/√2 + DELTA)

(the baseline: no dilation, no clip, no neighbours, as :func:`sm_mpc.evolve`). ``d``: ``"nearest"`` the distance to
the nearest member cell's square (0 inside one), ``"hausdorff"`` to the farthest point of those squares; 0 when no
cell is a member. The member test is :func:`raster.members`' (the cells the estimator reports).

**Closed form.** Subtracting r and taking a max commute exactly in floating point (rounding is monotone), so after
the h rounds ``v_c(g) = max(B(g), T_c(g))`` with the candidate-independent base ``B = max(v0 − h·r, outside,
steady neighbour terms)`` and ``T_c`` the max of the candidate's own and varying-neighbour terms, each
``depth − DELTA`` lowered by r once per later round. A neighbour footprint is *steady* at step κ when eq. 48 keeps
it for every candidate, *varying* when for some only (one that none keeps is ignored).

**Window R** (the area term). Let R be the cells whose squares meet the bounding box of the varying footprints (the
UAV's own at k+1 … k+h for every candidate and the varying neighbours'). A cell outside R lies outside every term
of ``T_c``, so ``v_c = B`` there for every candidate: the area outside R is one constant. The area reported is
``Σ_{g ∈ R} cell_area(v_c(g))``, so **the costs equal the true costs (:func:`reference_costs` on the whole grid)
minus one constant, the same for every candidate**, and the pick is the same (tested). Unlike the polygon local
window, no margin is needed: the raster operations are pointwise, so nothing spreads between cells.

**The kernel** (:func:`kernel_costs`, numba) never evaluates R cell by cell per candidate. Every term is a convex
footprint, so per row of R the cells where it can raise v (``term > 0``, a liberal interval) and where it makes a
cell empty (``term ≥ c/√2 + 2·DELTA``, a conservative interval) are intervals, computed once per footprint and row
(:func:`_spans`, the row through the footprint's edge lines). Per candidate and row: the area of the empty cells is
a difference of row prefix sums of ``cell_area(B)``; only the cells between the two unions (a band about one cell
wide along the footprints' edges) are evaluated exactly. So a candidate costs O(rows + perimeter/c), not O(|R|).

**The distance** needs member cells outside R too: those of ``G = max(v0 − h·r, outside)`` (candidate-independent;
removals only raise v) not covered by a steady or candidate term. The nearest search visits rows in order of their
gap to p and stops at the best distance found; in each row it takes the nearest free member on either side of p,
jumping over non-members and covered intervals (cells in the intervals' margins are checked exactly), first within
R with next/previous member columns built once per plan from B, then beyond R with the lazy rows of the grid
(:class:`MemberRows`, built only for the rows a search reaches beyond R, kept per Field object and shared through
``shared`` between the UAVs of one fleet plan holding the same Field). p lies in its own last footprint, inside
R, so when X^A is near the UAV the search never leaves R; for a set far away it costs O(rows × terms). The Field's
bounds off its stored window come from :func:`raster.values` (on four strips about the window, once per Field),
so the kernel follows that function's definition rather than recomputing it. As :func:`sm_mpc.plan_one` does,
``prune`` computes the distance only for the candidates whose area term leaves them a chance: usually one, but all
25 when the UAV is far from every set (nothing in reach, every area tied). For that case, when G has at most
:data:`LISTED_MEMBERS` member cells (a few small sets), they are listed row by row once per Field and the nearest
search runs over the listed rows only (:func:`_nearest_listed`, the same distance: both paths are tested against the
reference, the listed one also against testing every listed cell); a row search of the grid from far away would
cross the whole box once per candidate. Both searches start from the previous candidate's nearest cell when the
candidate's terms leave it free (the candidates' ends lie close together) and skip blocks of :data:`ROW_BLOCK` rows
whose members' column extent cannot be nearer; the least distance is the same (tested against every free member).

**Cost** (ib21-like scenes, 6 UAVs, 1 m cells; see the timing helper in ``tests/control/test_sm_mpc_raster.py``):
≈ 0.2 ms for all 25 candidates' areas, ≈ 0.05 ms for the distance, the rest :func:`sm_mpc.removals` (corners
only) and :func:`scene` (≈ 0.03 ms each) and Python glue; one compiled call per plan (:func:`_plan_costs`). Over a
400 s ib21-fleet-6 mission ≈ 1.0 ms per UAV and plan on average on a loaded 2-core machine, where the code before
these kernels' speed-ups took 1.4-1.5 ms (``benchmarks/bench_setmembership.py --sets raster``, "SM-MPC per UAV and
plan", which also counts predicting the fleet's states and footprints once per plan).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from swarmtrack.control import sm_mpc_problem as smp
from swarmtrack.control.sm_mpc_problem import DEFAULT_SETTINGS, SMMPCSettings
from swarmtrack.estimation import raster as rs

#: Margin (m) of the interval guesses on a footprint's depth: a cell within it of an interval's threshold is
#: evaluated exactly (round-off is ~1e-13 m at these coordinates).
EPS = 1e-7
DELTA = rs.DELTA


# --- the readable reference ----------------------------------------------------------------------------------------


def reference_costs(grid: rs.Grid, region: rs.Field, rem: smp.Removals, xy: np.ndarray, s: SMMPCSettings,
                    window: tuple[int, int, int, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Area and distance terms (C,) of eq. 47 by the rounds of eqs. 44, 46, 48-49 literally (module docstring), on
    the cells ``window`` (default: the whole grid, the true costs): ``rem`` from :func:`sm_mpc.removals`, ``xy``
    (C, 2) the predicted positions at k+h. The distance only sees member cells inside the window."""
    h, branch, c = s.horizon, len(s.inputs), grid.cell
    i0, j0, i1, j1 = (0, 0, grid.ny, grid.nx) if window is None else window
    n = len(rem.corners[-1])
    if region is None or region.is_empty:
        return np.zeros(n), np.zeros(n)
    v0 = rs.values(grid, region, (i0, j0, i1, j1))
    out = None if s.baseline or grid.outside is None else grid.outside[i0:i1, j0:j1]
    r = s.target_speed * s.period
    xl = grid.x0 + np.arange(j0, j1) * c
    yl = grid.y0 + np.arange(i0, i1) * c
    areas, dist = np.zeros(n), np.zeros(n)
    for cand in range(n):
        v = v0.copy()
        for k in range(h):
            node = cand // branch ** (h - 1 - k)
            if not s.baseline:
                v = v - r
                if out is not None:
                    v = np.maximum(v, out)
            for ell in np.flatnonzero(rem.kept[k][node]):
                v = np.maximum(v, rs.depth(grid, rem.nb_corners[ell, k], (i0, j0, i1, j1)) - DELTA)
            v = np.maximum(v, rs.depth(grid, rem.corners[k][node], (i0, j0, i1, j1)) - DELTA)
        areas[cand] = rs.cell_area(v, c).sum()
        ii, jj = np.nonzero(v <= grid.slack + DELTA)
        if len(ii):
            d = _square_distance(xy[cand], xl[jj], yl[ii], c, s.distance)
            dist[cand] = d.min() if s.distance == "nearest" else d.max()
    return areas, dist


def _square_distance(p, xl, yl, c, kind):
    """Distance from p to the squares with lower-left corners (xl, yl): nearest point or farthest corner."""
    xr, yr = xl + c, yl + c
    if kind == "nearest":
        dx = np.maximum(np.maximum(xl - p[0], p[0] - xr), 0.0)
        dy = np.maximum(np.maximum(yl - p[1], p[1] - yr), 0.0)
    else:
        dx = np.maximum(np.abs(xl - p[0]), np.abs(xr - p[0]))
        dy = np.maximum(np.abs(yl - p[1]), np.abs(yr - p[1]))
    return np.hypot(dx, dy)


# --- what one plan removes, as terms ------------------------------------------------------------------------------


@dataclass
class Scene:
    """One plan's footprints as terms: ``lines`` (F, 4, 4) each footprint's edge lines ``(px, py, nx, ny)`` (a point
    and the inward unit normal, :func:`raster.depth`'s), ``lag`` (F,) the rounds after its step (its term is
    lowered by r that many times), ``terms`` (C, T) the footprints of each candidate (own and varying neighbours',
    −1 padded), ``steady`` (S,) those removed for every candidate, ``window`` R in cells ``(i0, j0, i1, j1)``,
    ``rows`` the rows ``[t0, t1)`` of the per-row intervals (R's and the steady footprints')."""

    lines: np.ndarray
    lag: np.ndarray
    terms: np.ndarray
    steady: np.ndarray
    window: tuple[int, int, int, int]
    rows: tuple[int, int]


def edge_lines(corners: np.ndarray) -> np.ndarray:
    """(F, K, 4) ``(px, py, nx, ny)`` of convex polygons ``corners`` (F, K, 2), inward normals, computed with
    :func:`raster.depth`'s arithmetic (so the depths agree bit for bit)."""
    return _edge_lines(np.ascontiguousarray(corners, dtype=float))


@numba.njit(cache=True)
def _edge_lines(c):
    f, k = c.shape[0], c.shape[1]
    out = np.empty((f, k, 4))
    for q in range(f):
        area = 0.0
        for e in range(k):
            n = (e + 1) % k
            area += c[q, e, 0] * c[q, n, 1] - c[q, n, 0] * c[q, e, 1]
        turn = np.sign(area)
        for e in range(k):
            n = (e + 1) % k
            ex, ey = c[q, n, 0] - c[q, e, 0], c[q, n, 1] - c[q, e, 1]
            norm = math.hypot(ex, ey)
            out[q, e, 0], out[q, e, 1] = c[q, e, 0], c[q, e, 1]
            out[q, e, 2], out[q, e, 3] = turn * -ey / norm, turn * ex / norm
    return out


def scene(grid: rs.Grid, rem: smp.Removals, s: SMMPCSettings) -> Scene:
    """The terms of one plan (eqs. 46, 48-49): the UAV's own footprint at each step for the node of each
    candidate, and each neighbour footprint eq. 48 keeps at step κ, steady or varying (module docstring)."""
    own = np.concatenate(rem.corners)
    kept = np.concatenate(rem.kept) if rem.nb_corners.shape[0] else np.zeros((len(own), 0), dtype=bool)
    lines, lag, terms, steady, box = _assemble(own, np.array([len(c) for c in rem.corners], dtype=np.int64),
                                                kept, np.ascontiguousarray(rem.nb_corners, dtype=float),
                                                len(s.inputs))
    i0, i1 = grid.span(box[1], box[3], 0)
    j0, j1 = grid.span(box[0], box[2], 1)
    t0, t1 = i0, i1
    if len(steady):
        a, b = grid.span(box[4], box[5], 0)
        t0, t1 = (a, b) if t0 >= t1 else (min(t0, a), max(t1, b))
    return Scene(lines, lag, terms, steady, (i0, j0, i1, j1), (t0, t1))


@numba.njit(cache=True)
def _assemble(own, sizes, kept, nb, branch):
    """:func:`scene`'s tables from the own corners of every level ``own`` (Σ n_κ, 4, 2) (``sizes`` n_κ), eq. 48's
    ``kept`` (Σ n_κ, L) and the neighbours' corners ``nb`` (L, h, 4, 2); ``box``: the varying footprints' bounding
    box and the steady ones' y-extent."""
    h, n_nb = len(sizes), kept.shape[1]
    n = sizes[h - 1]
    offs = np.zeros(h + 1, dtype=np.int64)
    for k in range(h):
        offs[k + 1] = offs[k] + sizes[k]
    kind = np.zeros((h, n_nb), dtype=np.int64)  # 0 ignored, 1 steady, 2 varying
    n_st = n_var = 0
    for k in range(h):
        for ell in range(n_nb):
            some, every = False, True
            for q in range(offs[k], offs[k + 1]):
                some = some or kept[q, ell]
                every = every and kept[q, ell]
            if every and sizes[k]:
                kind[k, ell] = 1
                n_st += 1
            elif some:
                kind[k, ell] = 2
                n_var += 1
    total = offs[h] + n_st + n_var
    corners = np.empty((total, 4, 2))
    corners[:offs[h]] = own
    lag = np.empty(total, dtype=np.int64)
    terms = np.full((n, h + n_var), -1, dtype=np.int64)
    steady = np.empty(n_st, dtype=np.int64)
    box = np.array([np.inf, np.inf, -np.inf, -np.inf, np.inf, -np.inf])
    for k in range(h):
        stride = branch ** (h - 1 - k)
        lag[offs[k]:offs[k + 1]] = h - 1 - k
        for cand in range(n):
            terms[cand, k] = offs[k] + cand // stride
    fid, col, st = offs[h], h, 0
    for k in range(h):
        stride = branch ** (h - 1 - k)
        for ell in range(n_nb):
            if kind[k, ell] == 0:
                continue
            corners[fid] = nb[ell, k]
            lag[fid] = h - 1 - k
            if kind[k, ell] == 1:
                steady[st] = fid
                st += 1
            else:
                for cand in range(n):
                    if kept[offs[k] + cand // stride, ell]:
                        terms[cand, col] = fid
                col += 1
            fid += 1
    for q in range(total):
        varying = q < offs[h] or not _is_steady(q, steady)
        for e in range(4):
            x, y = corners[q, e, 0], corners[q, e, 1]
            if varying:
                box[0], box[1], box[2], box[3] = min(box[0], x), min(box[1], y), max(box[2], x), max(box[3], y)
            else:
                box[4], box[5] = min(box[4], y), max(box[5], y)
    return _edge_lines(corners), lag, terms, steady, box


@numba.njit(cache=True)
def _is_steady(q, steady):
    for s in steady:
        if s == q:
            return True
    return False


# --- the G-members per row, lazily ------------------------------------------------------------------------------


@dataclass
class MemberRows:
    """The Field's values where members of a candidate's set can be, and per row of the grid the columns of the
    cells of ``G = max(v0 − h·r, outside)`` that are members (the only cells that can be members of a candidate's
    set: removals only raise v): ``nxt[i, j]`` the first member column ≥ j (nx if none), ``prv[i, j]`` the last ≤ j
    (−1), ``has[i]``; filled by the kernel row by row as the searches reach them (``ready[i]``).

    Members lie in the *box*, the Field's window grown by the reach of the h dilations (off its window, the Field's
    bound is at least the distance to the window's rectangle). ``src`` holds the Field's stored values and
    :func:`raster.values` on the four strips of the box about them (so the kernel asks the raster module for the
    bounds off the window rather than recomputing them), ``fw`` the window and the box ``(i0, j0, i1, j1)`` × 2."""

    field: rs.Field
    src: tuple
    fw: np.ndarray
    nxt: np.ndarray
    prv: np.ndarray
    ready: np.ndarray
    has: np.ndarray
    #: per block of ROW_BLOCK grid rows, the least and greatest member column (``bmin > bmax``: none), filled with
    #: its rows when a search first reaches it (``bready``; :func:`_ensure_block`)
    bmin: np.ndarray | None = None
    bmax: np.ndarray | None = None
    bready: np.ndarray | None = None
    members: tuple | None = None  # (rows, starts, columns, complete) of G's members, if few (:func:`_member_list`)
    blocks: tuple | None = None  # the listed rows' column extents per block of ROW_BLOCK (:func:`_listed_blocks`)


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
    blocks = (grid.ny + ROW_BLOCK - 1) // ROW_BLOCK
    rows = MemberRows(region, src, fw, np.empty((grid.ny, grid.nx), dtype=np.int32),
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


# --- the plan ------------------------------------------------------------------------------------------------------


def plan_one_raster(grid: rs.Grid, region: rs.Field | None, own_states: np.ndarray, nb_states: np.ndarray,
                    s: SMMPCSettings = DEFAULT_SETTINGS, shared: dict | None = None, prune: bool = True,
                    corners: tuple[np.ndarray, np.ndarray | None] | None = None) -> smp.Choice:
    """Eq. 47 minimised over U_d^h for one UAV whose X^A is the raster ``region`` (a :class:`raster.Field` on
    ``grid``; None or empty: every cost 0, index 0), ``own_states`` (C, h, 7) and ``nb_states`` (L, h, 7) as
    :func:`sm_mpc.plan_one`. ``cost`` and ``area`` are over the window R (the true ones less one constant for all
    candidates, module docstring); ``window`` is R as ``(x0, y0, x1, y1)``. ``prune`` (as :func:`sm_mpc.plan_one`):
    the distance only for the candidates whose area term leaves them a chance, the others' cost ``inf``.
    ``shared``: a dict kept across the UAVs of one fleet plan (:func:`member_rows`); ``corners``: the footprints'
    corners of both kinds of states, if known (:func:`sm_mpc.removals`)."""
    cands = smp._candidates(tuple(s.inputs), s.horizon)  # the cached table, read only
    if region is None or region.is_empty:
        zero = np.zeros(len(cands))
        return smp.Choice(0, cands[0].copy(), zero, zero.copy(), zero.copy())
    rem = smp.removals(own_states, nb_states, s, neighbours=not s.baseline, polygons=False, corners=corners)
    k = RasterKernel(grid, region, scene(grid, rem, s), rem.xy[-1], s, member_rows(grid, region, s, shared))
    areas, dist, cost, index = k.plan(prune)
    i0, j0, i1, j1 = k.sc.window
    c = grid.cell
    window = (grid.x0 + j0 * c, grid.y0 + i0 * c, grid.x0 + j1 * c, grid.y0 + i1 * c)
    return smp.Choice(index, cands[index].copy(), cost, areas, dist, 0, window)


#: At most this many member cells of G: the nearest distance searches them listed (:meth:`RasterKernel.distances`).
LISTED_MEMBERS = 20_000
#: Listed member rows per block of :func:`_listed_blocks` (the listed search skips a block that cannot be nearer).
ROW_BLOCK = 8


class RasterKernel:
    """One plan's compiled costs (module docstring): :meth:`areas` over R for every candidate, :meth:`distances` for
    some; equal to :func:`reference_costs` (area on ``sc.window``, distance on the whole grid) up to the order of
    the sums."""

    def __init__(self, grid: rs.Grid, region: rs.Field, sc: Scene, xy: np.ndarray, s: SMMPCSettings,
                 rows: MemberRows | None = None):
        self.grid, self.region, self.sc, self.s = grid, region, sc, s
        self.xy = np.ascontiguousarray(xy, dtype=float)
        self.rows = member_rows(grid, region, s) if rows is None else rows
        self.clip = not s.baseline and grid.outside is not None
        self.outside = grid.outside if self.clip else np.zeros((1, 1))
        self.geo = np.array([grid.x0, grid.y0, grid.cell, 0.0 if s.baseline else s.target_speed * s.period])
        self.win = np.array(sc.window, dtype=np.int64)
        self._spans = self._base = self._members = None

    @property
    def spans(self) -> np.ndarray:
        """:func:`_spans` of the scene's footprints (once per plan)."""
        if self._spans is None:
            sc = self.sc
            self._spans = _spans(sc.lines, sc.lag, self.geo, sc.rows[0], sc.rows[1], self.grid.nx, self.grid.slack)
        return self._spans

    def _listed(self, listed: int = LISTED_MEMBERS) -> bool:
        """Whether the nearest distance searches the listed member cells of G (at most ``listed`` of them; the list
        and its blocks are made once per Field)."""
        m = self.rows
        if self.s.distance != "nearest":
            return False
        if m.members is None:
            m.members = _member_list(m.src, m.fw, self.s.horizon, self.geo[3], self.outside, self.clip,
                                     self.grid.slack + DELTA, m.ready, m.has, listed)
        if m.members[3] and m.blocks is None:
            m.blocks = _listed_blocks(m.members[1], m.members[2], ROW_BLOCK)
        return bool(m.members[3])

    def plan(self, prune: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """Areas, distances (inf where not computed), costs (eq. 47) and the pick in one compiled call
        (:func:`_plan_costs`): the steps of :meth:`areas`, :meth:`distances` and :func:`sm_mpc.choose` that
        :func:`plan_one_raster` describes, with the same numbers (``prune``: the distance only for the candidates
        that can still win)."""
        sc, m, s = self.sc, self.rows, self.s
        listed = self._listed()
        lists = (*m.members[:3], *m.blocks) if listed else _NO_LIST
        self._spans, base, prefix, areas, dist, cost, index = _plan_costs(
            sc.lines, sc.lag, sc.terms, sc.steady, sc.rows[0], sc.rows[1], self.win, self.geo, self.grid.slack,
            self.grid.nx, m.src, m.fw, s.horizon, self.outside, self.clip, self.xy, s.alpha, prune,
            s.distance == "hausdorff", listed, *lists, m.nxt, m.prv, m.ready, m.has, m.bmin, m.bmax, m.bready)
        self._base = (base, prefix)
        return areas, dist, cost, int(index)

    def base(self) -> tuple[np.ndarray, np.ndarray]:
        """On R: B (v without the candidates' terms) and the row prefix sums of cell_area(B) (once per plan)."""
        if self._base is None:
            sc, m = self.sc, self.rows
            self._base = _base_window(m.src, m.fw, self.geo, self.s.horizon, self.outside, self.clip, self.win,
                                      sc.lines, sc.lag, sc.steady, self.spans, sc.rows[0])
        return self._base

    def areas(self) -> np.ndarray:
        """Σ_R cell_area(v_c) (C,)."""
        sc = self.sc
        return _areas(sc.terms, sc.lines, sc.lag, self.spans, sc.rows[0], *self.base(), self.win, self.geo,
                      self.grid.slack)

    def distances(self, which: np.ndarray, listed: int = LISTED_MEMBERS) -> np.ndarray:
        """d of eq. 47 for the candidates ``which``: for the nearest distance to at most ``listed`` member cells
        of G, by a search over their list (:func:`_nearest_listed`; far from a few small sets, where every candidate
        ties on area and all 25 need a distance, each row search of the grid would cross the whole box), else by
        the row search."""
        sc, m = self.sc, self.rows
        if self._listed(listed):
            return _nearest_listed(np.asarray(which, dtype=np.int64), sc.terms, sc.steady, sc.lines, sc.lag,
                                   self.spans, sc.rows[0], sc.rows[1], self.geo, self.grid.slack, self.xy,
                                   *m.members[:3], *m.blocks)
        if self._members is None:
            self._members = _range_members(self.base()[0], self.grid.slack + DELTA, self.sc.window[1])
        return _distances(np.asarray(which, dtype=np.int64), sc.terms, sc.steady, sc.lines, sc.lag, self.spans,
                          sc.rows[0], sc.rows[1], self.geo, self.grid.slack, self.xy, self.s.distance == "hausdorff",
                          m.src, m.fw, self.s.horizon, self.outside, self.clip, m.nxt, m.prv, m.ready, m.has,
                          m.bmin, m.bmax, m.bready, self.win, *self._members)


_WARM: list[bool] = []  # set once this process has run :func:`warm`


def warm() -> None:
    """Load (or, on a new checkout, compile) this module's kernels once per process, so that the plan times a run
    measures (the ``solve_time`` probe, IB21 Fig. 11 right) are the planner's and not numba's: one plan against two
    small sets (the nearest distance over the listed member cells) and one against all of X0 (the row search).
    Without it the first plan of a study's worker took up to 37 s on a new checkout, 0.1-2 s otherwise."""
    if _WARM:
        return
    import shapely

    s = DEFAULT_SETTINGS
    grid = rs.Grid.over(shapely.box(0, 0, 400, 400), 1.0)
    nav = np.array([[200.0, 100.0, 100.0, 0.0, 0.0, 0.0, 0.0]])
    own = smp.predict(nav[:, None, :], smp.candidates(s.inputs, s.horizon)[None], s)[0]
    small = rs.union(grid, [rs.box(grid, (x, x, x + 10, x + 10)) for x in (20.0, 300.0)])
    for region in (small, rs.full(grid)):
        plan_one_raster(grid, region, own, np.zeros((0, s.horizon, 7)), s)
    _WARM.append(True)


def kernel_costs(grid: rs.Grid, region: rs.Field, sc: Scene, xy: np.ndarray, s: SMMPCSettings,
                 rows: MemberRows | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Area over R and distance terms (C,) of every candidate by the compiled kernel (:class:`RasterKernel`)."""
    k = RasterKernel(grid, region, sc, xy, s, rows)
    return k.areas(), k.distances(np.arange(len(sc.terms)))


# --- numba kernels -----------------------------------------------------------------------------------------------


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


@numba.njit(cache=True)
def _g_row(src, fw, i, j0, j1, h, r, outside, clip, out):
    """``G`` on cells (i, j0 … j1−1) into ``out[:j1 − j0]``: the Field's values after h rounds of eq. 44 without
    removals. ``src`` (stored values, top, bottom, left and right strips of :func:`raster.values` about them) and
    ``fw`` (stored window, box) as :class:`MemberRows`; ``+inf`` off the box (no member there)."""
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
def _spans(lines, lag, geo, t0, t1, nx, slack):
    """(F, t1 − t0, 4) per footprint and row: ``[ua, ub)`` a superset of the cells where its term is > 0 (it may
    raise v where v > 0) and ``[da, db)`` a subset of those where it is > c/√2 + 2·DELTA (the cell is empty); only
    the rows whose centres lie within the footprint's y-extent are visited (the others stay empty). The row at y
    meets each edge's half-plane ``(y − py)·ny + (x − px)·nx ≥ τ`` in a half-line of columns ``j ≥ k + τ·s`` (or
    ≤, as nx > 0 or < 0), so both intervals come from one pass; the thresholds are widened or narrowed by EPS for
    the round-off."""
    x0, y0, c, r = geo[0], geo[1], geo[2], geo[3]
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
def _base_window(src, fw, geo, h, outside, clip, win, lines, lag, steady, spans, t0):
    """On R: ``B`` (v without the candidates' terms) and the row prefix sums of ``cell_area(B)``. In a steady
    footprint's deep interval (:func:`_spans`: its term exceeds c/√2 + 2·DELTA, the cell is empty) ``B`` is set to
    ``+inf`` without evaluating the term: every use of B there (``cell_area(B) = 0``, not a member, no area left to
    remove) gives the same numbers."""
    x0, y0, c, r = geo[0], geo[1], geo[2], geo[3]
    i0, j0, i1, j1 = win[0], win[1], win[2], win[3]
    slack = c / math.sqrt(2.0)
    base = np.empty((i1 - i0, j1 - j0))
    prefix = np.zeros((i1 - i0, j1 - j0 + 1))
    for i in range(i0, i1):
        _g_row(src, fw, i, j0, j1, h, r, outside, clip, base[i - i0])
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
def _removed_area(ids, nid, lines, lag, spans, t0, base, prefix, win, geo, slack, ulo, uhi, dlo, dhi):
    """``Σ_R cell_area(B) − Σ_R cell_area(v_c)`` for the candidate whose terms are ``ids[:nid]``: per row, the empty
    cells' share by prefix sums over the union of the deep intervals, and the band between it and the union of
    the liberal intervals cell by cell."""
    x0, y0, c, r = geo[0], geo[1], geo[2], geo[3]
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
def _member_list(src, fw, h, r, outside, clip, thr, ready, has, most):
    """The cells where G is a member, row by row: the rows holding some (ascending), ``starts`` (one more) where
    each row's columns begin in ``cols`` (ascending within a row), and True; or empty arrays and False if there are
    more than ``most``. Rows marked ready without a member (:func:`_rows_without_members`) are not evaluated."""
    rows, starts = np.empty(fw[6] - fw[4], dtype=np.int64), np.zeros(fw[6] - fw[4] + 1, dtype=np.int64)
    cols = np.empty(most, dtype=np.int64)
    n = nr = 0
    width = fw[7] - fw[5]
    g = np.empty(max(width, 0))
    for i in range(fw[4], fw[6]):
        if ready[i] and not has[i]:
            continue
        _g_row(src, fw, i, fw[5], fw[7], h, r, outside, clip, g)
        for j in range(width):
            if g[j] <= thr:
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


@numba.njit(cache=True)
def _ensure_block(blk, src, fw, h, r, outside, clip, thr, nxt, prv, ready, has, bmin, bmax, bready):
    """Fill the rows of block ``blk`` (ROW_BLOCK grid rows) of the G-member columns (:func:`_ensure_row`) and its
    members' column extent (``bmin > bmax`` when it has none)."""
    ny, nx = nxt.shape
    lo, hi = nx, -1
    for i in range(blk * ROW_BLOCK, min((blk + 1) * ROW_BLOCK, ny)):
        _ensure_row(i, src, fw, h, r, outside, clip, thr, nxt, prv, ready, has)
        if has[i]:
            lo, hi = min(lo, nxt[i, 0]), max(hi, prv[i, nx - 1])
    bmin[blk], bmax[blk] = lo, hi
    bready[blk] = 1


@numba.njit(cache=True)
def _ensure_row(i, src, fw, h, r, outside, clip, thr, nxt, prv, ready, has):
    """Fill row i of the G-member columns (:class:`MemberRows`) if not done yet."""
    if ready[i]:
        return
    nx = nxt.shape[1]
    last = -1
    b0, b1 = (fw[5], fw[7]) if fw[4] <= i < fw[6] else (nx, nx)
    for j in range(b0):
        prv[i, j] = -1
    if b0 < b1:
        g = np.empty(b1 - b0)
        _g_row(src, fw, i, b0, b1, h, r, outside, clip, g)
        for j in range(b0, b1):
            if g[j - b0] <= thr:
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
def _candidate_ids(terms, cand, ids):
    """The footprint ids of a candidate's terms into ``ids``; returns their number."""
    nid = 0
    for q in range(terms.shape[1]):
        if terms[cand, q] >= 0:
            ids[nid] = terms[cand, q]
            nid += 1
    return nid


@numba.njit(cache=True)
def _terms_of(terms, steady, cand, ids):
    """The footprint ids of a candidate's terms and the steady ones into ``ids``; returns their number."""
    nid = _candidate_ids(terms, cand, ids)
    for p in range(len(steady)):
        ids[nid + p] = steady[p]
    return nid + len(steady)


@numba.njit(cache=True)
def _areas(terms, lines, lag, spans, t0, base, prefix, win, geo, slack):
    """Per candidate, the area over R: ``Σ_R cell_area(B)`` less what its terms remove."""
    n, width = terms.shape
    total = 0.0
    for row in range(prefix.shape[0]):
        total += prefix[row, prefix.shape[1] - 1]
    ids = np.empty(width, dtype=np.int64)
    ulo, uhi = np.empty(width, dtype=np.int64), np.empty(width, dtype=np.int64)
    dlo, dhi = np.empty(width, dtype=np.int64), np.empty(width, dtype=np.int64)
    areas = np.empty(n)
    for cand in range(n):
        nid = _candidate_ids(terms, cand, ids)
        areas[cand] = total - _removed_area(ids, nid, lines, lag, spans, t0, base, prefix, win, geo, slack,
                                            ulo, uhi, dlo, dhi)
    return areas


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


#: Placeholders for the member list and its blocks when the nearest search does not use them.
_NO_LIST = (np.zeros(0, dtype=np.int64), np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64),
            np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))


@numba.njit(cache=True)
def _choose(cost):
    """:func:`sm_mpc.choose` with its default tolerances: the first candidate within round-off of the minimum."""
    best = cost.min()
    near = best + 1e-9 + 1e-12 * abs(best)
    for q in range(len(cost)):
        if cost[q] <= near:
            return q
    return -1


@numba.njit(cache=True)
def _some_distances(which, terms, steady, lines, lag, spans, t0, t1, geo, slack, xy, hausdorff, listed, rows,
                    starts, cols, blo, bhi, src, fw, h, outside, clip, nxt, prv, ready, has, bmin, bmax, bready, win,
                    wnxt, wprv):
    """:meth:`RasterKernel.distances` for the candidates ``which`` on the path :meth:`RasterKernel._listed` chose."""
    if listed:
        return _nearest_listed(which, terms, steady, lines, lag, spans, t0, t1, geo, slack, xy, rows, starts, cols,
                               blo, bhi)
    return _distances(which, terms, steady, lines, lag, spans, t0, t1, geo, slack, xy, hausdorff, src, fw, h,
                      outside, clip, nxt, prv, ready, has, bmin, bmax, bready, win, wnxt, wprv)


@numba.njit(cache=True)
def _plan_costs(lines, lag, terms, steady, t0, t1, win, geo, slack, nx, src, fw, h, outside, clip, xy, alpha, prune,
                hausdorff, listed, rows, starts, cols, blo, bhi, nxt, prv, ready, has, bmin, bmax, bready):
    """One plan of :func:`plan_one_raster` in one call: the spans, B and its prefix sums, every candidate's area
    over R, then eq. 47's distance for the first candidate of least area and for those its cost leaves a chance
    (``prune``; else for all), the costs and the pick (:func:`_choose`). Returns the spans, B, the prefix sums, the
    areas, the distances (inf where not computed), the costs and the index."""
    spans = _spans(lines, lag, geo, t0, t1, nx, slack)
    base, prefix = _base_window(src, fw, geo, h, outside, clip, win, lines, lag, steady, spans, t0)
    areas = _areas(terms, lines, lag, spans, t0, base, prefix, win, geo, slack)
    n = len(areas)
    if listed:
        wnxt, wprv = np.zeros((0, 0), dtype=np.int32), np.zeros((0, 0), dtype=np.int32)
    else:
        wnxt, wprv = _range_members(base, slack + DELTA, win[1])
    dist = np.full(n, np.inf)
    need = np.ones(n, dtype=np.bool_)
    if prune:
        first = _choose(areas)
        one = np.full(1, first, dtype=np.int64)
        dist[first] = _some_distances(one, terms, steady, lines, lag, spans, t0, t1, geo, slack, xy, hausdorff,
                                      listed, rows, starts, cols, blo, bhi, src, fw, h, outside, clip, nxt, prv,
                                      ready, has, bmin, bmax, bready, win, wnxt, wprv)[0]
        bound = areas[first] + alpha * dist[first]
        for q in range(n):
            need[q] = areas[q] <= bound + 1e-9 + 1e-12 * abs(bound)
        need[first] = False
    which = np.flatnonzero(need)
    if len(which):
        got = _some_distances(which, terms, steady, lines, lag, spans, t0, t1, geo, slack, xy, hausdorff, listed,
                              rows, starts, cols, blo, bhi, src, fw, h, outside, clip, nxt, prv, ready, has, bmin,
                              bmax, bready, win, wnxt, wprv)
        for q in range(len(which)):
            dist[which[q]] = got[q]
    cost = np.empty(n)
    for q in range(n):
        cost[q] = areas[q] + alpha * dist[q]
    return spans, base, prefix, areas, dist, cost, _choose(cost)
