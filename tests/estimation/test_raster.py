"""Raster sets (grids of distance lower bounds): every operation keeps each cell's value at most the exact distance
from its centre to the exact set (so the reported set is an outer approximation), the outer area is at least the
exact area and close to it, and a point of the exact set always passes the guarantee's check."""

import numpy as np
import pytest
import shapely

from swarmtrack.control.sm_mpc_raster import edge_lines
from swarmtrack.estimation import raster as rs

AREA = shapely.box(0, 0, 200, 200)
GRID = rs.Grid.over(AREA, 1.0)


def exact_distances(grid: rs.Grid, geom) -> np.ndarray:
    xx, yy = np.meshgrid(grid.xs, grid.ys)
    if geom.is_empty:
        return np.full(xx.shape, np.inf)
    return shapely.distance(shapely.points(xx.ravel(), yy.ravel()), geom).reshape(xx.shape)


def assert_lower_bound(grid: rs.Grid, f: rs.Field, geom):
    """On every cell of the grid (stored or implied), the value is at most the exact distance."""
    v = rs.values(grid, f, (0, 0, grid.ny, grid.nx))
    assert (v <= exact_distances(grid, geom) + 1e-9).all()


def rotated_square(rng, side):
    cx, cy = rng.uniform(20, 180, 2)
    a = rng.uniform(0, np.pi)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    return np.array([cx, cy]) + (np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * side / 2) @ rot.T


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 2])
def test_sweeps_of_dilations_and_removals_stay_below_the_exact_distance(seed):
    rng = np.random.default_rng(seed)
    f, exact = rs.full(GRID), AREA
    for _ in range(6):
        corners = rotated_square(rng, 60.0)
        f, exact = rs.remove(GRID, f, corners), exact.difference(shapely.Polygon(corners))
        r = rng.uniform(0.3, 4.0)
        f, exact = rs.dilate(GRID, f, r), exact.buffer(r, quad_segs=64).intersection(AREA)
        assert_lower_bound(GRID, f, exact)
    assert exact.area <= rs.area(GRID, f) <= exact.area + exact.length * GRID.slack  # outer, and close


def test_a_shorter_dilation_would_break_the_bound():
    """The check above can fail: dilating the raster less than the exact set is caught."""
    f = rs.box(GRID, (50, 50, 60, 60))
    short = rs.dilate(GRID, f, 2.0)
    exact = shapely.box(50, 50, 60, 60).buffer(3.0, quad_segs=64)
    v = rs.values(GRID, short, (0, 0, GRID.ny, GRID.nx))
    assert (v > exact_distances(GRID, exact) + 1e-9).any()


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3, 4])
def test_unions_intersections_and_meets_of_boxes_and_blobs_stay_below_the_exact_distance(seed):
    rng = np.random.default_rng(seed)
    geoms = [shapely.box(*(lambda x, y, w, h: (x, y, x + w, y + h))(*rng.uniform(10, 150, 2), *rng.uniform(3, 40, 2)))
             for _ in range(4)]
    fields = [rs.box(GRID, g.bounds) for g in geoms]
    blob = shapely.Point(*rng.uniform(60, 140, 2)).buffer(40.0, quad_segs=64)
    fb = rs.dilate(GRID, rs.box(GRID, shapely.Point(blob.centroid).buffer(0.01).bounds), 40.0)
    assert_lower_bound(GRID, fb, blob)
    u = rs.union(GRID, fields[:2])
    assert_lower_bound(GRID, u, shapely.union_all(geoms[:2]))
    m = rs.meet(GRID, u, fields[2], fb)
    assert_lower_bound(GRID, m, shapely.union_all(geoms[:2]).intersection(geoms[2].union(blob)))
    held = rs.held_by_all(GRID, u, [[fields[2], fb], [fields[3], fb]])
    exact = shapely.union_all(geoms[:2]).intersection(geoms[2].union(blob)).intersection(geoms[3].union(blob))
    assert_lower_bound(GRID, held, exact)
    both = rs.intersect_all(GRID, [fb, u])
    assert_lower_bound(GRID, both, blob.intersection(shapely.union_all(geoms[:2])))


@pytest.mark.slow
def test_a_box_is_exact_at_the_centres_and_its_outer_area_is_close():
    f = rs.box(GRID, (50.2, 60.7, 60.2, 70.7))
    g = shapely.box(50.2, 60.7, 60.2, 70.7)
    i0, j0, i1, j1 = f.window
    assert np.allclose(f.data, exact_distances(GRID, g)[i0:i1, j0:j1], atol=1e-9)  # exact where stored
    assert_lower_bound(GRID, f, g)  # and below it where implied
    assert g.area <= rs.area(GRID, f) <= g.area + g.length * GRID.slack


def test_every_point_of_the_exact_set_passes_the_guarantee_check():
    rng = np.random.default_rng(5)
    f, exact = rs.full(GRID), AREA
    for _ in range(4):
        corners = rotated_square(rng, 50.0)
        f, exact = rs.dilate(GRID, rs.remove(GRID, f, corners), 1.3), \
            exact.difference(shapely.Polygon(corners)).buffer(1.3, quad_segs=64).intersection(AREA)
    pts = rng.uniform(0, 200, (20000, 2))
    inside = shapely.covers(exact, shapely.points(pts))
    assert rs.holds(GRID, f, pts)[inside].all()
    # and it is not much more: the removal bounds by the footprint's depth only (seams of overlapping sweeps stay
    # loose), measured: 12 of 2,642 points farther than 2 m pass
    far = exact_distances_at(pts, exact) > 2.0
    assert rs.holds(GRID, f, pts)[far].mean() < 0.01
    assert rs.area(GRID, f) < exact.area * 1.01


def exact_distances_at(pts, geom):
    return shapely.distance(shapely.points(pts), geom)


def test_removing_a_footprint_that_misses_returns_the_same_object():
    f = rs.box(GRID, (10, 10, 20, 20))
    assert rs.remove(GRID, f, np.array([[100, 100], [150, 100], [150, 150], [100, 150]])) is f


def test_an_area_that_is_not_the_grid_rectangle_clips_dilations():
    tri = shapely.Polygon([(0, 0), (100, 0), (0, 100)])
    grid = rs.Grid.over(tri, 1.0)
    f = rs.dilate(grid, rs.box(grid, (44, 44, 49, 49)), 10.0)
    exact = shapely.box(44, 44, 49, 49).buffer(10.0, quad_segs=64).intersection(tri)
    assert_lower_bound(grid, f, exact)
    assert rs.area(grid, f) < shapely.box(44, 44, 49, 49).buffer(10.0).area * 0.85  # the part beyond X0 is gone
    assert rs.area(grid, rs.full(grid)) == pytest.approx(tri.area, rel=0.02)


def test_cell_area_is_the_square_less_the_disc_about_its_centre():
    c = 2.0
    v = np.array([-1.0, 0.0, 0.5, 1.2, 1.4, 2.0])
    pts = np.random.default_rng(6).uniform(-1, 1, (200000, 2))
    mc = [(np.hypot(pts[:, 0], pts[:, 1]) >= max(x, 0)).mean() * c * c for x in v]
    assert np.allclose(rs.cell_area(v, c), mc, atol=0.02)


def test_a_bad_cell_size_is_refused():
    with pytest.raises(ValueError, match="cell"):
        rs.Grid.over(AREA, 0.0)


def test_the_compiled_fill_equals_its_reference_beyond_the_window():
    f = rs.dilate(GRID, rs.union(GRID, [rs.box(GRID, (40, 40, 52, 47)), rs.box(GRID, (60, 45, 66, 70))]), 2.5)
    win = (0, 0, 120, 110)
    got = rs.values(GRID, f, win)
    want = rs._beyond(GRID, f, win)
    i0, j0, i1, j1 = f.window
    want[i0:i1, j0:j1] = f.data
    assert np.allclose(got, want, rtol=0, atol=1e-9)
    assert np.allclose(rs._support(GRID, f), rs.support_reference(GRID, f), rtol=0, atol=1e-9)


def test_a_minimum_skipping_cells_gives_the_minimum_with_the_full_values_where_it_counts():
    rng = np.random.default_rng(7)
    f = rs.dilate(GRID, rs.union(GRID, [rs.box(GRID, (40, 40, 52, 47)), rs.box(GRID, (60, 45, 66, 70))]), 2.5)
    win = (0, 0, 120, 110)
    acc = rng.uniform(0.0, 60.0, (120, 110))
    floor = rng.uniform(0.0, 60.0, (120, 110))
    want = np.minimum(acc, rs.values(GRID, f, win))
    plain = acc.copy()
    rs.lower(GRID, plain, win, [f])
    assert np.array_equal(plain, want)
    skipped = acc.copy()
    rs.lower(GRID, skipped, win, [f], floor)
    assert np.array_equal(np.maximum(skipped, floor), np.maximum(want, floor))
    assert (skipped != want).any()  # the floor did skip cells


def test_the_compiled_removal_and_area_equal_their_readable_references():
    rng = np.random.default_rng(8)
    f = rs.dilate(GRID, rs.box(GRID, (60, 60, 100, 90)), 3.0)
    corners = rotated_square(rng, 40.0) * 0.3 + 55.0
    got = rs.remove(GRID, f, corners)
    d = rs.depth(GRID, corners, f.window) - rs.DELTA
    assert np.array_equal(rs.values(GRID, got, f.window), np.maximum(f.data, d))
    assert rs.area(GRID, got) == pytest.approx(rs.cell_area(got.data, GRID.cell).sum(), rel=1e-12)


def test_the_centroid_is_the_mean_centre_of_the_member_cells():
    rng = np.random.default_rng(3)
    f = rs.remove(GRID, rs.dilate(GRID, rs.box(GRID, (60, 60, 100, 90)), 3.0), rotated_square(rng, 40.0) * 0.3 + 60.0)
    rows, cols = np.nonzero(rs.members(GRID, f))
    want = [GRID.x0 + (f.j0 + cols + 0.5).mean() * GRID.cell, GRID.y0 + (f.i0 + rows + 0.5).mean() * GRID.cell]
    assert rs.centroid(GRID, f) == pytest.approx(want, rel=1e-12)
    assert np.isnan(rs.centroid(GRID, rs.EMPTY)).all()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_compiled_redistancing_equals_its_readable_reference(seed):
    rng = np.random.default_rng(seed)
    X0 = rs.full(GRID)
    blob = rs.dilate(GRID, rs.box(GRID, (60, 61, 97, 90)), 2.5)  # a window whose sides are not whole blocks
    for f in (X0, blob):
        for _ in range(3):  # seams between footprints, and values below 0 where dilations went on
            f = rs.dilate(GRID, rs.remove(GRID, f, rotated_square(rng, 50.0)), 1.5)
        for block in (3, 4):
            got, ref = rs.redistance(GRID, f, block), rs.redistance_reference(GRID, f, block)
            assert got.window == ref.window and np.array_equal(got.data, ref.data)
            assert (got is f) == (ref is f)
    assert rs.redistance(GRID, X0) is X0  # every block a member: nothing to raise


def test_footprints_prepared_together_equal_those_prepared_one_by_one():
    rng = np.random.default_rng(5)
    corners = np.stack([rotated_square(rng, s) for s in (30.0, 82.8, 50.0)])
    corners[1] = corners[1, ::-1]  # either order
    lines = edge_lines(corners)  # the planner's own compiled normals, written apart from these
    for F, c, line in zip(rs.convex_all(GRID, corners), corners, lines, strict=True):
        one = rs.convex(GRID, c)
        assert np.array_equal(F.normals, one.normals) and (F.i0, F.j0, F.i1, F.j1) == (one.i0, one.j0, one.i1, one.j1)
        assert np.array_equal(F.normals, line[:, 2:]) and np.array_equal(F.corners, line[:, :2])
        cells = [GRID.span(c[:, 1].min(), c[:, 1].max(), 0), GRID.span(c[:, 0].min(), c[:, 0].max(), 1)]
        assert (F.i0, F.i1, F.j0, F.j1) == (*cells[0], *cells[1])


def test_lowering_by_several_fields_at_once_gives_the_minimum_of_their_values():
    rng = np.random.default_rng(9)
    fields = [rs.dilate(GRID, rs.box(GRID, b), r) for b, r in (((40, 40, 52, 47), 2.5), ((90, 45, 96, 70), 1.0),
                                                              ((20, 150, 30, 160), 0.0))]
    win = (0, 0, 180, 120)
    acc = np.where(rng.random((180, 120)) < 0.5, np.inf, rng.uniform(0.0, 60.0, (180, 120)))
    want = acc.copy()
    for f in fields:
        want = np.minimum(want, rs.values(GRID, f, win))
    got = acc.copy()
    rs.lower(GRID, got, win, fields)
    assert np.array_equal(got, want)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_block_distances_equal_scipys_exact_transform(seed):
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    for shape, share in (((11, 11), 0.1), ((7, 30), 0.02), ((40, 40), 0.3), ((1, 5), 0.5), ((5, 1), 0.3),
                         ((100, 100), 0.97), ((100, 100), 0.001), ((63, 17), 0.5), ((1, 1), 1.0)):
        coarse = rng.random(shape) < share
        coarse[rng.integers(shape[0]), rng.integers(shape[1])] = True  # at least one member
        assert np.array_equal(rs.block_distances(coarse), ndimage.distance_transform_edt(~coarse))


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_whether_sets_meet_is_whether_their_meet_has_a_member_cell(seed):
    rng = np.random.default_rng(seed)
    boxes = [rs.box(GRID, (*xy, *(xy + rng.uniform(3, 30, 2)))) for xy in rng.uniform(10, 160, (4, 2))]
    small = rs.dilate(GRID, boxes[0], rng.uniform(0.5, 6.0))  # untrimmed: members may lie off its core
    for holders in ([boxes[1]], [boxes[1], boxes[2]], [rs.dilate(GRID, boxes[3], 20.0)], [rs.EMPTY]):
        met = rs.meet(GRID, small, *holders)
        assert rs.meets(GRID, small, *holders) == (not met.is_empty and bool(rs.members(GRID, met).any()))
