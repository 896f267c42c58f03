"""IB21's estimator on raster sets: the guarantee holds on seeded synthetic missions run side by side with the polygon
estimator (same draws), its uncertainty stays close to the polygons', an under-estimated bound is seen, and the
estimator class shares, fuses and answers the monitor as the polygon one does."""

import numpy as np
import pytest
import shapely

from swarmtrack.estimation import polygons as pg
from swarmtrack.estimation import raster as rs
from swarmtrack.estimation import setmembership as poly
from swarmtrack.estimation import setmembership_raster as ras
from swarmtrack.sensors.detections import IDENTIFIED_FALSE, UNLABELLED

AREA = shapely.box(0, 0, 200, 200)
GRID = rs.Grid.over(AREA, 1.0)
SIDE, SPEED, DT, N_T = 60.0, 1.0, 0.5, 3


def mission(seed: int, true_bound: float, assumed_bound: float, duration: float = 30.0, decoys: int = 2):
    """Two UAVs sweep lawnmower paths; targets and decoys walk at SPEED with a random-walk heading (reflected at the
    border); every object in a footprint is detected with box noise, targets identified at random frames, decoys
    sometimes confused or identified as decoys. Both estimators get the same frames. Returns (raster violations,
    raster alarms, polygon violations, raster beliefs, polygon beliefs)."""
    rng = np.random.default_rng(seed)
    objs = rng.uniform(0, 200, (N_T + decoys, 2))
    heading = rng.uniform(-np.pi, np.pi, N_T + decoys)
    rb, pb = ras.RasterBeliefs.start(GRID, 2, N_T), poly.Beliefs.start(2, N_T, AREA)
    r_bad = p_bad = 0
    for k in range(1, int(duration / DT) + 1):
        t = k * DT
        for _ in range(5):  # objects move at most SPEED·DT/5 per sub-step
            heading = heading + rng.normal(0, 0.3, len(heading)) * np.sqrt(DT / 5)
            objs = objs + SPEED * DT / 5 * np.column_stack([np.cos(heading), np.sin(heading)])
            out = (objs < 0) | (objs > 200)
            objs = np.where(objs < 0, -objs, np.where(objs > 200, 400 - objs, objs))
            heading = np.where(out[:, 0], np.pi - heading, heading)
            heading = np.where(out[:, 1], -heading, heading)
        centres = np.array([[30 + (16 * t) % 140, 30 + 60 * ((16 * t) // 140 % 3)],
                            [170 - (16 * t) % 140, 170 - 60 * ((16 * t) // 140 % 3)]])
        ras.predict(rb, np.arange(2), t, SPEED)
        poly.predict(pb, np.arange(2), t, SPEED, AREA)
        for i, c in enumerate(centres):
            corners = c + np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * SIDE / 2
            seen = np.flatnonzero(np.all(np.abs(objs - c) <= SIDE / 2, axis=1))
            z = objs[seen] + rng.uniform(-true_bound, true_bound, (len(seen), 2))
            labels = np.full(len(seen), UNLABELLED)
            draw = rng.random(len(seen))
            for m, o in enumerate(seen):
                if o < N_T and draw[m] < 0.3:
                    labels[m] = o
                elif o >= N_T and draw[m] < 0.2:
                    labels[m] = (o - N_T) % N_T  # confused with a target
                elif o >= N_T and draw[m] < 0.4:
                    labels[m] = IDENTIFIED_FALSE
            ras.correct(rb, i, corners, z, labels, (assumed_bound, assumed_bound))
            poly.correct(pb, i, pg.inner(shapely.Polygon(corners)), z, labels, (assumed_bound, assumed_bound))
        ras.fuse(rb, np.array([0, 1]), np.array([1, 0]), rb.copy())
        ras.redistance(rb)
        poly.fuse(pb, np.array([0, 1]), np.array([1, 0]), pb.copy())
        r_bad += int((~ras.containing(rb, objs[:N_T], np.arange(N_T))).sum())
        p_bad += int((~poly.containing(pb, objs[:N_T], np.arange(N_T))).sum())
    alarms = sum(int(v.sum()) for v in rb.alarms.values())
    return r_bad, alarms, p_bad, rb, pb


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_every_true_target_stays_in_its_raster_sets_and_phi_stays_near_the_polygons(seed):
    r_bad, _, p_bad, rb, pb = mission(seed, true_bound=5.0, assumed_bound=5.0)
    assert r_bad == 0 and p_bad == 0
    phi_r = ras.uncertainty(rb, ras.aggregated(rb))["phi"]
    phi_p = poly.uncertainty(pb)["phi"]
    assert (phi_r < AREA.area).all()  # the sets did learn something
    assert np.allclose(phi_r, phi_p, rtol=0.15)  # and about as much as the polygons (measured: 7-8 % above)


@pytest.mark.slow
def test_an_underestimated_noise_bound_loses_targets_visibly_on_raster_sets():
    lost = [mission(seed, true_bound=20.0, assumed_bound=1.0, decoys=0)[:2] for seed in (1, 2)]
    assert sum(v + a for v, a in lost) > 0


def test_correction_keeps_the_box_of_a_first_identification_and_clears_the_footprint():
    b = ras.RasterBeliefs.start(GRID, 1, 2)
    corners = np.array([[0, 0], [100, 0], [100, 100], [0, 100]], dtype=float)
    ras.correct(b, 0, corners, np.array([[40.0, 40.0], [70.0, 20.0]]), np.array([1, UNLABELLED]), (5.0, 5.0))
    assert b.identified[0, 0].is_empty
    assert 100 <= rs.area(GRID, b.identified[0, 1]) < 100 + 40 * GRID.slack  # the box (35, 35, 45, 45), outer
    assert rs.holds(GRID, b.identified[0, 1], np.array([[35.0, 35.0], [45.0, 45.0]])).all()
    assert 100 <= rs.area(GRID, b.unidentified[0]) < 100 + 40 * GRID.slack
    assert rs.area(GRID, b.unexplored[0]) == pytest.approx(200 * 200 - 100 * 100, abs=200 * GRID.slack)


def test_the_raster_estimator_updates_and_fuses_over_links_like_the_polygon_one():
    from swarmtrack.network.messages import Inbox
    from swarmtrack.sensors import footprint

    ests = [poly.SetMembershipEstimator(2, 1, AREA, speed=1.0, bound=(5.0, 5.0), period=0.5),
            ras.RasterSetMembershipEstimator(2, 1, AREA, speed=1.0, bound=(5.0, 5.0), period=0.5, cell=1.0)]
    uavs = np.array([[50.0, 50.0, 100.0], [150.0, 150.0, 100.0]])
    obj = np.array([[55.0, 52.0]])
    links = np.array([[False, True], [True, False]])
    for k in range(11):
        det, _ = footprint.sense(uavs, np.zeros(2), obj, np.zeros(1), np.zeros(1, bool), np.zeros(1),
                                 np.full(1, 0.1), np.full((2, 1, 2), 0.5))
        for est in ests:
            out = est.share(0.05 * k, None, det)
            assert bool(out) == (k in (0, 10))
            est.fuse(0.05 * k, det, Inbox(links, out))
    p, r = (est.sample() for est in ests)
    assert ests[1].updates.tolist() == [2, 2]
    assert r["phi_unexplored"][0] == pytest.approx(r["phi_unexplored"][1])  # both footprints fused
    edges = 2 * 4 * 2 * 100 * footprint.tan_half(np.pi / 4, "full")  # the two footprints' edges (m)
    assert (p["phi_unexplored"] <= r["phi_unexplored"]).all()  # outer
    assert (r["phi_unexplored"] <= p["phi_unexplored"] + edges * GRID.slack).all()  # and close
    assert r["phi"] == pytest.approx(p["phi"], rel=0.02)
    assert ests[1].containing(obj, np.array([0])).all()
    assert rs.holds(GRID, ests[1].view().region.sets[0], obj).all()  # the object seen unidentified stays in X^A
    assert np.allclose(ests[1].view().state[:, :2], ests[0].view().state[:, :2], atol=1.0)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_frame_without_detections_removes_the_footprint_from_every_set_as_the_full_correction_does(seed):
    rb = mission(seed, true_bound=5.0, assumed_bound=5.0, duration=10.0)[3]
    assert any(not f.is_empty for f in rb.identified[0]) or not rb.unidentified[0].is_empty  # something to cut
    corners = np.array([[40.0, 40.0], [130.0, 50.0], [120.0, 140.0], [30.0, 130.0]])
    quick, full = rb.copy(), rb.copy()
    ras.correct(quick, 0, corners, np.zeros((0, 2)), np.zeros(0, dtype=int), (5.0, 5.0))
    # a decoy identified as a decoy: eqs. 17-29 take nothing from it, so the full path gives the same sets
    ras.correct(full, 0, corners, np.array([[80.0, 90.0]]), np.array([IDENTIFIED_FALSE]), (5.0, 5.0))
    for a, b in [(quick.unexplored[0], full.unexplored[0]), (quick.unidentified[0], full.unidentified[0]),
                 *zip(quick.identified[0], full.identified[0], strict=True)]:
        assert a.window == b.window and np.array_equal(a.data, b.data)
    assert quick.unexplored[0] is not rb.unexplored[0]  # the footprint did cut X̄
