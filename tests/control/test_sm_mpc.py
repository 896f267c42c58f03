"""IB21 Sec. 5 set-membership MPC: predictions follow the fixed-wing model, the cost (eq. 47) steers toward what is
unexplored, lower-indexed neighbours' footprints count (eqs. 48-49), the baseline ignores them, ties go to the first
candidate, and the local window picks the input the full-set reference picks."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from swarmtrack.control import sm_mpc as sm
from swarmtrack.estimation import polygons as pg
from swarmtrack.estimation.base import TargetView
from swarmtrack.estimation.set_backends import PolygonSets
from swarmtrack.models import fixed_wing as fw
from swarmtrack.network.messages import Inbox
from swarmtrack.sensors.footprint import footprint_corners, footprint_polygons

X0 = shapely.box(0, 0, 400, 400)
S = sm.SMMPCSettings()


def uav(x, y, psi, rate=0.0, acc=0.0):
    return np.array([x, y, 100.0, 0.0, psi, rate, acc])


def plan(region, state, settings=S, nb=None, exact=None):
    own = sm.predict(state, sm.candidates(settings.inputs, settings.horizon), settings)
    nb = np.zeros((0, settings.horizon, 7)) if nb is None else nb
    return sm.plan_one(region, own, nb, X0, settings, exact=exact)


def test_candidates_are_ordered_zero_first_then_increasing_magnitude():
    assert sm.input_order([-0.5, -0.25, 0.0, 0.25, 0.5]).tolist() == [0.0, -0.25, 0.25, -0.5, 0.5]
    c = sm.candidates(S.inputs, 2)
    assert c.shape == (25, 2)
    assert c[:6].tolist() == [[0, 0], [0, 0.25], [0, -0.25], [0, 0.5], [0, -0.5], [0.25, 0]]


@pytest.mark.slow
def test_predicted_footprints_follow_the_fixed_wing_kinematics():
    state = uav(200, 200, 0.4, 0.1, 0.2)
    settings = sm.SMMPCSettings(inputs=(0.3,), horizon=2)
    s = state[None]
    removed = []
    for _ in range(2):  # the world's own step, tick by tick, the input held for T^c
        for _ in range(10):
            s = fw.step(s, [0.3])
        removed.append(footprint_polygons(footprint_corners(s[:, :2], s[:, 4], s[:, 2], S.tan_half))[0])
    # eqs. 44, 46 by hand
    a = np.array([X0], dtype=object)
    for f in removed:
        a = pg.clip(pg.dilate(a, 0.5), X0)
        a = shapely.difference(a, f)
    for exact in (True, False):
        choice = plan(X0, state, settings, exact=exact)
        if exact:
            assert choice.area[0] == pytest.approx(pg.area(a)[0], rel=1e-12)
        assert choice.plan.tolist() == [0.3, 0.3]
    own = sm.predict(state, [[0.3, 0.3]], settings)[0]
    np.testing.assert_array_equal(own[-1], s[0])


def test_a_blob_ahead_left_makes_the_uav_turn_left():
    for exact in (True, False):
        choice = plan(shapely.Point(170, 255).buffer(12), uav(100, 200, 0.0), exact=exact)
        assert choice.plan[0] > 0, choice.plan
        mirrored = plan(shapely.Point(170, 145).buffer(12), uav(100, 200, 0.0), exact=exact)
        assert mirrored.plan[0] < 0


def test_when_no_footprint_reaches_the_set_the_distance_term_steers_toward_it():
    region = shapely.Point(350, 300).buffer(20)  # ahead-left, far beyond any footprint within 1 s
    for exact in (True, False):
        choice = plan(region, uav(50, 180, 0.0), exact=exact)
        assert np.ptp(choice.area) == pytest.approx(0.0, abs=1e-6)  # the area term cannot decide
        assert choice.plan[0] > 0
        assert choice.distance[choice.index] == pytest.approx(np.min(choice.distance))
    # without α every candidate ties and the first one (straight ahead) is taken
    flat = plan(region, uav(50, 180, 0.0), sm.SMMPCSettings(alpha=0.0))
    assert flat.plan.tolist() == [0.0, 0.0]


def test_hausdorff_distance_is_the_farthest_point_of_the_set():
    region = shapely.box(300, 100, 320, 140)
    state = uav(20, 20, 0.0)
    choice = plan(region, state, sm.SMMPCSettings(distance="hausdorff"), exact=True)
    own = sm.predict(state, sm.candidates(S.inputs, 2), S)[:, -1, :2]
    # the dilated box's farthest points: its corners pushed out by 2 dilations, ≈ 1 m along the diagonal
    far = np.hypot(*(own[:, None, :] - np.array([[300, 100], [320, 100], [320, 140], [300, 140]])).T).max(axis=0)
    np.testing.assert_allclose(choice.distance, far + 2 * S.reach, atol=0.02)
    fast = plan(region, state, sm.SMMPCSettings(distance="hausdorff"), exact=False)
    np.testing.assert_allclose(fast.distance, choice.distance, rtol=1e-9)


def test_an_empty_set_ties_everything_and_the_uav_flies_straight():
    choice = plan(shapely.Polygon(), uav(100, 100, 1.0))
    assert choice.plan.tolist() == [0.0, 0.0] and (choice.cost == 0).all()


def test_exact_ties_go_to_the_first_candidate_in_the_given_order():
    region = shapely.box(0, 150, 400, 250).difference(shapely.box(40, 190, 400, 210))
    for inputs in ((0.25, -0.25), (-0.25, 0.25)):
        settings = sm.SMMPCSettings(inputs=inputs, horizon=1)
        choice = plan(region, uav(60, 200, 0.0), settings, exact=True)
        assert choice.cost[0] == pytest.approx(choice.cost[1], rel=1e-9)  # mirror images
        assert choice.plan[0] == inputs[0]


def test_a_lower_neighbour_covering_a_region_sends_the_higher_uav_elsewhere():
    left, right = shapely.Point(170, 255).buffer(14), shapely.Point(170, 145).buffer(12)
    region = shapely.union(left, right)  # the left blob is a little larger: alone, UAV 1 turns left
    nav = np.stack([uav(170, 285, -np.pi / 2), uav(100, 200, 0.0)])  # UAV 0 flies south over the left blob
    regions = np.array([region, region], dtype=object)
    alone = sm.plan_all(nav, regions, X0, S, np.zeros((2, 2), bool), nav)
    assert alone.plans[1, 0] > 0
    links = np.array([[False, True], [True, False]])
    together = sm.plan_all(nav, regions, X0, S, links, nav)
    assert together.plans[1, 0] < 0 and together.neighbours.tolist() == [0, 1]
    assert (together.plans[0] == alone.plans[0]).all()  # UAV 0 plans alone either way (no lower index)
    exact = sm.plan_all(nav, regions, X0, S, links, nav, exact=True)
    np.testing.assert_array_equal(exact.plans, together.plans)
    # beyond d^c (eq. 48) the neighbour is ignored even over a link
    far = sm.plan_all(nav, regions, X0, sm.SMMPCSettings(comm_range=50.0), links, nav)
    assert far.plans[1, 0] > 0
    # the baseline ignores the neighbour (SimpleBaselineMPC): it differs from the full MPC here
    base = sm.plan_all(nav, regions, X0, sm.SMMPCSettings(baseline=True), links, nav)
    assert base.plans[1, 0] > 0 and base.neighbours[1] == 0


def test_the_baseline_neither_dilates_nor_counts_neighbours():
    region = shapely.box(150, 150, 250, 250)
    state = uav(200, 200, 0.0)
    choice = plan(region, state, sm.SMMPCSettings(baseline=True), exact=True)
    own = sm.predict(state, sm.candidates(S.inputs, 2), S)
    f = footprint_polygons(footprint_corners(own[:, :, :2].reshape(-1, 2), own[:, :, 4].ravel(), 100, S.tan_half))
    f = f.reshape(25, 2)
    expected = shapely.area(shapely.difference(shapely.difference(region, f[:, 0]), f[:, 1]))
    np.testing.assert_allclose(choice.area, expected, rtol=1e-12)


def _mission_like(rng, n_sweeps=5):
    region = X0
    for _ in range(n_sweeps):
        s = uav(*rng.uniform(0, 400, 2), rng.uniform(-np.pi, np.pi), rng.uniform(-0.3, 0.3))[None]
        for _ in range(rng.integers(10, 60)):
            s = fw.rollout(s, [[0.0]], 10)[:, 0]
            region = pg.clip(pg.dilate(np.array([region]), 0.5), X0)[0]
            region = shapely.difference(region, footprint_polygons(footprint_corners(s[:, :2], s[:, 4], 100,
                                                                                     S.tan_half))[0])
    return region


@pytest.mark.slow
@pytest.mark.parametrize("distance", ["nearest", "hausdorff"])
def test_the_local_window_picks_the_input_of_the_full_set_reference(distance):
    rng = np.random.default_rng(21)
    settings = sm.SMMPCSettings(distance=distance)
    same = total = 0
    for _ in range(6):
        region = _mission_like(rng)
        n = 4
        nav = np.stack([uav(*rng.uniform(-20, 420, 2), rng.uniform(-np.pi, np.pi), rng.uniform(-0.5, 0.5),
                            rng.choice([0.0, 0.25, -0.5])) for _ in range(n)])
        nav[1:, :2] = nav[0, :2] + rng.uniform(-150, 150, (n - 1, 2))  # close enough to be neighbours
        d = np.hypot(*(nav[:, None, :2] - nav[None, :, :2]).T)
        links = (d <= 200) & ~np.eye(n, dtype=bool)
        regions = np.array([region] * n, dtype=object)
        fast = sm.plan_all(nav, regions, X0, settings, links, nav)
        exact = sm.plan_all(nav, regions, X0, settings, links, nav, exact=True)
        for i in range(n):
            total += 1
            f, e = fast.choices[i], exact.choices[i]
            if f.index == e.index:
                same += 1
            else:  # then the reference must rate both the same, up to round-off
                assert e.cost[f.index] == pytest.approx(e.cost[e.index], rel=1e-9, abs=1e-6)
            # the proof: where the fast path evaluated them, costs differ from the exact ones by one constant
            ok = np.isfinite(f.cost)
            offset = e.cost[ok] - f.cost[ok]
            assert np.ptp(offset) == pytest.approx(0.0, abs=1e-6 + 1e-9 * abs(offset).max())
    assert same / total >= 0.95


def test_the_fast_path_without_pruning_gives_every_candidates_cost_up_to_one_constant():
    region = _mission_like(np.random.default_rng(4))
    state = uav(180, 210, 2.0, -0.2, 0.25)
    f = plan(region, state, exact=False)
    full = sm.plan_one(region, sm.predict(state, sm.candidates(S.inputs, 2), S), np.zeros((0, 2, 7)), X0, S,
                       exact=False, prune=False)
    e = plan(region, state, exact=True)
    assert np.isfinite(full.cost).all() and full.index == e.index == f.index
    assert np.ptp(e.cost - full.cost) < 1e-6


def test_the_controller_commands_yaw_accelerations_and_records_its_solve_time():
    region = shapely.box(0, 0, 400, 400).difference(shapely.box(100, 100, 200, 200))
    nav = np.stack([uav(50, 50, 0.0), uav(150, 60, 1.0), uav(300, 300, -2.0)])
    mpc = sm.SetMembershipMPC(PolygonSets(X0), regions=lambda view: np.array([region] * 3, dtype=object))
    beacons = mpc.broadcast(0.0, nav)
    assert beacons["state"].shape == (3, 7)
    links = np.array([[0, 1, 0], [1, 0, 0], [0, 0, 0]], dtype=bool)
    view = TargetView(np.full((3, 4), np.nan))
    u = mpc.command(0.0, nav, view, Inbox(links, beacons), 0.5)
    assert u.shape == (3, 1) and set(u.ravel()) <= set(S.inputs)
    probes = mpc.sample()
    assert set(probes) == {p.name for p in mpc.probes}
    assert (probes["solve_time"] > 0).all() and (probes["solve_time"] < 1.0).all()
    assert probes["neighbours"].tolist() == [0, 1, 0] and (probes["candidates"] == 25).all()
    np.testing.assert_array_equal(probes["yaw_accel"], u.ravel())
    # between plans the input is held
    again = mpc.command(0.25, nav, view, Inbox(links, beacons), 0.25)
    np.testing.assert_array_equal(again, u)


def test_the_controller_reads_the_region_from_the_view_by_default():
    mpc = sm.SetMembershipMPC(PolygonSets(X0))
    with pytest.raises(ValueError, match="region"):
        mpc.command(0.0, np.stack([uav(10, 10, 0.0)]), TargetView(np.zeros((1, 4))), None, 0.5)


def test_settings_refuse_bad_values():
    with pytest.raises(ValueError, match="distance"):
        sm.SMMPCSettings(distance="sup")
    with pytest.raises(ValueError, match="multiple"):
        sm.SMMPCSettings(period=0.52)


def test_uavs_far_from_the_same_set_share_its_far_part_and_get_the_distances_of_separate_plans():
    region = shapely.box(20, 20, 40, 40)  # far from both UAVs: the distance needs the part outside the window
    cands = sm.candidates(S.inputs, S.horizon)
    shared: dict = {}
    for state in (uav(300, 300, 0.5), uav(350, 200, -1.0)):
        own = sm.predict(state, cands, S)
        alone = sm.plan_one(region, own, np.zeros((0, 2, 7)), X0, S, prune=False)
        common = sm.plan_one(region, own, np.zeros((0, 2, 7)), X0, S, prune=False, shared=shared)
        np.testing.assert_array_equal(alone.distance, common.distance)
        assert alone.index == common.index
    assert len(shared) == 1  # built once for both


@pytest.mark.parametrize("sets", ["polygons", "raster"])
def test_a_fleet_plan_gives_each_uav_the_numbers_of_its_own_plan(sets):
    """:func:`plan_all` computes the footprints once for the fleet and hands each UAV its own and its neighbours'
    (:func:`removals` ``corners``): every UAV's costs are those of planning it alone from its predicted states and
    its lower neighbours' (footprints computed there), bit for bit."""
    from swarmtrack.control import sm_mpc_raster as smr
    from swarmtrack.estimation import raster as rs

    rng = np.random.default_rng(7)
    n = 4
    nav = np.stack([uav(*rng.uniform(100, 300, 2), rng.uniform(-np.pi, np.pi), rng.uniform(-0.2, 0.2))
                    for _ in range(n)])
    links = (np.hypot(*(nav[:, None, :2] - nav[None, :, :2]).T) <= S.comm_range) & ~np.eye(n, dtype=bool)
    assert links[np.tril_indices(n, -1)].any()  # some UAV plans after a neighbour
    parts = [(0, 0, 150, 400), (250, 0, 400, 400), (150, 300, 250, 400)]  # X0 less a strip explored
    grid = rs.Grid.over(X0, 1.0) if sets == "raster" else None
    if grid is not None:
        x_a = rs.union(grid, [rs.box(grid, b) for b in parts])
    else:
        x_a = shapely.union_all([shapely.box(*b) for b in parts])
    fleet = sm.plan_all(nav, np.array([x_a] * n, dtype=object), X0, S, links, nav, grid=grid)
    cands = sm.candidates(S.inputs, S.horizon)
    for i in range(n):
        lower = np.flatnonzero(links[i, :i])
        nb = sm.predict(nav[lower], fleet.plans[lower], S) if len(lower) else np.zeros((0, S.horizon, 7))
        own = sm.predict(nav[i], cands, S)
        alone = (smr.plan_one_raster(grid, x_a, own, nb, S) if grid is not None else
                 sm.plan_one(x_a, own, nb, X0, S))
        got = fleet.choices[i]
        assert got.index == alone.index
        for a, b in ((got.cost, alone.cost), (got.area, alone.area), (got.distance, alone.distance)):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("seed", range(4))
def test_far_distances_part_by_part_equal_the_distance_to_the_whole_sets_rounds(seed):
    """Late-mission sets (scattered blobs) far from the UAVs: the nearest parts' rounds only, with the bound
    ``d(p, part) − hρ``, give the distance to the rounds of the whole set, and the plans of the full-set reference."""
    rng = np.random.default_rng(seed)
    region = shapely.union_all(shapely.buffer(shapely.points(rng.uniform(0, 400, (9, 2))), rng.uniform(2, 15, 9)))
    n = 3
    nav = np.stack([uav(*rng.uniform(0, 400, 2), rng.uniform(-np.pi, np.pi)) for _ in range(n)])
    d = np.hypot(*(nav[:, None, :2] - nav[None, :, :2]).T)
    links = (d <= 200) & ~np.eye(n, dtype=bool)
    regions = np.array([region] * n, dtype=object)
    fast = sm.plan_all(nav, regions, X0, S, links, nav)
    exact = sm.plan_all(nav, regions, X0, S, links, nav, exact=True)
    for f, e in zip(fast.choices, exact.choices, strict=True):
        ok = np.isfinite(f.cost)
        assert f.index == e.index and np.ptp(e.cost[ok] - f.cost[ok]) < 1e-6
    # directly: against the rounds of the whole set, outside a box
    own = sm.predict(nav[0], sm.candidates(S.inputs, S.horizon), S)
    rem = sm.removals(own, np.zeros((0, S.horizon, 7)), S)
    steady = [np.zeros(0, dtype=bool)] * S.horizon
    xy = rem.xy[-1]
    box = (*(xy.min(axis=0) - 5), *(xy.max(axis=0) + 5))
    got = sm._far_nearest(region, rem, S, X0, xy, box, steady, True, {"shared": None})
    whole = sm.evolve(region, rem, S, X0, use_own=False, nb_masks=steady, box=True)[0]
    want = sm.set_distance(np.full(len(xy), shapely.difference(whole, shapely.box(*box)), dtype=object), xy)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
