"""W20 Ch. 4's error budget in the camera (issue 27): the marker noise's growth, the servos, and the imperfect
sensing path (an exact camera is the ideal one; a mount or tilt error displaces what the UAV infers)."""

import numpy as np

from swarmtrack.sensors import camera


def test_marker_noise_is_sigma_head_on_at_the_reference_range_and_grows_with_distance_and_view_angle():
    h = 1.5
    pc = np.array([[0.0, 0.0, 1.5], [0.0, 0.0, 3.0]])
    drop = np.array([h, h])  # the second: the same height, seen obliquely at twice the distance (cos α = 0.5)
    np.testing.assert_allclose(camera.marker_sigma(pc, drop, 0.03, 1.5, 0.0, 0.0), [0.03, 0.03])
    np.testing.assert_allclose(camera.marker_sigma(pc, drop, 0.03, 1.5, 1.0, 0.0), [0.03, 0.06])
    np.testing.assert_allclose(camera.marker_sigma(pc, drop, 0.03, 1.5, 0.0, 1.0), [0.03, 0.06])
    np.testing.assert_allclose(camera.marker_sigma(pc, drop, 0.03, 1.5, 1.0, 1.0), [0.03, 0.12])


def test_a_servo_holds_inside_its_dead_band_and_turns_at_most_at_its_speed():
    db, speed, dt = np.radians(0.5), np.radians(300.0), 1 / 30
    a = np.zeros(4)
    cmd = np.radians([0.2, -0.24, 3.0, 30.0])
    got = camera.servo_step(a, cmd, dt, db, speed)
    np.testing.assert_allclose(got[:2], 0.0)  # within ±0.25°: holds
    np.testing.assert_allclose(got[2], cmd[2])  # 3° in one frame is within its 10° per frame: reaches it
    np.testing.assert_allclose(got[3], speed * dt)  # 30° is not: rate limited
    # across ±π it turns the short way
    np.testing.assert_allclose(camera.servo_step(np.array([np.pi - 0.01]), np.array([-np.pi + 0.01]), dt, 0.0,
                                                 speed), [-np.pi + 0.01], atol=1e-12)
    # an instant servo without a dead band is its command
    np.testing.assert_allclose(camera.servo_step(a, cmd, dt, 0.0, np.inf), cmd)


def _scene(rng, n=4):
    uavs = np.array([[-1.2, -1.2], [1.2, -1.2], [0.0, 1.3], [0.4, 0.2]])[:n]
    objects = np.array([[0.1, -0.2]])
    aim = objects + rng.normal(0, 0.05, (n, 2))
    return uavs, objects, aim


def test_an_exact_imperfect_camera_senses_as_the_ideal_one():
    rng = np.random.default_rng(3)
    uavs, objects, aim = _scene(rng)
    stamped = uavs + rng.normal(0, 1e-3, uavs.shape)
    noise = rng.standard_normal((len(uavs), 1, 2))
    ideal, src = camera.sense(objects, uavs, stamped, 1.5, aim, (0.4, 0.3), 0.03, noise)
    ang = camera.angles(stamped, 1.5, aim)
    exact = camera.Pointing(tuple(a[None] for a in ang), tuple(a[None] for a in ang), np.zeros((1, len(uavs), 3)))
    det, labels = camera.sense_imperfect(objects[None], uavs[None], stamped[None], 1.5, exact, (0.4, 0.3), 0.03,
                                         noise[None], np.arange(1)[None])
    np.testing.assert_array_equal(det.owner, ideal.owner)
    np.testing.assert_array_equal(labels, src)
    np.testing.assert_allclose(det.z, ideal.z, atol=1e-12)
    np.testing.assert_allclose(det.frame, ideal.frame, atol=1e-12)


def test_a_mount_offset_shifts_the_inferred_target_by_minus_the_offset():
    """The UAV believes its camera sits on its body; one ``δ`` to the side, it infers the target ``−δ`` away."""
    rng = np.random.default_rng(4)
    uavs, objects, aim = _scene(rng)
    ang = tuple(a[None] for a in camera.angles(uavs, 1.5, aim))
    offset = np.zeros((1, len(uavs), 3))
    offset[..., :2] = rng.normal(0, 0.005, (len(uavs), 2))
    det, _ = camera.sense_imperfect(objects[None], uavs[None], uavs[None], 1.5, camera.Pointing(ang, ang, offset),
                                    (0.4, 0.3), 1e-9, np.zeros((1, len(uavs), 1, 2)), np.arange(1)[None])
    inferred = camera.invert(det.frame, det.z)
    np.testing.assert_allclose(inferred, objects - offset[0, det.owner, :2], atol=1e-9)


def test_a_tilt_error_displaces_the_inferred_target_along_the_line_of_sight_by_about_distance_times_angle():
    rng = np.random.default_rng(5)
    uavs, objects, aim = _scene(rng, 3)
    aim = np.repeat(objects, 3, axis=0)
    psi, theta = camera.angles(uavs, 1.5, aim)
    delta = np.radians(1.0)
    tilted = camera.Pointing((psi[None], theta[None]), (psi[None], theta[None] + delta), np.zeros((1, 3, 3)))
    det, _ = camera.sense_imperfect(objects[None], uavs[None], uavs[None], 1.5, tilted, (0.4, 0.3), 1e-9,
                                    np.zeros((1, 3, 1, 2)), np.arange(1)[None])
    shift = camera.invert(det.frame, det.z) - objects
    sight = (objects - uavs) / np.linalg.norm(objects - uavs, axis=1, keepdims=True)
    along = np.sum(shift * sight, axis=1)
    across = sight[:, 0] * shift[:, 1] - sight[:, 1] * shift[:, 0]
    d = np.hypot(np.linalg.norm(objects - uavs, axis=1), 1.5)
    np.testing.assert_allclose(across, 0.0, atol=1e-9)
    # pointing too far out, the camera sees the target nearer its axis's foot: the UAV infers it nearer
    assert np.all(along < 0)
    ratio = -along / (d * delta)
    assert np.all((ratio > 0.8) & (ratio < 3.0)), ratio
