"""IB21's set-membership estimator: the guarantee holds on seeded synthetic missions, and breaks (visibly) when the
assumed noise bound is too small; prediction, correction and fusion each do what their equations say."""

import numpy as np
import pytest
import shapely

from swarmtrack.estimation import polygons as pg
from swarmtrack.estimation.setmembership import (
    IDENTIFIED_FALSE,
    UNLABELLED,
    Beliefs,
    containing,
    correct,
    fuse,
    predict,
    uncertainty,
)

AREA = shapely.box(0, 0, 200, 200)
SIDE, SPEED, DT = 60.0, 1.0, 0.5


def walk(rng, pos, heading, steps, dt):
    """Objects at SPEED with a random-walk heading, reflected at the border (never farther than SPEED·dt a step)."""
    for _ in range(steps):
        heading = heading + rng.normal(0, 0.3, len(heading)) * np.sqrt(dt)
        new = pos + SPEED * dt * np.column_stack([np.cos(heading), np.sin(heading)])
        for axis in (0, 1):
            low, high = new[:, axis] < 0, new[:, axis] > 200
            new[low, axis] = -new[low, axis]
            new[high, axis] = 400 - new[high, axis]
            flip = low | high
            heading = np.where(flip, np.pi - heading if axis == 0 else -heading, heading)
        pos = new
    return pos, heading


def mission(seed: int, true_bound: float, assumed_bound: float, duration: float = 40.0, decoys: int = 2):
    """Two UAVs sweep lawnmower paths over the area; 3 targets and some decoys walk; every object inside a footprint
    is detected with box noise; targets are identified at random frames, decoys sometimes confused with a target or
    identified as decoys. Returns (violations, alarms, final beliefs)."""
    rng = np.random.default_rng(seed)
    n_t = 3
    objs = rng.uniform(0, 200, (n_t + decoys, 2))
    heading = rng.uniform(-np.pi, np.pi, n_t + decoys)
    b = Beliefs.start(2, n_t, AREA)
    violations = 0
    for k in range(1, int(duration / DT) + 1):
        t = k * DT
        objs, heading = walk(rng, objs, heading, 5, DT / 5)
        centres = np.array([[30 + (16 * t) % 140, 30 + 60 * ((16 * t) // 140 % 3)],
                            [170 - (16 * t) % 140, 170 - 60 * ((16 * t) // 140 % 3)]])
        predict(b, np.arange(2), t, SPEED, AREA)
        for i, c in enumerate(centres):
            fp = shapely.box(c[0] - SIDE / 2, c[1] - SIDE / 2, c[0] + SIDE / 2, c[1] + SIDE / 2)
            seen = np.flatnonzero(np.all(np.abs(objs - c) <= SIDE / 2, axis=1))
            z = objs[seen] + rng.uniform(-true_bound, true_bound, (len(seen), 2))
            labels = np.full(len(seen), UNLABELLED)
            draw = rng.random(len(seen))
            for m, o in enumerate(seen):
                if o < n_t and draw[m] < 0.3:
                    labels[m] = o
                elif o >= n_t and draw[m] < 0.2:
                    labels[m] = (o - n_t) % n_t  # confused with a target
                elif o >= n_t and draw[m] < 0.4:
                    labels[m] = IDENTIFIED_FALSE
            correct(b, i, pg.inner(fp), z, labels, (assumed_bound, assumed_bound))
        sent = b.copy()
        fuse(b, np.array([0, 1]), np.array([1, 0]), sent)
        violations += int((~containing(b, objs[:n_t], np.arange(n_t))).sum())
    alarms = sum(int(v.sum()) for v in b.alarms.values())
    return violations, alarms, b


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_every_true_target_stays_in_its_sets_while_the_noise_bound_holds(seed):
    violations, _, b = mission(seed, true_bound=5.0, assumed_bound=5.0)
    assert violations == 0
    assert uncertainty(b)["phi"].max() < AREA.area  # and the sets did learn something


@pytest.mark.slow
def test_without_decoys_and_with_a_matched_bound_no_alarm_is_raised():
    violations, alarms, _ = mission(4, true_bound=5.0, assumed_bound=5.0, decoys=0)
    assert violations == 0 and alarms == 0


@pytest.mark.slow
def test_an_underestimated_noise_bound_loses_targets_visibly():
    lost = [mission(seed, true_bound=20.0, assumed_bound=1.0, decoys=0)[:2] for seed in (1, 2, 3)]
    assert sum(v + a for v, a in lost) > 0  # violations found by the monitor, or the estimator's own alarms


def test_prediction_covers_every_point_the_target_can_reach():
    b = Beliefs.start(1, 1, AREA)
    b.unexplored[0] = shapely.box(50, 50, 60, 60)
    predict(b, np.array([0]), 10.0, 2.0, AREA)  # 20 m
    pts = shapely.points(np.random.default_rng(0).uniform(20, 90, (20000, 2)))
    reach = shapely.distance(pts, shapely.box(50, 50, 60, 60)) <= 20.0
    assert shapely.covers(b.unexplored[0], pts)[reach].all()
    exact = 10 * 10 + 4 * 10 * 20 + np.pi * 20 ** 2  # the square dilated by a disc of radius 20
    # the radius grows by 1/cos(3π/64) (polygons.circumscribed: GEOS's arcs), its discs' area by 2.2 %: here 1.3 %
    assert exact < b.unexplored[0].area < exact * 1.015


def test_correction_keeps_the_box_of_a_first_identification_and_clears_the_footprint():
    b = Beliefs.start(1, 2, AREA)
    fp = shapely.box(0, 0, 100, 100)
    correct(b, 0, pg.inner(fp), np.array([[40.0, 40.0], [70.0, 20.0]]), np.array([1, UNLABELLED]), (5.0, 5.0))
    assert b.identified[0, 1].equals(shapely.box(35, 35, 45, 45))  # eq. 23: (Xᵁ ∪ X̄) ∩ B(y), X̄ outside F empty
    assert b.identified[0, 0].is_empty
    assert b.unidentified[0].equals(shapely.box(65, 15, 75, 25))  # eqs. 24-27
    assert b.unexplored[0].area == pytest.approx(200 * 200 - 100 * 100, rel=1e-6)  # eq. 28


def test_fusion_intersects_what_each_uav_has_not_explored():
    b = Beliefs.start(2, 1, AREA)
    correct(b, 0, pg.inner(shapely.box(0, 0, 100, 200)), np.zeros((0, 2)), np.zeros(0, int), (5, 5))
    correct(b, 1, pg.inner(shapely.box(100, 0, 200, 200)), np.zeros((0, 2)), np.zeros(0, int), (5, 5))
    sent = b.copy()
    fuse(b, np.array([0, 1]), np.array([1, 0]), sent)
    assert pg.area(b.unexplored).max() < 1.0  # only the round-off sliver at the seam
    sent_one_way = sent.copy()
    fuse(sent_one_way, np.array([0]), np.array([1]), sent)  # UAV 1 heard nothing: its own sets stay
    assert sent_one_way.unexplored[1].equals(sent.unexplored[1])


def test_the_estimator_updates_at_sharing_times_and_identification_frames_and_fuses_over_links():
    from swarmtrack.estimation.setmembership import SetMembershipEstimator
    from swarmtrack.network.messages import Inbox
    from swarmtrack.sensors import footprint

    est = SetMembershipEstimator(2, 1, AREA, speed=1.0, bound=(5.0, 5.0), period=0.5)
    uavs = np.array([[50.0, 50.0, 100.0], [150.0, 150.0, 100.0]])
    obj = np.array([[55.0, 52.0]])
    links = Inbox(np.array([[False, True], [True, False]]), {})
    for k in range(11):  # 0.5 s at 20 Hz
        t = 0.05 * k
        det, _ = footprint.sense(uavs, np.zeros(2), obj, np.zeros(1), np.zeros(1, bool), np.zeros(1),
                                 np.full(1, 0.1), np.full((2, 1, 2), 0.5))
        out = est.share(t, None, det)
        assert bool(out) == (k in (0, 10))  # shared at 0 and 0.5 s only
        est.fuse(t, det, Inbox(links.links, out))
    assert est.updates.tolist() == [2, 2]  # nothing identified in between: no extra update
    phi = est.sample()["phi_unexplored"]
    side = 2 * 100 * footprint.tan_half(np.pi / 4, "full")
    assert phi[0] == pytest.approx(phi[1]) and phi[0] < 200 * 200 - 2 * side * side + 1.0  # both footprints fused
    region = est.view().region.sets
    assert shapely.covers(region[0], shapely.Point(55.0, 52.0))  # the object seen unidentified stays in X^A
    assert est.containing(obj, np.array([0])).all()


def _three_uavs_sharing_a_base():
    """Three UAVs whose X̄ were fused alike (one object), predicted, and cut by different footprints."""
    b = Beliefs.start(3, 1, AREA)
    correct(b, 0, pg.inner(shapely.box(0, 0, 60, 200)), np.zeros((0, 2)), np.zeros(0, int), (5, 5))
    b.unexplored[1] = b.unexplored[2] = b.unexplored[0]
    b.base[:] = b.unexplored[0]
    b.cut[:] = pg.EMPTY
    predict(b, np.arange(3), 2.0, SPEED, AREA)
    for i, (x, y) in enumerate([(100, 50), (130, 90), (160, 150)]):
        correct(b, i, pg.inner(shapely.box(x - 30, y - 30, x + 30, y + 30)), np.zeros((0, 2)), np.zeros(0, int),
                (5, 5))
    return b


def test_fusing_sets_of_one_lineage_as_one_difference_gives_their_intersection():
    b = _three_uavs_sharing_a_base()
    assert b.base[0] is b.base[1] is b.base[2]  # one dilation served all three
    plain = shapely.intersection_all(b.unexplored)
    sent = b.copy()
    fuse(b, np.array([0, 0]), np.array([1, 2]), sent)
    assert shapely.symmetric_difference(b.unexplored[0], plain).area < 1e-6
    pts = shapely.points(np.random.default_rng(0).uniform(0, 200, (20000, 2)))
    assert (shapely.covers(b.unexplored[0], pts) | ~shapely.covers(plain, pts)).all()


def test_uavs_with_the_same_neighbourhood_share_one_fusion_result():
    b = _three_uavs_sharing_a_base()
    sent = b.copy()
    alone = b.copy()
    fuse(b, np.array([0, 0, 1, 1, 2, 2]), np.array([1, 2, 0, 2, 0, 1]), sent)
    assert b.unexplored[0] is b.unexplored[1] is b.unexplored[2]
    fuse(alone, np.array([2, 2]), np.array([0, 1]), sent)  # computed on its own
    assert shapely.symmetric_difference(alone.unexplored[2], b.unexplored[2]).area < 1e-6


def test_within_per_part_equals_the_overlay_on_the_whole_bounding_box():
    rng = np.random.default_rng(3)
    small = shapely.union_all(shapely.buffer(shapely.points(rng.uniform(0, 200, (6, 2))), 4.0))
    big = shapely.difference(AREA, shapely.union_all(shapely.buffer(shapely.points(rng.uniform(0, 200, (30, 2))),
                                                                    15.0)))
    fast = pg.within(small, big, shapely.box(0, 0, 50, 50))
    reference = shapely.intersection(small, shapely.union(big, shapely.box(0, 0, 50, 50)))
    assert fast.is_valid and shapely.difference(fast, small).area < 1e-12
    assert_outer_and_close(fast, reference)


def test_fusing_sets_of_two_lineages_gives_their_intersection_and_reuses_the_bases_intersection():
    b = _three_uavs_sharing_a_base()
    b.base[2] = b.unexplored[2] = shapely.difference(b.unexplored[2], shapely.box(0, 150, 40, 200))  # own lineage
    b.cut[2] = pg.EMPTY
    plain = shapely.intersection_all(b.unexplored)
    sent = b.copy()
    fuse(b, np.array([0, 0, 1, 1]), np.array([1, 2, 0, 2]), sent)  # UAVs 0 and 1: neighbourhoods differ in order
    for i in (0, 1):
        assert_outer_and_close(b.unexplored[i], plain)


def assert_outer_and_close(got, exact, margin=3 * pg.LOOSEN):
    """``got`` ⊇ ``exact`` (up to round-off) and no farther than ``margin`` from it: a loosened intersection."""
    assert shapely.difference(exact, got).area < 1e-9
    assert shapely.hausdorff_distance(got, exact) <= margin + 1e-9
    assert shapely.difference(got, exact).area <= margin * shapely.length(got) + 1e-9


def test_round_intersections_reuse_chains_and_equal_intersection_all_of_the_ordered_sets():
    """Each chain in the canonical order (by area, smallest first: a function of the sets alone), every prefix kept
    for the round."""
    from swarmtrack.estimation.setmembership import _Meets

    rng = np.random.default_rng(5)
    sets = [shapely.difference(AREA, shapely.union_all(shapely.buffer(shapely.points(rng.uniform(0, 200, (8, 2))),
                                                                       12.0))) for _ in range(5)]
    base = np.empty(5, dtype=object)
    base[:] = sorted(sets, key=lambda s: s.area)  # row k: the k-th smallest
    groups = [np.array(g) for g in ([0, 1, 2], [1, 0, 2, 3], [2, 1, 0, 3, 4], [4, 3], [3])]
    meets = _Meets()
    pg.OPS.clear()
    results = [meets.meet(list(base[g[::-1]])) for g in groups]  # the argument's order does not matter
    assert pg.OPS["intersection"] == 2 + 1 + 1 + 1  # {0,1,2} once; 3 and then 4 on top; {3,4} alone
    for g, got in zip(groups, results, strict=True):
        ordered = sorted(g.tolist())
        chain = [base[e] if k == 0 else pg.loosen(base[e]) for k, e in enumerate(ordered)]
        want = shapely.intersection_all(chain)  # the same overlay chain
        assert shapely.equals_exact(got, want, tolerance=0.0)
        assert_outer_and_close(got, shapely.intersection_all(base[g]))
        assert shapely.equals_identical(_Meets().meet(list(base[g])), got)  # a UAV alone: the same bits


def test_a_loosened_set_contains_the_set_with_its_edges_apart():
    rng = np.random.default_rng(6)
    a = shapely.difference(AREA, shapely.union_all(shapely.buffer(shapely.points(rng.uniform(0, 200, (8, 2))),
                                                                   12.0, quad_segs=3)))
    loose = pg.loosen(a)
    assert loose.is_valid and shapely.contains(loose, a)
    assert shapely.hausdorff_distance(loose, a) <= 3 * pg.LOOSEN
    assert shapely.distance(shapely.boundary(loose), shapely.boundary(a)) > 0.5 * pg.LOOSEN


def _random_blobs(rng, n, radius, quad_segs=8):
    return shapely.union_all(shapely.buffer(shapely.points(rng.uniform(0, 200, (n, 2))), radius, quad_segs=quad_segs))


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(6))
def test_within_on_sets_loosened_once_contains_the_exact_intersection(seed):
    rng = np.random.default_rng(seed)
    base = _random_blobs(rng, 8, 15.0)
    cut = shapely.box(*rng.uniform(0, 200, 2), *rng.uniform(100, 200, 2))
    small = shapely.union_all([shapely.difference(base, cut), _random_blobs(rng, 3, 5.0)])
    big = [shapely.difference(base, shapely.box(*(c := rng.uniform(0, 180, 2)), *(c + 60))), _random_blobs(rng, 4, 9.0)]
    exact = shapely.intersection(small, shapely.union_all(big))
    loose: dict = {}
    got = pg.within(small, *big, loose=loose)
    assert got.is_valid and shapely.difference(got, small).area < 1e-12
    assert_outer_and_close(got, exact)
    pts = shapely.points(rng.uniform(0, 200, (20000, 2)))
    assert (shapely.covers(got, pts) | ~shapely.covers(exact, pts)).all()
    assert pg.within(small, *big, loose=loose).equals(got)  # the loosened sets reused


def test_identity_shortcuts_return_the_same_object_and_are_exact():
    a, far, near = shapely.box(0, 0, 10, 10), shapely.box(50, 50, 60, 60), shapely.box(5, 5, 20, 20)
    assert pg.union_all([a, a, pg.EMPTY]) is a  # A ∪ A = A
    assert pg.remove(a, far) is a  # A \ F = A when they do not meet
    got = pg.remove(np.array([a, a], dtype=object), np.array([far, near], dtype=object))
    assert got[0] is a and got[1].equals(shapely.difference(a, near))
    assert pg.within(a, near, a) is a  # a ∩ (near ∪ a) = a


def test_fusion_of_near_equal_sets_contains_the_exact_fusion():
    """Eqs. 34, 36 with the loosened candidate union and holders, against the plain overlays."""
    from swarmtrack.estimation.setmembership import _candidate, _held_by_all

    rng = np.random.default_rng(11)
    for _ in range(5):
        base = _random_blobs(rng, 6, 12.0)
        xs = np.array([shapely.difference(base, shapely.box(*(c := rng.uniform(0, 170, 2)), *(c + 80)))
                       for _ in range(4)], dtype=object)
        us = np.array([_random_blobs(rng, 2, 6.0) for _ in range(4)], dtype=object)
        holders = [[xs[k], us[k]] for k in range(4)]
        loose: dict = {}
        got = _held_by_all(_candidate(xs, loose), holders, loose)
        exact = shapely.intersection_all([shapely.union_all(xs)] + [shapely.union_all(h) for h in holders])
        assert_outer_and_close(got, exact, margin=5 * pg.LOOSEN)
