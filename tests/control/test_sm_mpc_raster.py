"""IB21 Sec. 5 set-membership MPC on raster sets: the compiled kernel computes the rounds of eqs. 44, 46, 48-49 as
the numpy reference does, its window costs equal the true costs up to one constant, it steers as the polygon
planner does (toward the set, away from a lower neighbour's footprint, straight on nothing), and its area terms
match the polygon planner's within the raster's resolution.

Run as a script to time both planners on the same random scenes: ``PYTHONPATH=src .venv/bin/python
tests/control/test_sm_mpc_raster.py``."""

from __future__ import annotations

import time

import numpy as np
import pytest
import shapely

from swarmtrack.control import sm_mpc as sm
from swarmtrack.control import sm_mpc_raster as smr
from swarmtrack.control import sm_mpc_raster_members as members
from swarmtrack.control import sm_mpc_raster_search as search
from swarmtrack.estimation import raster as rs
from swarmtrack.estimation.set_backends import PolygonSets, RasterSets

X0 = shapely.box(0, 0, 400, 400)
GRID = rs.Grid.over(X0, 1.0)
S = sm.SMMPCSettings()


def uav(x, y, psi, rate=0.0, acc=0.0):
    return np.array([x, y, 100.0, 0.0, psi, rate, acc])


def field_of(poly, grid=GRID, margin=3.0) -> rs.Field:
    """The exact distance field of a polygon on a window covering its bounds plus a margin (outside: the distance to
    the window, a lower bound since the polygon lies inside it)."""
    if poly.is_empty:
        return rs.EMPTY
    x0, y0, x1, y1 = poly.bounds
    i0, i1 = grid.span(y0 - margin, y1 + margin, 0)
    j0, j1 = grid.span(x0 - margin, x1 + margin, 1)
    xx, yy = np.meshgrid(grid.xs[j0:j1], grid.ys[i0:i1])
    d = shapely.distance(shapely.points(xx.ravel(), yy.ravel()), poly).reshape(xx.shape)
    return rs.Field(i0, j0, d)


def own_states(state, s=S):
    return sm.predict(state, sm.candidates(s.inputs, s.horizon), s)


def no_neighbours(s=S):
    return np.zeros((0, s.horizon, 7))


def plan(region_poly, state, s=S, nb=None, grid=GRID, **kw):
    nb = no_neighbours(s) if nb is None else nb
    return smr.plan_one_raster(grid, field_of(region_poly, grid), own_states(state, s), nb, s, **kw)


def random_region(rng, area=X0, n_cuts=6):
    """A mid-mission X^A: the area less a few explored strips and rectangles, plus a few blobs left inside them."""
    x0, y0, x1, y1 = area.bounds
    cuts = []
    for _ in range(n_cuts):
        a, b = rng.uniform([x0, y0], [x1, y1], (2, 2))
        cuts.append(shapely.LineString([a, b]).buffer(rng.uniform(20, 45), cap_style="square"))
    region = shapely.difference(area, shapely.union_all(cuts))
    blobs = shapely.buffer(shapely.points(rng.uniform([x0, y0], [x1, y1], (4, 2))), rng.uniform(3, 15, 4))
    return shapely.intersection(shapely.union(region, shapely.union_all(blobs)), area)


def random_scene(rng, area=X0, n_nb=3, edge=None):
    """A region, a UAV and lower neighbours near it; with ``edge`` (d^c), the first neighbour's predicted position at
    k+h is put at d^c from the middle of the UAV's predicted positions, across its heading, so eq. 48 keeps it for
    some candidates only."""
    x0, y0, x1, y1 = area.bounds
    state = uav(*rng.uniform([x0 + 40, y0 + 40], [x1 - 40, y1 - 40]), rng.uniform(-np.pi, np.pi),
                rng.uniform(-0.3, 0.3), rng.choice([0.0, 0.25, -0.5]))
    nav = np.stack([uav(*(state[:2] + rng.uniform(-120, 120, 2)), rng.uniform(-np.pi, np.pi)) for _ in range(n_nb)])
    nb = sm.predict(nav, rng.choice(S.inputs, (n_nb, S.horizon)), S)
    if edge is not None:
        ends = own_states(state)[:, -1, :2]
        side = np.array([-np.sin(state[4]), np.cos(state[4])]) * rng.choice([-1, 1])
        nb[0, :, :2] += np.median(ends, axis=0) + edge * side - nb[0, -1, :2]
    return random_region(rng, area), state, nb


# --- the kernel against the reference -----------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("distance", ["nearest", "hausdorff"])
@pytest.mark.parametrize("case", ["box", "odd_area", "baseline", "near_range"])
def test_the_kernel_equals_the_numpy_reference(case, distance):
    """Areas over R equal the reference's on R, distances the reference's on the whole grid (1e-9), with steady
    and varying neighbours, a non-rectangular X0 (the clip), the baseline, and neighbours at the edge of d^c."""
    rng = np.random.default_rng(["box", "odd_area", "baseline", "near_range"].index(case))
    area = shapely.box(0, 0, 250, 250) if case != "odd_area" else \
        shapely.Polygon([(0, 0), (250, 0), (250, 120), (130, 250), (0, 250)])
    grid = rs.Grid.over(area, 1.0)
    s = sm.SMMPCSettings(distance=distance, baseline=case == "baseline",
                         comm_range=120.0 if case == "near_range" else 200.0)
    checked_steady = checked_varying = False
    for _ in range(3):
        poly, state, nb = random_scene(rng, area, edge=s.comm_range if case == "near_range" else None)
        region = field_of(poly, grid)
        rem = sm.removals(own_states(state, s), nb, s, neighbours=not s.baseline)
        sc = smr.scene(grid, rem, s)
        checked_steady |= len(sc.steady) > 0
        checked_varying |= sc.terms.shape[1] > s.horizon
        areas, dist = smr.kernel_costs(grid, region, sc, rem.xy[-1], s)
        ref_area, _ = smr.reference_costs(grid, region, rem, rem.xy[-1], s, sc.window)
        _, ref_dist = smr.reference_costs(grid, region, rem, rem.xy[-1], s)
        np.testing.assert_allclose(areas, ref_area, rtol=0, atol=1e-9 * max(1.0, np.abs(ref_area).max()))
        np.testing.assert_allclose(dist, ref_dist, rtol=0, atol=1e-9)
    if case == "box":
        assert checked_steady  # neighbours removed for every candidate were exercised
    if case == "near_range":
        assert checked_varying  # and neighbours eq. 48 keeps for some candidates only


def every_listed_member(k: smr.RasterKernel, which: np.ndarray, row_search: bool = False) -> np.ndarray:
    """The nearest distance of the listed search by its definition: over every listed member cell of G that no term
    of the candidate (nor a steady one) covers, the least distance from p to its square (``np.hypot`` is the C
    library's, as the kernel's ``math.hypot``; Python's own differs in the last bit). ``row_search``: with the row
    search's arithmetic for the gap across the rows (its cell's upper side as ``y0 + (i + 1)·c``)."""
    rows, starts, cols, complete = k.rows.members
    assert complete
    sc, (x0, y0, c) = k.sc, k.geo[:3]
    ii, jj = np.repeat(rows, np.diff(starts)), cols
    ids = np.empty(sc.terms.shape[1] + len(sc.steady), dtype=np.int64)
    out = np.zeros(len(which))
    for q, cand in enumerate(which):
        cover = (ids, search._terms_of(sc.terms, sc.steady, cand, ids), k.feet, k.grid.slack + smr.DELTA)
        free = np.array([not search._covered.py_func(cover, k.geo, i, j) for i, j in zip(ii, jj, strict=True)],
                        dtype=bool)
        if free.any():
            px, py = k.xy[cand]
            dx = np.maximum(np.maximum(x0 + jj * c - px, px - (x0 + jj * c + c)), 0.0)
            top = y0 + (ii + 1) * c if row_search else y0 + ii * c + c
            dy = np.maximum(np.maximum(y0 + ii * c - py, py - top), 0.0)
            out[q] = np.hypot(dx, dy)[free].min()
    return out


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(2))
def test_the_nearest_distance_over_the_listed_members_equals_the_row_search(seed):
    """Both paths of :meth:`RasterKernel.distances` (the search over the listed member cells of G, the row search of
    the grid) give the reference's distances, on sets large and small (a few blobs far from the UAV: the case the
    first is for, and a blob the UAV's footprints cut); the listed search gives exactly the least distance over every
    listed cell left uncovered."""
    rng = np.random.default_rng(10 + seed)
    for kind in ("large", "far", "cut"):
        poly, state, nb = random_scene(rng)
        rem = sm.removals(own_states(state), nb, S)
        if kind == "far":
            poly = shapely.union_all(shapely.buffer(shapely.points(rng.uniform(0, 400, (3, 2))), 4.0))
        elif kind == "cut":
            poly = shapely.Point(*(rem.xy[-1].mean(axis=0) + rng.uniform(-30, 30, 2))).buffer(25)
        region = field_of(poly)
        sc = smr.scene(GRID, rem, S)
        _, ref = smr.reference_costs(GRID, region, rem, rem.xy[-1], S)
        every = np.arange(len(sc.terms))
        for listed in (0, 10 ** 7):
            k = smr.RasterKernel(GRID, region, sc, rem.xy[-1], S, smr.member_rows(GRID, region, S))
            dist = k.distances(every, listed=listed)
            np.testing.assert_allclose(dist, ref, rtol=0, atol=1e-9)
            if not listed:
                rows_dist = dist
            elif kind != "large":  # both searches (warm starts, skipped blocks) give the least distance exactly
                np.testing.assert_array_equal(dist, every_listed_member(k, every))
                np.testing.assert_array_equal(rows_dist, every_listed_member(k, every, row_search=True))


@pytest.mark.slow
@pytest.mark.parametrize("horizon, inputs", [(1, (0.0, 0.25, -0.25, 0.5, -0.5)), (3, (0.0, 0.5, -0.5))])
def test_the_kernel_equals_the_numpy_reference_at_other_horizons(horizon, inputs):
    area = shapely.box(0, 0, 250, 250)
    grid = rs.Grid.over(area, 1.0)
    s = sm.SMMPCSettings(horizon=horizon, inputs=inputs, comm_range=150.0)
    rng = np.random.default_rng(horizon)
    poly = random_region(rng, area, n_cuts=3)
    state = uav(125, 125, rng.uniform(-np.pi, np.pi), 0.1)
    nav = np.stack([uav(60, 150, 0.5), uav(150, 40, 2.0)])
    nb = sm.predict(nav, np.zeros((2, horizon)), s)
    nb[1, :, :2] += state[:2] + np.array([150.0, 0.0]) - nb[1, -1, :2]  # at d^c at k+h: kept for some candidates
    region = field_of(poly, grid)
    rem = sm.removals(own_states(state, s), nb, s)
    sc = smr.scene(grid, rem, s)
    areas, dist = smr.kernel_costs(grid, region, sc, rem.xy[-1], s)
    ref_area, _ = smr.reference_costs(grid, region, rem, rem.xy[-1], s, sc.window)
    _, ref_dist = smr.reference_costs(grid, region, rem, rem.xy[-1], s)
    assert len(areas) == len(inputs) ** horizon
    np.testing.assert_allclose(areas, ref_area, rtol=0, atol=1e-9 * np.abs(ref_area).max())
    np.testing.assert_allclose(dist, ref_dist, rtol=0, atol=1e-9)


@pytest.mark.slow
def test_the_kernel_equals_the_reference_for_a_set_far_from_the_uav_and_off_its_stored_window():
    """A small blob far away: the distance comes from member cells outside R and outside the Field's stored window
    (the distance to its rectangle)."""
    poly = shapely.Point(40, 350).buffer(6)
    state = uav(330, 60, 0.3)
    region = rs.Field(*field_of(poly, margin=0.0).window[:2], field_of(poly, margin=0.0).data)
    for s in (S, sm.SMMPCSettings(distance="hausdorff")):
        rem = sm.removals(own_states(state, s), no_neighbours(s), s)
        sc = smr.scene(GRID, rem, s)
        areas, dist = smr.kernel_costs(GRID, region, sc, rem.xy[-1], s)
        _, ref = smr.reference_costs(GRID, region, rem, rem.xy[-1], s)
        np.testing.assert_allclose(dist, ref, rtol=0, atol=1e-9)
        assert np.ptp(areas) == 0.0 and dist.min() > 300


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_window_costs_differ_from_the_full_grid_costs_by_one_constant(seed):
    """The costs over R (module docstring) equal the true costs (the reference on the whole grid) less one constant
    for every candidate, so both pick the same input."""
    rng = np.random.default_rng(100 + seed)
    poly, state, nb = random_scene(rng)
    region = field_of(poly)
    own = own_states(state)
    fast = smr.plan_one_raster(GRID, region, own, nb, S, prune=False)
    rem = sm.removals(own, nb, S)
    true_area, true_dist = smr.reference_costs(GRID, region, rem, rem.xy[-1], S)
    true_cost = true_area + S.alpha * true_dist
    offset = true_cost - fast.cost
    assert np.ptp(offset) < 1e-9 * true_area.max()
    assert offset.min() > 0  # the cells off R carry area too
    assert sm.choose(true_cost) == fast.index
    pruned = smr.plan_one_raster(GRID, region, own, nb, S)
    assert pruned.index == fast.index
    ok = np.isfinite(pruned.cost)
    np.testing.assert_array_equal(pruned.cost[ok], fast.cost[ok])


# --- steering -----------------------------------------------------------------------------------------------------


def test_a_set_ahead_left_makes_the_uav_turn_left():
    left = plan(shapely.Point(170, 255).buffer(12), uav(100, 200, 0.0))
    assert left.plan[0] > 0, left.plan
    right = plan(shapely.Point(170, 145).buffer(12), uav(100, 200, 0.0))
    assert right.plan[0] < 0, right.plan


def test_when_no_footprint_can_reach_the_set_the_distance_term_steers_toward_it():
    region = shapely.Point(350, 300).buffer(20)  # ahead-left, far beyond any footprint within 1 s
    choice = plan(region, uav(50, 180, 0.0), prune=False)
    assert np.ptp(choice.area) == 0.0  # the area term cannot decide
    assert choice.plan[0] > 0
    assert choice.distance[choice.index] == pytest.approx(np.min(choice.distance))
    flat = plan(region, uav(50, 180, 0.0), sm.SMMPCSettings(alpha=0.0))
    assert flat.plan.tolist() == [0.0, 0.0]  # without α every candidate ties: straight ahead


@pytest.mark.parametrize("region", [None, rs.EMPTY])
def test_an_empty_set_ties_everything_and_the_uav_flies_straight(region):
    choice = smr.plan_one_raster(GRID, region, own_states(uav(100, 100, 1.0)), no_neighbours(), S)
    assert choice.index == 0 and choice.plan.tolist() == [0.0, 0.0] and (choice.cost == 0).all()


def _two_blobs():
    left, right = shapely.Point(170, 255).buffer(14), shapely.Point(170, 145).buffer(12)
    return field_of(shapely.union(left, right))  # the left blob is a little larger: alone, UAV 1 turns left


def test_a_lower_neighbour_covering_a_region_changes_the_pick():
    region = _two_blobs()
    nb_nav = uav(170, 285, -np.pi / 2)  # UAV 0 flies south over the left blob
    first = smr.plan_one_raster(GRID, region, own_states(nb_nav), no_neighbours(), S)
    nb = sm.predict(nb_nav[None], first.plan[None], S)
    own = own_states(uav(100, 200, 0.0))
    alone = smr.plan_one_raster(GRID, region, own, no_neighbours(), S)
    together = smr.plan_one_raster(GRID, region, own, nb, S)
    assert alone.plan[0] > 0 and together.plan[0] < 0
    far = smr.plan_one_raster(GRID, region, own, nb, sm.SMMPCSettings(comm_range=50.0))  # eq. 48: out of range
    assert far.plan[0] > 0


def test_the_baseline_ignores_neighbours_and_does_not_dilate():
    region = _two_blobs()
    nb = sm.predict(uav(170, 285, -np.pi / 2)[None], np.zeros((1, 2)), S)
    own = own_states(uav(100, 200, 0.0))
    base = sm.SMMPCSettings(baseline=True)
    with_nb = smr.plan_one_raster(GRID, region, own, nb, base, prune=False)
    without = smr.plan_one_raster(GRID, region, own, no_neighbours(), base, prune=False)
    np.testing.assert_array_equal(with_nb.cost, without.cost)
    assert with_nb.plan[0] > 0
    # no dilation: a set no footprint reaches keeps its area (that of X^A's values on the grid); the MPC's grows
    far = field_of(shapely.box(20, 20, 40, 40))
    rem = sm.removals(own_states(uav(300, 300, 0.5)), no_neighbours(), base)
    unchanged = rs.cell_area(rs.values(GRID, far, (0, 0, GRID.ny, GRID.nx)), GRID.cell).sum()
    kept, _ = smr.reference_costs(GRID, far, rem, rem.xy[-1], base)
    grown, _ = smr.reference_costs(GRID, far, rem, rem.xy[-1], S)
    np.testing.assert_allclose(kept, unchanged, rtol=1e-12)
    assert (grown > unchanged + 80).all()  # two dilations by 0.5 m of a 20 m square: about 4 × 20 × 1 m more


def test_uavs_holding_the_same_field_share_its_member_rows():
    region = field_of(shapely.box(20, 20, 40, 40))  # far from both UAVs
    shared: dict = {}
    for state in (uav(300, 300, 0.5), uav(350, 200, -1.0)):
        alone = smr.plan_one_raster(GRID, region, own_states(state), no_neighbours(), S, prune=False)
        common = smr.plan_one_raster(GRID, region, own_states(state), no_neighbours(), S, prune=False, shared=shared)
        np.testing.assert_array_equal(alone.distance, common.distance)
        assert alone.index == common.index
    assert len(shared) == 1


# --- against the polygon planner ----------------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(2))
def test_raster_area_terms_match_the_polygon_planner_within_perimeter_times_cell(seed):
    """On the rasterisation of a polygon P (its exact distance field), each candidate's true raster area term is
    within (perimeter of its predicted polygon set) × c of the polygon planner's exact area term."""
    rng = np.random.default_rng(200 + seed)
    poly, state, nb = random_scene(rng)
    own = own_states(state)
    exact = sm.plan_one(poly, own, nb, X0, S, exact=True)
    rem = sm.removals(own, nb, S)
    raster_area, _ = smr.reference_costs(GRID, field_of(poly), rem, rem.xy[-1], S)
    perimeter = shapely.length(sm.evolve(poly, rem, S, X0))
    gap = np.abs(raster_area - exact.area)
    assert (gap <= perimeter * GRID.cell).all(), (gap / perimeter).max()
    fast = smr.plan_one_raster(GRID, field_of(poly), own, nb, S)
    assert exact.cost[fast.index] - exact.cost.min() <= 2 * perimeter.max() * GRID.cell


# --- timing (run as a script) -----------------------------------------------------------------------------------


def time_planners(seeds=range(4), n_uavs=6, repeats=5) -> dict[str, float]:
    """ms per UAV plan of the raster planner and of the polygon local path (:func:`sm_mpc.plan_one`) on the same
    random scenes: ``n_uavs`` UAVs plan in index order with their lower neighbours within d^c (their predicted
    states computed outside the timing), each UAV with its own Field object (nothing shared); per UAV the best of
    ``repeats`` calls, averaged over the UAVs. A rough measure."""
    cands = sm.candidates(S.inputs, S.horizon)
    out = {"raster": 0.0, "polygon": 0.0}
    count = 0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        poly = random_region(rng)
        nav = np.stack([uav(*rng.uniform(30, 370, 2), rng.uniform(-np.pi, np.pi)) for _ in range(n_uavs)])
        own = sm.predict(nav[:, None, :], cands[None], S)
        field = field_of(poly)
        near = np.hypot(*(nav[:, None, :2] - nav[None, :, :2]).T) <= S.comm_range
        plans = np.zeros((n_uavs, S.horizon))
        for i in range(n_uavs):
            lower = np.flatnonzero(near[i, :i])
            nb = sm.predict(nav[lower], plans[lower], S) if len(lower) else no_neighbours()
            best = {}
            for _ in range(repeats):
                for name in out:
                    region = rs.Field(field.i0, field.j0, field.data)  # a fresh object: no sharing between calls
                    t0 = time.perf_counter()
                    if name == "raster":
                        choice = smr.plan_one_raster(GRID, region, own[i], nb, S)
                    else:
                        sm.plan_one(poly, own[i], nb, X0, S)
                    best[name] = min(best.get(name, np.inf), time.perf_counter() - t0)
            plans[i] = choice.plan
            for name in out:
                out[name] += best[name] * 1e3
            count += 1
    return {k: v / count for k, v in out.items()}


if __name__ == "__main__":
    time_planners(seeds=[99], repeats=1)  # compile
    for name, ms in time_planners().items():
        print(f"{name}: {ms:.3f} ms per UAV plan")


def test_a_controller_on_a_grid_loads_the_planner_kernels_before_its_first_plan(monkeypatch):
    """The ``solve_time`` probe (Fig. 11 right) must not time numba loading or compiling the kernels: building the
    controller runs both distance paths once per process (:func:`sm_mpc_raster.warm`)."""
    monkeypatch.setattr(smr, "_WARM", [])
    planned = []
    monkeypatch.setattr(smr, "plan_one_raster", lambda grid, region, *a, **k: planned.append(len(
        np.flatnonzero(rs.members(grid, region)))))
    grid = rs.Grid.over(shapely.box(0, 0, 400, 400), 1.0)
    area = shapely.box(0, 0, 400, 400)
    sm.SetMembershipMPC(RasterSets(area, grid), n_uavs=2)
    assert len(planned) == 2 and min(planned) <= smr.LISTED_MEMBERS < max(planned)  # both distance paths
    sm.SetMembershipMPC(RasterSets(area, grid), n_uavs=2)
    sm.SetMembershipMPC(PolygonSets(area), n_uavs=2)  # polygons: nothing to load
    assert len(planned) == 2  # once per process


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_a_strip_left_infinite_has_no_value_at_most_the_limit(seed):
    """:func:`sm_mpc_raster_members._strip` gives ``+inf`` for a strip off the Field's window only where every value
    :func:`raster.values` gives there exceeds the limit (no member after the dilations, no area: the same numbers),
    and it does so for the usual windows (cores well inside them)."""
    rng = np.random.default_rng(40 + seed)
    skipped = 0
    for _ in range(8):
        blobs = shapely.buffer(shapely.points(rng.uniform(20, 380, (2, 2))), rng.uniform(3, 15, 2))
        region = rs.trim(GRID, field_of(shapely.union_all(blobs), margin=float(rng.uniform(0.5, 6.0))))
        i0, j0, i1, j1 = region.window
        ci0, cj0, ci1, cj1 = region.core
        limit = GRID.slack + 2 * smr.DELTA + S.horizon * S.target_speed * S.period
        for window, gap in (((i0 - 4, j0 - 4, i0, j1 + 4), ci0 - i0), ((i1, j0 - 4, i1 + 4, j1 + 4), i1 - ci1),
                            ((i0, j0 - 4, i1, j0), cj0 - j0), ((i0, j1, i1, j1 + 4), j1 - cj1)):
            window = (max(window[0], 0), max(window[1], 0), min(window[2], GRID.ny), min(window[3], GRID.nx))
            if window[0] >= window[2] or window[1] >= window[3]:
                continue
            got = members._strip(GRID, region, window, gap, limit)
            values = rs.values(GRID, region, window)
            if np.isinf(got).all():
                skipped += 1
                assert (values > limit).all()
            else:
                np.testing.assert_array_equal(got, values)
    assert skipped


def test_the_listed_blocks_kernel_equals_its_numpy_reference():
    rng = np.random.default_rng(7)
    for n_rows in (1, 7, 8, 9, 30):
        counts = rng.integers(1, 6, n_rows)
        starts = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        cols = np.concatenate([np.sort(rng.choice(400, k, replace=False)) for k in counts]).astype(np.int64)
        for size in (1, 3, 8):
            got = members._listed_blocks(starts, cols, size)
            for a, b in zip(got, smr.listed_blocks_reference(starts, cols, size), strict=True):
                np.testing.assert_array_equal(a, b)


@pytest.mark.slow
@pytest.mark.parametrize("distance", ["nearest", "hausdorff"])
def test_the_one_call_plan_equals_the_separate_kernels(distance):
    """:meth:`RasterKernel.plan` (one compiled call) gives the areas and distances of :meth:`RasterKernel.areas` and
    :meth:`RasterKernel.distances` bit for bit, and :func:`sm_mpc.choose`'s pick of their costs; pruned, the same
    distances where it computes them."""
    s = sm.SMMPCSettings(distance=distance)
    rng = np.random.default_rng(21)
    for kind in ("large", "far"):
        poly, state, nb = random_scene(rng)
        if kind == "far":
            poly = shapely.union_all(shapely.buffer(shapely.points(rng.uniform(0, 400, (3, 2))), 4.0))
        region = field_of(poly)
        rem = sm.removals(own_states(state, s), nb, s)
        sc = smr.scene(GRID, rem, s)
        areas, dist = smr.kernel_costs(GRID, region, sc, rem.xy[-1], s)
        for prune in (False, True):
            k = smr.RasterKernel(GRID, region, sc, rem.xy[-1], s)
            got_areas, got_dist, cost, index = k.plan(prune)
            np.testing.assert_array_equal(got_areas, areas)
            done = np.isfinite(got_dist)
            assert done.all() or prune
            np.testing.assert_array_equal(got_dist[done], dist[done])
            np.testing.assert_array_equal(cost, got_areas + s.alpha * got_dist)
            assert index == sm.choose(cost) == sm.choose(areas + s.alpha * dist)
