"""Properties of the range-bearing sensor (L24 Sec. 3.2 and Sec. 4, L23)."""

from __future__ import annotations

import numpy as np
import pytest

from swarmtrack.sensors import (
    L23_SIGMA,
    L24_SIGMA,
    measure,
    polar_covariance,
    polar_model,
    position_covariance,
    to_position,
    wrap_angle,
)


def test_paper_noise_constants():
    assert L24_SIGMA == (0.08, 0.02)
    assert L23_SIGMA == (0.4, 0.1)
    np.testing.assert_array_equal(polar_covariance(*L24_SIGMA), np.diag([0.08**2, 0.02**2]))


def test_wrap_angle_maps_into_minus_pi_exclusive_to_pi_inclusive():
    a = np.linspace(-20.0, 20.0, 10001)
    w = wrap_angle(a)
    assert np.all(w > -np.pi) and np.all(w <= np.pi)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    assert wrap_angle(np.pi) == pytest.approx(np.pi)
    assert wrap_angle(-np.pi) == pytest.approx(np.pi)
    assert wrap_angle(3 * np.pi) == pytest.approx(np.pi)
    assert wrap_angle(0.3) == pytest.approx(0.3)


def test_measure_noise_has_the_requested_mean_and_std():
    rng = np.random.default_rng(42)
    sensor = np.array([1.0, 2.0])
    target = np.array([4.0, 6.0])  # range 5, bearing atan2(4, 3)
    sr, sb = L23_SIGMA
    z = measure(np.broadcast_to(target, (40000, 2)), sensor, sr, sb, rng)
    assert z.shape == (40000, 2)
    n = z.shape[0]
    assert z[:, 0].mean() == pytest.approx(5.0, abs=4 * sr / np.sqrt(n))
    assert z[:, 1].mean() == pytest.approx(np.arctan2(4.0, 3.0), abs=4 * sb / np.sqrt(n))
    assert z[:, 0].std() == pytest.approx(sr, rel=0.03)
    assert z[:, 1].std() == pytest.approx(sb, rel=0.03)
    assert abs(np.corrcoef(z.T)[0, 1]) < 0.03


def test_measure_is_reproducible_from_the_seed_and_wraps_the_bearing():
    target = np.array([-5.0, 1e-9])  # bearing ≈ π: noise pushes it across ±π
    z1 = measure(np.broadcast_to(target, (1000, 2)), np.zeros(2), 0.1, 0.1, np.random.default_rng(3))
    z2 = measure(np.broadcast_to(target, (1000, 2)), np.zeros(2), 0.1, 0.1, np.random.default_rng(3))
    np.testing.assert_array_equal(z1, z2)
    assert np.all(z1[:, 1] > -np.pi) and np.all(z1[:, 1] <= np.pi)
    assert np.any(z1[:, 1] < 0) and np.any(z1[:, 1] > 0)


def test_measure_and_polar_model_broadcast_over_batch_axes():
    rng = np.random.default_rng(0)
    targets = rng.normal(size=(7, 3, 2)) * 5
    sensors = rng.normal(size=(3, 2))
    z = measure(targets, sensors, 0.0, 0.0, rng)
    h, H = polar_model(targets, sensors)
    assert z.shape == h.shape == (7, 3, 2) and H.shape == (7, 3, 2, 2)
    np.testing.assert_allclose(z, h, atol=1e-12)
    for i in range(7):
        for j in range(3):
            hij, Hij = polar_model(targets[i, j], sensors[j])
            np.testing.assert_allclose(h[i, j], hij, rtol=1e-14)
            np.testing.assert_allclose(H[i, j], Hij, rtol=1e-14)


def test_polar_jacobian_matches_central_differences():
    rng = np.random.default_rng(5)
    eps = 1e-6
    for _ in range(10):
        target, sensor = rng.normal(size=2) * 4, rng.normal(size=2) * 4
        _, H = polar_model(target, sensor)
        num = np.zeros((2, 2))
        for j in range(2):
            e = np.zeros(2)
            e[j] = eps
            hp, _ = polar_model(target + e, sensor)
            hm, _ = polar_model(target - e, sensor)
            d = hp - hm
            d[1] = wrap_angle(d[1])
            num[:, j] = d / (2 * eps)
        np.testing.assert_allclose(H, num, rtol=1e-6, atol=1e-8)


def test_polar_jacobian_stays_finite_when_target_is_on_the_sensor():
    h, H = polar_model(np.array([1.0, 1.0]), np.array([1.0, 1.0]))
    assert np.all(np.isfinite(h)) and np.all(np.isfinite(H))
    assert h[0] == 0.0


def test_to_position_inverts_the_noiseless_measurement():
    rng = np.random.default_rng(9)
    targets = rng.normal(size=(50, 2)) * 10
    sensors = rng.normal(size=(50, 2)) * 10
    z = measure(targets, sensors, 0.0, 0.0, rng)
    np.testing.assert_allclose(to_position(z, sensors), targets, atol=1e-10)


@pytest.mark.parametrize("sigma", [L24_SIGMA, L23_SIGMA])
def test_position_covariance_matches_empirical_covariance_of_converted_measurements(sigma):
    rng = np.random.default_rng(11)
    sensor = np.array([-1.0, 0.5])
    bearing = 2.3
    rho = 5.0
    target = sensor + rho * np.array([np.cos(bearing), np.sin(bearing)])
    n = 40000
    p = to_position(measure(np.broadcast_to(target, (n, 2)), sensor, *sigma, rng), sensor)
    emp = np.cov(p.T)
    R = position_covariance(rho, bearing, *sigma)
    assert np.linalg.norm(emp - R) / np.linalg.norm(R) < 0.1
    # Along and across the line of sight separately.
    los = np.array([np.cos(bearing), np.sin(bearing)])
    perp = np.array([-los[1], los[0]])
    assert los @ emp @ los == pytest.approx(sigma[0] ** 2, rel=0.1)
    assert perp @ emp @ perp == pytest.approx((rho * sigma[1]) ** 2, rel=0.1)
    assert los @ R @ los == pytest.approx(sigma[0] ** 2)
    assert perp @ R @ perp == pytest.approx((rho * sigma[1]) ** 2)


def test_position_covariance_is_symmetric_positive_definite_even_at_zero_range():
    rng = np.random.default_rng(2)
    rhos = np.concatenate([[0.0, 1e-9], rng.uniform(0.0, 100.0, size=200)])
    betas = rng.uniform(-np.pi, np.pi, size=rhos.shape)
    for sigma in (L24_SIGMA, L23_SIGMA):
        R = position_covariance(rhos, betas, *sigma)
        assert R.shape == (rhos.size, 2, 2)
        np.testing.assert_array_equal(R, np.swapaxes(R, -1, -2))
        assert np.all(np.linalg.eigvalsh(R) > 0)
        np.linalg.cholesky(R)
