"""Properties of the IB21 footprint sensor and identification cones (IB21 Sec. 3.2, Sec. 6, eqs. 50-54)."""

import math

import numpy as np
import pytest
import shapely

from swarmtrack.sensors import footprint as fp
from swarmtrack.sensors.detections import IDENTIFIED_FALSE, UNLABELLED

H = 100.0
T = fp.tan_half()


def test_the_full_opening_convention_gives_an_82_84_m_square_at_100_m():
    assert 2 * H * fp.tan_half(math.pi / 4, "full") == pytest.approx(82.8427, abs=1e-4)
    assert 2 * H * fp.tan_half(math.pi / 4, "half") == pytest.approx(200.0)
    assert fp.FootprintParams().tan_half == T
    with pytest.raises(ValueError, match="convention"):
        fp.tan_half(math.pi / 4, "quarter")
    with pytest.raises(ValueError, match="confusion"):
        fp.FootprintParams(confusion="sometimes")


def test_footprint_is_a_ccw_square_below_the_uav_aligned_with_its_heading():
    xy = np.array([[10.0, 20.0], [-5.0, 300.0], [0.0, 0.0]])
    psi = np.array([0.0, 0.7, -2.2])
    c = fp.footprint_corners(xy, psi, H, T)
    assert c.shape == (3, 4, 2)
    edges = np.roll(c, -1, axis=1) - c
    np.testing.assert_allclose(np.hypot(*edges.T).T, 82.8427, atol=1e-4)
    np.testing.assert_allclose(c.mean(axis=1), xy, atol=1e-12)
    # the first edge (rear right to front right) points along the heading; counter-clockwise: positive area
    np.testing.assert_allclose(np.arctan2(edges[:, 0, 1], edges[:, 0, 0]), psi, atol=1e-12)
    polys = fp.footprint_polygons(c)
    assert all(p.exterior.is_ccw for p in polys)
    np.testing.assert_allclose(shapely.area(polys), 82.8427**2, rtol=1e-6)
    # north: sides along the axes whatever the heading; altitude per UAV
    n = fp.footprint_corners(xy, psi, [100.0, 50.0, 100.0], T, orientation="north")
    np.testing.assert_allclose(n[1], xy[1] + 50 * T * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]), atol=1e-12)


@pytest.mark.slow
def test_inside_agrees_with_shapely_covers_including_points_on_the_edges():
    rng = np.random.default_rng(5)
    xy = rng.uniform(0, 100, (6, 2))
    psi = np.r_[0.0, math.pi / 2, rng.uniform(-math.pi, math.pi, 4)]
    corners = np.concatenate([fp.footprint_corners(xy, psi, H, T),
                              fp.footprint_corners(np.round(xy), psi, 100.0, 0.5, orientation="north")])
    a, b = corners, np.roll(corners, -1, axis=1)
    t = rng.uniform(0, 1, (len(corners), 4, 100, 1))
    on_edges = (a[:, :, None] + t * (b - a)[:, :, None]).reshape(-1, 2)  # on the edge up to rounding
    midpoints = ((a + b) / 2).reshape(-1, 2)  # exactly on the edge for the north squares of integer corners
    nudged = on_edges + rng.choice([-1e-12, 0.0, 1e-12], on_edges.shape)
    points = np.concatenate([rng.uniform(-60, 160, (2000, 2)), on_edges, midpoints, corners.reshape(-1, 2), nudged])
    got = fp.inside(corners, points)
    polys = fp.footprint_polygons(corners)
    expected = shapely.covers(polys[:, None], shapely.points(points)[None, :])
    np.testing.assert_array_equal(got, expected)
    assert got.sum() > 2000  # the test hit the inside, the outside and the edges
    own = fp.inside(corners[6:], midpoints.reshape(12, 4, 2)[6:].reshape(-1, 2)).reshape(6, 6, 4)
    assert own[np.arange(6), np.arange(6)].all()  # exactly on the edge: inside the closed square


def test_cone_axes_are_unit_and_turn_with_the_heading():
    beta, gamma = fp.draw_cones(np.random.default_rng(0), 50)
    assert np.all((beta >= -math.pi / 4) & (beta <= math.pi / 4))
    assert np.all((gamma >= 2 * math.pi / 60) & (gamma <= 3 * math.pi / 60))
    a = fp.cone_axis(np.zeros(50), beta, gamma)
    np.testing.assert_allclose(np.linalg.norm(a, axis=1), 1.0)
    np.testing.assert_allclose(np.arccos(a[:, 2]), gamma)
    b = fp.cone_axis(np.full(50, 0.9), beta, gamma)
    np.testing.assert_allclose(np.arctan2(b[:, 1], b[:, 0]), np.arctan2(a[:, 1], a[:, 0]) + 0.9, atol=1e-12)
    np.testing.assert_allclose(b[:, 2], a[:, 2])


def test_a_uav_right_above_an_object_with_a_vertical_axis_identifies_it():
    obj = np.array([[5.0, 5.0, 0.0], [50.0, 0.0, 0.0]])
    axis = fp.cone_axis([0.3, 0.0], [0.0, 0.0], [0.0, 0.0])  # γ = 0: vertical
    uav = np.array([[5.0, 5.0, H], [5.0, 5.0, -H]])
    labels = fp.identify(uav, obj, axis, [False, False])
    assert labels[0, 0] == 0  # true target 0, above it
    assert labels[1, 0] == UNLABELLED  # one nappe: below the vertex is not in the cone
    assert labels[0, 1] == UNLABELLED  # 45 m off to the side
    # with the paper's tilt (6-9°) the point straight above is outside the 1.5° cone
    tilted = fp.cone_axis([0.3], [0.0], [2 * math.pi / 60])
    assert fp.identify(uav[:1], obj[:1], tilted, [False])[0, 0] == UNLABELLED


@pytest.mark.parametrize("gamma", [2 * math.pi / 60, 2.5 * math.pi / 60, 3 * math.pi / 60])
def test_the_identification_patch_at_100_m_is_2_6_m_wide_and_10_5_to_15_8_m_from_the_object(gamma):
    heading, beta = 0.4, -0.3
    obj = np.array([[200.0, 150.0, 0.0]])
    axis = fp.cone_axis([heading], [beta], [gamma])
    u = np.array([math.cos(heading + beta), math.sin(heading + beta)])  # the patch lies along the axis' azimuth
    g = np.arange(-4, 4, 0.01)  # a window around the expected centre; the patch must not touch its border
    gx, gy = np.meshgrid(g, g)
    centre = obj[0, :2] + H * math.tan(gamma) * u
    uav = np.column_stack([centre[0] + gx.ravel(), centre[1] + gy.ravel(), np.full(gx.size, H)])
    hit = fp.in_cone(uav, obj, axis, fp.APERTURE_TRUE / 2)[:, 0]
    assert not (hit.reshape(gx.shape)[[0, -1]].any() or hit.reshape(gx.shape)[:, [0, -1]].any())
    rel = uav[hit, :2] - obj[0, :2]
    radial, cross = rel @ u, rel @ np.array([-u[1], u[0]])
    lam = fp.APERTURE_TRUE / 2
    assert 10.5 <= radial.mean() <= 15.85
    assert radial.mean() == pytest.approx(H * math.tan(gamma), abs=0.05)
    half_radial = H * (math.tan(gamma + lam) - math.tan(gamma - lam)) / 2
    half_cross = H / math.cos(gamma) * math.tan(lam)
    assert (radial.max() - radial.min()) / 2 == pytest.approx(half_radial, abs=0.03)
    assert (cross.max() - cross.min()) / 2 == pytest.approx(half_cross, abs=0.03)
    assert 2.6 <= half_radial <= 2.7 and 2.6 <= half_cross <= 2.66
    assert abs(cross.mean()) < 0.02


def _uav_at_angle(obj, axis, angle, dist=H):
    """A UAV at ``dist`` from ``obj`` whose direction makes ``angle`` with ``axis`` (tilted in the vertical plane)."""
    az = math.atan2(axis[1], axis[0])
    tilt = math.acos(axis[2]) + angle
    return obj + dist * np.array([math.sin(tilt) * math.cos(az), math.sin(tilt) * math.sin(az), math.cos(tilt)])


@pytest.mark.parametrize(("angle", "outside_inner", "inside_inner"), [
    (0.01, IDENTIFIED_FALSE, 1),  # inside the π/60 cone (half-aperture π/120 = 0.0262)
    (-0.04, 1, IDENTIFIED_FALSE),  # inside π/30 (0.0524), outside π/60: the ring
    (0.06, UNLABELLED, UNLABELLED),  # outside π/30
])
def test_each_decoy_outcome_in_each_ring_with_both_confusion_readings(angle, outside_inner, inside_inner):
    # objects: target 0, decoy 0, target 1, decoy 1 -> J = (0, 1): decoy 1 is confused with target 1
    is_decoy = np.array([False, True, False, True])
    obj = np.array([[0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [200.0, 0.0, 0.0], [300.0, 0.0, 0.0]])
    axis = fp.cone_axis([0.5] * 4, [0.1] * 4, [0.12] * 4)
    uav = _uav_at_angle(obj[3], axis[3], angle)[None, :]
    for confusion, expected in (("outside_inner_cone", outside_inner), ("inside_inner_cone", inside_inner)):
        labels = fp.identify(uav, obj, axis, is_decoy, confusion=confusion)
        assert labels[0, 3] == expected, confusion
    # a true target at the same relative place is identified only inside its π/60 cone
    uav_t = _uav_at_angle(obj[2], axis[2], angle)[None, :]
    assert fp.identify(uav_t, obj, axis, is_decoy)[0, 2] == (1 if abs(angle) < math.pi / 120 else UNLABELLED)


def test_confusion_map_is_l_mod_nt():
    np.testing.assert_array_equal(fp.confusion_map(6, 3), [0, 1, 2, 0, 1, 2])
    np.testing.assert_array_equal(fp.confusion_map(2, 0), [IDENTIFIED_FALSE] * 2)
    drawn = fp.confusion_map(100, 3, np.random.default_rng(1))
    assert set(drawn) == {0, 1, 2}
    # with no true target a would-be confusion is reported as identified false
    obj = np.array([[0.0, 0.0, 0.0]])
    axis = fp.cone_axis([0.0], [0.0], [0.1])
    uav = _uav_at_angle(obj[0], axis[0], 0.04)[None, :]
    assert fp.identify(uav, obj, axis, [True])[0, 0] == IDENTIFIED_FALSE


def test_sense_detects_exactly_the_objects_in_each_footprint_with_bounded_noise():
    rng = np.random.default_rng(21)
    n, m = 4, 300
    uav_xyz = np.column_stack([rng.uniform(100, 300, (n, 2)), np.full(n, H)])
    uav_heading = rng.uniform(-math.pi, math.pi, n)
    obj_xy = rng.uniform(0, 400, (m, 2))
    obj_heading = rng.uniform(-math.pi, math.pi, m)
    is_decoy = rng.uniform(size=m) < 0.5
    beta, gamma = fp.draw_cones(rng, m)
    u = rng.uniform(size=(n, m, 2))
    params = fp.FootprintParams(noise_bound=(5.0, 20.0))
    stamped = uav_xyz[:, :2] + 0.5
    det, source = fp.sense(uav_xyz, uav_heading, obj_xy, obj_heading, is_decoy, beta, gamma, u, params,
                           stamped=stamped)
    corners = fp.footprint_corners(uav_xyz[:, :2], uav_heading, H, T)
    seen = fp.inside(corners, obj_xy)
    assert 0 < len(det) == seen.sum()
    np.testing.assert_array_equal(seen[det.owner, source], True)
    assert np.all(np.diff(det.owner) >= 0)  # UAV-major
    w = det.z - obj_xy[source]
    np.testing.assert_allclose(w, np.array([5.0, 20.0]) * (2 * u[det.owner, source] - 1))
    assert np.all(np.abs(w) <= [5.0, 20.0])
    np.testing.assert_array_equal(det.sensor_pos, stamped[det.owner])
    labels = fp.identify(uav_xyz, np.column_stack([obj_xy, np.zeros(m)]), fp.cone_axis(obj_heading, beta, gamma),
                         is_decoy)
    np.testing.assert_array_equal(det.label, labels[det.owner, source])
    assert det.n_uavs == n


def test_sense_labels_a_target_and_a_decoy_seen_from_inside_their_cones():
    obj_xy = np.array([[50.0, 50.0], [150.0, 50.0], [70.0, 50.0]])  # target 0, decoy 0, target 1
    is_decoy = np.array([False, True, False])
    beta, gamma = np.zeros(3), np.full(3, 0.12)
    axis = fp.cone_axis(np.zeros(3), beta, gamma)
    obj3 = np.column_stack([obj_xy, np.zeros(3)])
    uavs = np.array([_uav_at_angle(obj3[0], axis[0], 0.0, H / math.cos(0.12)),
                     _uav_at_angle(obj3[1], axis[1], 0.04, H / math.cos(0.12 + 0.04))])
    det, source = fp.sense(uavs, np.zeros(2), obj_xy, np.zeros(3), is_decoy, beta, gamma, np.full((2, 3, 2), 0.5))
    got = {(int(o), int(s)): int(lab) for o, s, lab in zip(det.owner, source, det.label, strict=True)}
    # UAV 0 above target 0's patch also sees target 1 (20 m away, unidentified); UAV 1 confuses the decoy with 0
    assert got == {(0, 0): 0, (0, 2): UNLABELLED, (1, 1): 0}
    np.testing.assert_allclose(det.z, obj_xy[source])  # u = 0.5: no noise


def test_sense_with_no_objects_or_nothing_in_view():
    det, source = fp.sense(np.array([[0.0, 0.0, H]]), [0.0], np.zeros((0, 2)), [], np.zeros(0, bool), [], [],
                           np.zeros((1, 0, 2)))
    assert len(det) == 0 and len(source) == 0 and det.z.shape == (0, 2)
    det, _ = fp.sense(np.array([[0.0, 0.0, H]]), [0.0], [[300.0, 300.0]], [0.0], [False], [0.0], [0.1],
                      np.zeros((1, 1, 2)))
    assert len(det) == 0


@pytest.mark.parametrize("confusion, orientation", [("outside_inner_cone", "heading"), ("inside_inner_cone", "north")])
def test_the_compiled_sense_equals_the_reference_bit_for_bit(confusion, orientation):
    """:func:`sense`'s compiled pass gives the very footprints, detections and labels of the numpy functions, on
    random frames, on objects exactly on footprint edges (the exact orientation tests) and seen from inside their
    cones (every label outcome); with the per-run constants derived once (as the world's sensor does), and the
    detections gathered by the compiled pass (:func:`_detections_kernel`) or numpy (:func:`_detections`)."""
    rng = np.random.default_rng(11)
    params = fp.FootprintParams(confusion=confusion, orientation=orientation)
    outcomes = set()
    for trial in range(60):
        n, m = 6, 8
        is_decoy = np.arange(m) >= 4
        beta, gamma = fp.draw_cones(rng, m)
        obj_xy, obj_heading = rng.uniform(0, 400, (m, 2)), rng.uniform(-math.pi, math.pi, m)
        uav_xyz = np.column_stack([rng.uniform(0, 400, (n, 2)), np.full(n, H)])
        psi = rng.uniform(-math.pi, math.pi, n)
        axis = fp.cone_axis(obj_heading, beta, gamma)
        for i in range(3):  # UAVs in (or at the rim of) an object's cones
            k = rng.integers(m)
            tilt = rng.uniform(0, 2 * fp.APERTURE_DECOY_IDENTIFY)
            uav_xyz[i] = _uav_at_angle(np.r_[obj_xy[k], 0.0], axis[k], tilt, H / math.cos(gamma[k] + tilt))
        if trial % 3 == 0:  # objects on the corners and edges of footprints, up to rounding
            c = fp.footprint_corners(uav_xyz[:, :2], psi, uav_xyz[:, 2], params.tan_half, orientation)
            obj_xy[:2] = c[0, :2]
            obj_xy[2] = (c[1, 1] + c[1, 2]) / 2
        u = rng.random((n, m, 2))
        args = (uav_xyz, psi, obj_xy, obj_heading, is_decoy, beta, gamma, u, params)
        ref, src_ref = fp.sense(*args, compiled=False)
        # the compiled pass, deriving the objects' constants itself (sense) or given them and the UAVs' cos ψ, sin ψ
        constants = fp.ObjectConstants.of(params, is_decoy, beta, gamma)
        for fast, src_fast in (fp.sense(*args),
                               fp.sense_frame(uav_xyz, psi, obj_xy, obj_heading, u, params, constants,
                                              uav_trig=(np.cos(psi), np.sin(psi)))):
            np.testing.assert_array_equal(fast.footprint, ref.footprint)
            np.testing.assert_array_equal(src_fast, src_ref)
            np.testing.assert_array_equal(fast.owner, ref.owner)
            np.testing.assert_array_equal(fast.label, ref.label)
            np.testing.assert_array_equal(fast.z, ref.z)
        outcomes |= set(ref.label.tolist())
    assert {UNLABELLED, IDENTIFIED_FALSE, 0, 1}.issubset(outcomes)  # the labels were exercised


def test_sense_frame_is_sense_for_ready_arrays():
    """:func:`sense_frame` (the world's per-frame call, no conversions) gives :func:`sense`'s detections and sources."""
    rng = np.random.default_rng(5)
    params = fp.FootprintParams()
    is_decoy = np.arange(6) >= 3
    beta, gamma = fp.draw_cones(rng, 6)
    constants = fp.ObjectConstants.of(params, is_decoy, beta, gamma)
    for _ in range(20):
        uav_xyz = np.column_stack([rng.uniform(0, 100, (4, 2)), np.full(4, H)])
        psi, obj_xy, obj_heading = rng.uniform(-3, 3, 4), rng.uniform(0, 100, (6, 2)), rng.uniform(-3, 3, 6)
        u, stamped = rng.random((4, 6, 2)), uav_xyz[:, :2] + 0.5
        ref, src_ref = fp.sense(uav_xyz, psi, obj_xy, obj_heading, is_decoy, beta, gamma, u, params, stamped=stamped)
        fast, src = fp.sense_frame(uav_xyz, psi, obj_xy, obj_heading, u, params, constants, stamped=stamped)
        np.testing.assert_array_equal(src, src_ref)
        for name in ("owner", "z", "sensor_pos", "label", "footprint"):
            np.testing.assert_array_equal(getattr(fast, name), getattr(ref, name), err_msg=name)
        assert fast.n_uavs == ref.n_uavs
