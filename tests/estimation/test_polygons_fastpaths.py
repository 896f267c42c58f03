"""The fast paths of the polygon sets (issue 26) give what the general paths give, bit for bit, and count the same
set operations (the planner's ``set_ops`` probe reads them): one set's removal without the arrays, the dilation
without a vertex cap, the fusion round's cache of :func:`polygons.within` (copies where the computation makes new
objects), the aggregated sets' cache of unchanged rows, and the planner's rounds of an empty set."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from swarmtrack.control import sm_mpc as sm
from swarmtrack.estimation import polygons as pg
from swarmtrack.estimation.setmembership import Beliefs, aggregated, uncertainty

X0 = shapely.box(0, 0, 400, 400)


def blobs(rng, n=5, radius=12.0, quad_segs=8):
    """A union of discs with boxes cut out: arcs, holes, several parts."""
    g = shapely.union_all(shapely.buffer(shapely.points(rng.uniform(20, 180, (n, 2))), radius, quad_segs=quad_segs))
    for _ in range(2):
        c = rng.uniform(20, 180, 2)
        g = shapely.difference(g, shapely.box(*(c - rng.uniform(2, 8)), *(c + rng.uniform(2, 8))))
    return g


def same(a, b) -> bool:
    """The same geometry to the bit (type, rings, coordinates and their order)."""
    return shapely.to_wkb(a) == shapely.to_wkb(b)


@pytest.mark.parametrize("seed", range(4))
def test_removing_from_one_set_equals_the_array_path_and_counts_the_same(seed):
    rng = np.random.default_rng(seed)
    a = blobs(rng)
    regions = [shapely.box(*(c := rng.uniform(0, 200, 2)), *(c + rng.uniform(5, 60))) for _ in range(6)]
    regions += [shapely.box(500, 500, 510, 510), pg.EMPTY, shapely.box(0, 0, 1, 1)]  # far, empty, corner
    for f in regions:
        for s in (a, pg.EMPTY):
            pg.OPS.clear()
            one = pg.remove(s, f)
            ops_one = dict(pg.OPS)
            pg.OPS.clear()
            many = pg.remove(np.array([s], dtype=object), np.array([f], dtype=object))[0]
            assert ops_one == dict(pg.OPS)
            assert same(one, many)
            assert (one is s) == (many is s)  # a miss returns the set itself either way


def test_a_dilation_without_a_vertex_cap_is_the_capped_formula():
    rng = np.random.default_rng(7)
    sets = np.array([blobs(rng) for _ in range(4)] + [pg.EMPTY], dtype=object)
    r = np.array([0.5, 0.25, 1.0, 0.5, 0.5])
    for radius in (0.5, r):
        reference = shapely.buffer(sets, pg.circumscribed(np.where(np.zeros(len(sets), bool), radius + 1.0, radius)),
                                   quad_segs=pg.QUAD_SEGS)  # what dilate built before: no set above the cap
        pg.OPS.clear()
        got = pg.dilate(sets, radius, cap=np.inf)
        assert pg.OPS == {"buffer": len(sets)}
        assert all(same(x, y) for x, y in zip(got, reference, strict=True))
        assert all(same(x, y) for x, y in zip(pg.dilate(sets, radius, cap=10 ** 9), reference, strict=True))


def _chain(small, holders, loose):
    out = small
    for h in holders:
        out = pg.within(out, *h, loose=loose)
    return out


@pytest.mark.parametrize("seed", range(3))
def test_a_fusion_round_reuses_within_and_gives_the_same_sets_as_new_objects(seed):
    """Two groups meet the same candidate with the same holders: the second reads the first's chain (no overlay),
    as copies: the same bits, new objects where the overlay makes them, and the candidate itself where it is kept
    whole."""
    rng = np.random.default_rng(seed)
    base = blobs(rng, 6, 14.0)
    xs = [shapely.difference(base, shapely.box(*(c := rng.uniform(0, 150, 2)), *(c + 60))) for _ in range(3)]
    us = [blobs(rng, 2, 6.0) for _ in range(3)]
    small = shapely.union_all(xs)
    holders = [[xs[k], us[k]] for k in range(3)]
    cold = _chain(small, holders, {})  # no cache: each call computes
    loose: dict = {}
    pg.OPS.clear()
    first = _chain(small, holders, loose)
    assert pg.OPS["intersection"] >= 2  # the holders cut the candidate (not one of the identity shortcuts)
    pg.OPS.clear()
    again = _chain(small, holders, loose)
    assert pg.OPS["intersection"] == 0 and pg.OPS["union"] == 0  # the whole chain from the round's cache
    assert same(first, cold) and same(again, cold)
    assert again is not first
    # a set that every holder covers is its own result: the very object, with or without the cache
    inside = shapely.box(*(c := np.array(shapely.get_coordinates(shapely.point_on_surface(xs[0]))[0])), *(c + 1e-3))
    kept = [[shapely.buffer(inside, 5.0)], [shapely.buffer(inside, 6.0)]]
    assert _chain(inside, kept, loose) is inside and _chain(inside, kept, loose) is inside


def _beliefs(rng, n=4, n_ids=3):
    b = Beliefs.start(n, n_ids, X0)
    for i in range(n):
        b.unexplored[i] = shapely.difference(X0, blobs(rng, 8, 30.0))
        b.unidentified[i] = blobs(rng, 2, 5.0)
        for j in range(n_ids):
            b.identified[i, j] = blobs(rng, 1, 4.0) if rng.uniform() < 0.7 else pg.EMPTY
    b.identified[3] = b.identified[2]  # UAVs 2 and 3 hold the same objects
    b.unidentified[3], b.unexplored[3] = b.unidentified[2], b.unexplored[2]
    return b


def test_the_aggregated_sets_of_unchanged_rows_come_from_the_cache():
    rng = np.random.default_rng(4)
    b = _beliefs(rng)
    cache: dict = {}
    ids: dict = {}
    first = aggregated(b, cache)
    phi = uncertainty(b, first, ids)
    assert first[2] is first[3]
    b.unidentified[1] = shapely.union(b.unidentified[1], shapely.box(300, 300, 310, 310))  # UAV 1's update
    pg.OPS.clear()
    second = aggregated(b, cache)
    assert pg.OPS["union"] == len([g for g in (*b.identified[1], b.unidentified[1], b.unexplored[1])
                                   if not g.is_empty]) - 1  # UAV 1's row only
    for i in (0, 2, 3):
        assert second[i] is first[i]
    plain = aggregated(b)
    assert all(same(x, y) for x, y in zip(second, plain, strict=True))
    again = uncertainty(b, second, ids)
    want = uncertainty(b, plain)
    for k in want:
        np.testing.assert_array_equal(again[k], want[k])
    np.testing.assert_array_equal(phi["identified"], again["identified"])  # ∪_j X_j unchanged: from the cache
    assert len(cache) == 3  # the rows of the last call only (UAVs 2 and 3 one)


def test_the_planner_rounds_of_an_empty_set_are_those_of_the_general_path():
    s = sm.SMMPCSettings()
    state = np.array([200.0, 200.0, 100.0, 0.0, 0.3, 0.0, 0.0])
    nb_state = np.array([210.0, 190.0, 100.0, 0.0, 1.0, 0.0, 0.0])
    own = sm.predict(state, sm.candidates(s.inputs, s.horizon), s)
    nb = sm.predict(nb_state[None], np.zeros((1, s.horizon)), s)
    rem = sm.removals(own, nb, s)
    windows = (None, (150.0, 150.0, 260.0, 250.0), (500.0, 500.0, 600.0, 600.0))  # none, inside X0, off X0
    for settings in (s, sm.SMMPCSettings(baseline=True)):
        for box in (False, True):
            for window in windows:
                for use_own in (True, False):
                    masks = None if use_own else [np.ones(1, bool)] * s.horizon
                    rect = None if settings.baseline else sm._rect(X0, box, window)
                    pg.OPS.clear()
                    general = sm._rounds(pg.EMPTY, rem, settings, X0, use_own, masks, True, box, rect)
                    ops = dict(pg.OPS)
                    pg.OPS.clear()
                    fast = sm.evolve(pg.EMPTY, rem, settings, X0, use_own=use_own, nb_masks=masks, box=box,
                                     window=window)
                    assert dict(pg.OPS) == ops
                    assert len(fast) == len(general) and shapely.is_empty(general).all()
                    assert shapely.is_empty(fast).all()


def test_the_measured_footprint_areas_skip_empty_sets_and_keep_the_others_numbers():
    rng = np.random.default_rng(9)
    sets = np.array([blobs(rng), pg.EMPTY, blobs(rng), shapely.GeometryCollection()], dtype=object)
    c = rng.uniform(40, 160, (4, 2))
    corners = np.stack([c + [-20, -10], c + [20, -10], c + [20, 10], c + [-20, 10]], axis=1)
    got = sm._minus_areas(sets, corners)
    assert got[1] == 0.0 and got[3] == 0.0
    for k in (0, 2):  # the general path on one set at a time: the same numbers
        np.testing.assert_array_equal(got[k:k + 1], sm._minus_areas(sets[k:k + 1], corners[k:k + 1]))
        exact = shapely.area(shapely.intersection(sets[k], shapely.Polygon(corners[k])))
        assert got[k] == pytest.approx(exact, rel=1e-9, abs=1e-9)
