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

**Modules.** This one holds the reference, the planner (:func:`plan_one_raster`, :class:`RasterKernel`) and the
plan kernel (:func:`_plan_costs`); the terms are built in :mod:`~swarmtrack.control.sm_mpc_raster_scene`, G's
members kept in :mod:`~swarmtrack.control.sm_mpc_raster_members`, the area term computed in
:mod:`~swarmtrack.control.sm_mpc_raster_areas` and the distance term in :mod:`~swarmtrack.control.sm_mpc_raster_search`
(their docstrings name the tuples the kernels take their inputs in: a few arrays that describe one thing, ``g``,
``lazy``, ``feet``, ``cover``, …). The problem shared with the polygon planner comes from
:mod:`~swarmtrack.control.sm_mpc_problem`. numba's cache does not notice an edit to a kernel in another module
than its caller's: after changing one of these modules, delete their ``__pycache__/sm_mpc_raster*.nb[ic]`` files.
"""

from __future__ import annotations

import numba
import numpy as np

from swarmtrack.control import sm_mpc_problem as smp
from swarmtrack.control.sm_mpc_problem import DEFAULT_SETTINGS, SMMPCSettings
from swarmtrack.control.sm_mpc_raster_areas import _areas, _base_window, _spans
from swarmtrack.control.sm_mpc_raster_members import (
    ROW_BLOCK,
    MemberRows,
    _listed_blocks,
    _member_list,
    _range_members,
    listed_blocks_reference,
    member_rows,
)
from swarmtrack.control.sm_mpc_raster_scene import Scene, edge_lines, scene
from swarmtrack.control.sm_mpc_raster_search import _distances, _nearest_listed
from swarmtrack.estimation import raster as rs

#: Re-exported: importable from here as before the kernels moved to their modules.
__all__ = ["DELTA", "LISTED_MEMBERS", "ROW_BLOCK", "MemberRows", "RasterKernel", "Scene", "edge_lines",
           "kernel_costs", "listed_blocks_reference", "member_rows", "plan_one_raster", "reference_costs", "scene",
           "warm"]

DELTA = rs.DELTA


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


class RasterKernel:
    """One plan's compiled costs (module docstring): :meth:`areas` over R for every candidate, :meth:`distances` for
    some; equal to :func:`reference_costs` (area on ``sc.window``, distance on the whole grid) up to the order of
    the sums."""

    def __init__(self, grid: rs.Grid, region: rs.Field, sc: Scene, xy: np.ndarray, s: SMMPCSettings,
                 rows: MemberRows | None = None):
        self.grid, self.region, self.sc, self.s = grid, region, sc, s
        self.xy = np.ascontiguousarray(xy, dtype=float)
        self.rows = member_rows(grid, region, s) if rows is None else rows
        #: the grid as the kernels take it: origin, cell side, dilation per round of eq. 44, c/√2
        self.geo = np.array([grid.x0, grid.y0, grid.cell, 0.0 if s.baseline else s.target_speed * s.period,
                             grid.slack])
        self.win = np.array(sc.window, dtype=np.int64)
        self._spans = self._base = self._members = None

    @property
    def spans(self) -> np.ndarray:
        """:func:`_spans` of the scene's footprints (once per plan)."""
        if self._spans is None:
            sc = self.sc
            self._spans = _spans(sc.lines, sc.lag, self.geo, sc.rows[0], sc.rows[1], self.grid.nx)
        return self._spans

    @property
    def feet(self) -> tuple:
        """The scene's footprints as the kernels take them, ``(lines, lag, spans, t0, t1)``."""
        sc = self.sc
        return sc.lines, sc.lag, self.spans, sc.rows[0], sc.rows[1]

    @property
    def cands(self) -> tuple:
        """The candidates as the distance kernels take them: their terms, the steady ones and their ends p."""
        return self.sc.terms, self.sc.steady, self.xy

    def _listed(self, listed: int = LISTED_MEMBERS) -> bool:
        """Whether the nearest distance searches the listed member cells of G (at most ``listed`` of them; the list
        and its blocks are made once per Field)."""
        m = self.rows
        if self.s.distance != "nearest":
            return False
        if m.members is None:
            m.members = _member_list(m.g, m.ready, m.has, listed)
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
        members = (m.g, m.lazy, listed, (*m.members[:3], *m.blocks) if listed else _NO_LIST)
        self._spans, base, prefix, areas, dist, cost, index = _plan_costs(
            (sc.lines, sc.lag, sc.terms, sc.steady, sc.rows[0], sc.rows[1], self.win), self.xy, self.geo, members,
            (s.alpha, prune, s.distance == "hausdorff"))
        self._base = (base, prefix)
        return areas, dist, cost, int(index)

    def base(self) -> tuple[np.ndarray, np.ndarray]:
        """On R: B (v without the candidates' terms) and the row prefix sums of cell_area(B) (once per plan)."""
        if self._base is None:
            self._base = _base_window(self.rows.g, self.geo, self.win, self.feet, self.sc.steady)
        return self._base

    def areas(self) -> np.ndarray:
        """Σ_R cell_area(v_c) (C,)."""
        return _areas(self.sc.terms, self.feet, (self.win, *self.base()), self.geo)

    def distances(self, which: np.ndarray, listed: int = LISTED_MEMBERS) -> np.ndarray:
        """d of eq. 47 for the candidates ``which``: for the nearest distance to at most ``listed`` member cells
        of G, by a search over their list (:func:`_nearest_listed`; far from a few small sets, where every candidate
        ties on area and all 25 need a distance, each row search of the grid would cross the whole box), else by
        the row search."""
        m, which = self.rows, np.asarray(which, dtype=np.int64)
        if self._listed(listed):
            return _nearest_listed(which, self.cands, self.feet, self.geo, (*m.members[:3], *m.blocks))
        if self._members is None:
            self._members = _range_members(self.base()[0], self.grid.slack + DELTA, self.sc.window[1])
        return _distances(which, self.cands, self.feet, self.geo, self.s.distance == "hausdorff", m.g, m.lazy,
                          (self.win, *self._members))


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
def _some_distances(which, cands, feet, geo, hausdorff, members, inner):
    """:meth:`RasterKernel.distances` for the candidates ``which`` on the path :meth:`RasterKernel._listed` chose
    (``members``: as :func:`_plan_costs`; ``inner``: R and its members, :func:`_nearest`)."""
    g, lazy, listed, listing = members
    if listed:
        return _nearest_listed(which, cands, feet, geo, listing)
    return _distances(which, cands, feet, geo, hausdorff, g, lazy, inner)


@numba.njit(cache=True)
def _plan_costs(scene, xy, geo, members, rule):
    """One plan of :func:`plan_one_raster` in one call: the spans, B and its prefix sums, every candidate's area
    over R, then eq. 47's distance for the first candidate of least area and for those its cost leaves a chance
    (``prune``; else for all), the costs and the pick (:func:`_choose`). Returns the spans, B, the prefix sums, the
    areas, the distances (inf where not computed), the costs and the index.

    ``scene``: :class:`Scene`'s tables ``(lines, lag, terms, steady, t0, t1, win)`` (``(t0, t1)`` its rows, ``win``
    its window R); ``xy`` the candidates' ends p; ``geo`` the grid (:attr:`RasterKernel.geo`); ``members``: G's
    members ``(g, lazy, listed, listing)`` (:class:`MemberRows`' ``g`` and ``lazy``, whether the nearest search runs
    over the listed members, and their list and blocks); ``rule``: ``(alpha, prune, hausdorff)``, α of eq. 47,
    whether to prune, and the distance's kind."""
    lines, lag, terms, steady, t0, t1, win = scene
    g, lazy, listed, _ = members
    alpha, prune, hausdorff = rule
    spans = _spans(lines, lag, geo, t0, t1, lazy[0].shape[1])
    feet = (lines, lag, spans, t0, t1)
    base, prefix = _base_window(g, geo, win, feet, steady)
    areas = _areas(terms, feet, (win, base, prefix), geo)
    n = len(areas)
    if listed:
        wnxt, wprv = np.zeros((0, 0), dtype=np.int32), np.zeros((0, 0), dtype=np.int32)
    else:
        wnxt, wprv = _range_members(base, g[6], win[1])
    inner, cands = (win, wnxt, wprv), (terms, steady, xy)
    dist = np.full(n, np.inf)
    need = np.ones(n, dtype=np.bool_)
    if prune:
        first = _choose(areas)
        one = np.full(1, first, dtype=np.int64)
        dist[first] = _some_distances(one, cands, feet, geo, hausdorff, members, inner)[0]
        bound = areas[first] + alpha * dist[first]
        for q in range(n):
            need[q] = areas[q] <= bound + 1e-9 + 1e-12 * abs(bound)
        need[first] = False
    which = np.flatnonzero(need)
    if len(which):
        got = _some_distances(which, cands, feet, geo, hausdorff, members, inner)
        for q in range(len(which)):
            dist[which[q]] = got[q]
    cost = np.empty(n)
    for q in range(n):
        cost[q] = areas[q] + alpha * dist[q]
    return spans, base, prefix, areas, dist, cost, _choose(cost)
