"""The constant-acceleration term of a profile phase and the ground robot's CV/CA/CT segments (W20 Ch. 4)."""

import math

import numpy as np
import pytest

from swarmtrack.vehicles import Phase, VelocityProfile


def _midpoint_positions(prof: VelocityProfile, t: np.ndarray, start) -> np.ndarray:
    """Fine numerical integral of the velocity (midpoint rule) on the grid ``t``."""
    dt = np.diff(t)
    v_mid = prof.velocity(t[:-1] + 0.5 * dt)
    return np.asarray(start) + np.concatenate([np.zeros((1, 2)), np.cumsum(v_mid * dt[:, None], axis=0)])


# ---------------------------------------------------------------------- constant-acceleration term
def _accel_profile() -> VelocityProfile:
    return VelocityProfile(
        (
            Phase("cv", 3.0, c=(0.2, -0.1)),
            Phase("ca", 4.0, c=(0.2, -0.1), accel=(0.05, -0.02)),
            Phase("mixed", 5.0, c=(0.1, 0.3), amplitude=(0.2, 0.1), omega=(0.5, 0.0), phi=(0.3, 1.0),
                  accel=(-0.03, 0.01)),
        )
    )


def test_accel_phase_velocity_and_acceleration_are_the_exact_formulas():
    prof = _accel_profile()
    tau = np.linspace(0.0, 3.9, 40)
    np.testing.assert_allclose(prof.velocity(3.0 + tau), [0.2, -0.1] + np.outer(tau, [0.05, -0.02]), atol=1e-12)
    np.testing.assert_allclose(prof.acceleration(3.0 + tau), np.tile([0.05, -0.02], (40, 1)), atol=1e-15)
    v = prof.velocity(7.0 + tau)
    np.testing.assert_allclose(v[:, 0], 0.1 - 0.03 * tau + 0.2 * np.sin(0.5 * tau + 0.3), atol=1e-12)
    np.testing.assert_allclose(v[:, 1], 0.3 + 0.01 * tau + 0.1 * np.sin(1.0), atol=1e-12)
    a = prof.acceleration(7.0 + tau)
    np.testing.assert_allclose(a[:, 0], -0.03 + 0.2 * 0.5 * np.cos(0.5 * tau + 0.3), atol=1e-12)
    np.testing.assert_allclose(a[:, 1], 0.01, atol=1e-15)


def test_accel_phase_position_is_the_exact_integral_of_velocity():
    prof = _accel_profile()
    start = (0.5, -0.25)
    t = np.linspace(0.0, 15.0, 150_001)  # past the end (12 s): the last phase, accel included, continues
    np.testing.assert_allclose(prof.position(t, start), _midpoint_positions(prof, t, start), atol=1e-9)
    # the CA phase in closed form: p = p(3) + c·τ + a·τ²/2
    p3 = np.array(start) + 3.0 * np.array([0.2, -0.1])
    np.testing.assert_allclose(prof.position(5.0, start), p3 + 2.0 * np.array([0.2, -0.1])
                               + 0.5 * 4.0 * np.array([0.05, -0.02]), atol=1e-12)


def test_accel_acceleration_is_the_derivative_of_velocity_and_velocity_of_position():
    prof = _accel_profile()
    t = np.array([1.0, 4.0, 6.5, 8.0, 11.0, 14.0])
    h = 1e-5
    np.testing.assert_allclose(prof.acceleration(t), (prof.velocity(t + h) - prof.velocity(t - h)) / (2 * h),
                               atol=1e-8)
    np.testing.assert_allclose(prof.velocity(t), (prof.position(t + h) - prof.position(t - h)) / (2 * h),
                               atol=1e-8)


def test_accel_keeps_growing_beyond_the_end_of_the_profile():
    prof = VelocityProfile((Phase("ca", 2.0, c=(0.1, 0.0), accel=(0.05, 0.0)),))
    np.testing.assert_allclose(prof.velocity(10.0), [0.1 + 0.05 * 10.0, 0.0])


def test_accel_defaults_to_zero_and_is_validated():
    assert Phase("p", 1.0).accel == (0.0, 0.0)
    assert Phase("p", 1.0, accel=[1, 2]).accel == (1.0, 2.0)
    with pytest.raises(ValueError):
        Phase("p", 1.0, accel=(1.0,))
    # the positional order of the older fields is unchanged
    ph = Phase("p", 1.0, (1.0, 2.0), (0.5, 0.5), (0.1, 0.2), (0.0, math.pi))
    assert ph.phi == (0.0, math.pi) and ph.accel == (0.0, 0.0)
