import numpy as np
import pytest

from swarmtrack.sensors import camera


def _setup(rng, n=50):
    cam = rng.uniform(-2, 2, (n, 2))
    aim = cam + rng.uniform(-2, 2, (n, 2))
    return cam, aim


def test_rotation_is_proper_and_puts_the_aim_point_on_the_optical_axis():
    rng = np.random.default_rng(0)
    cam, aim = _setup(rng)
    C = camera.rotation(cam, 1.5, aim)
    np.testing.assert_allclose(C @ np.swapaxes(C, -1, -2), np.broadcast_to(np.eye(3), C.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(C), 1.0, atol=1e-12)
    pc = camera.camera_frame(aim, C, cam, 1.5)
    np.testing.assert_allclose(pc[:, :2], 0.0, atol=1e-12)  # centred (the pan-tilt unit's job)
    np.testing.assert_allclose(pc[:, 2], np.sqrt(np.sum((aim - cam) ** 2, axis=1) + 1.5**2), rtol=1e-12)


def test_ground_affine_equals_the_rigid_transform_on_flat_ground_and_inverts():
    rng = np.random.default_rng(1)
    cam, aim = _setup(rng)
    C = camera.rotation(cam, 1.5, aim)
    p = rng.uniform(-3, 3, (len(cam), 2))
    frame = camera.ground_affine(C, cam, 1.5)
    z = np.einsum("nab,nb->na", frame[:, :, :2], p) + frame[:, :, 2]
    np.testing.assert_allclose(z, camera.camera_frame(p, C, cam, 1.5)[:, :2], atol=1e-12)  # W20 eq. 4.16
    np.testing.assert_allclose(camera.invert(frame, z), p, atol=1e-9)


def test_field_of_view_is_the_thesis_footprint_at_1_5_m():
    """Straight down from 1.5 m, the field of view is 1.2 m x 0.9 m (W20 Sec. 3.2.2.2); looking straight down
    (yaw 0) the width spans the world's y axis."""
    cam = np.zeros((1, 2))
    C = camera.rotation(cam, 1.5, cam)
    tan_half = (0.6 / 1.5, 0.45 / 1.5)
    for x, y, seen in [(0.0, 0.59, True), (0.0, 0.61, False), (0.44, 0.0, True), (0.46, 0.0, False),
                       (-0.44, -0.59, True)]:
        pc = camera.camera_frame(np.array([[x, y]]), C, cam, 1.5)
        assert camera.in_view(pc, tan_half)[0] == seen, (x, y)


def test_sense_detects_only_in_view_and_stamps_the_navigation_pose():
    rng = np.random.default_rng(2)
    uavs = np.array([[0.0, 0.0], [3.0, 0.0]])
    stamped = uavs + 0.01
    objects = np.array([[0.1, 0.1]])
    aim = np.array([[0.1, 0.1], [10.0, 10.0]])  # UAV 2 looks away
    noise = rng.standard_normal((2, 1, 2))
    det, source = camera.sense(objects, uavs, stamped, 1.5, aim, (0.4, 0.3), 0.01, noise)
    assert det.owner.tolist() == [0] and source.tolist() == [0]
    np.testing.assert_allclose(det.sensor_pos, stamped[:1])
    # the UAV's own frame from its navigation pose maps the object close to the measurement (nav error + noise)
    p = camera.invert(det.frame, det.z)
    assert np.linalg.norm(p - objects) < 0.1
    hidden = np.ones((2, 1), dtype=bool)
    det, _ = camera.sense(objects, uavs, stamped, 1.5, aim, (0.4, 0.3), 0.01, noise, hidden)
    assert len(det) == 0


@pytest.mark.parametrize("height", [0.5, 1.5, 10.0])
def test_measurement_noise_enters_in_the_camera_frame(height):
    cam = np.zeros((1, 2))
    objects = np.array([[0.2, -0.1]])
    noise = np.array([[[1.0, -2.0]]])
    det0, _ = camera.sense(objects, cam, cam, height, objects, (1.0, 1.0), 0.0, noise)
    det1, _ = camera.sense(objects, cam, cam, height, objects, (1.0, 1.0), 0.05, noise)
    np.testing.assert_allclose(det1.z - det0.z, [[0.05, -0.1]], atol=1e-12)
