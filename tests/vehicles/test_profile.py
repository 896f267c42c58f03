import math

import numpy as np
import pytest

from swarmtrack.vehicles import Phase, VelocityProfile, l23_profile, l24_profile


def test_l24_phases_have_the_paper_values():
    prof = l24_profile()
    assert prof.phase_names == ("linear", "sinusoidal", "circular")
    assert [p.duration for p in prof] == [40.0, 62.8, 50.3]
    assert prof.total_duration == pytest.approx(153.1)
    tau = np.linspace(0.0, 30.0, 61)
    # linear: vx = 0.5, vy = 0
    np.testing.assert_allclose(prof.velocity(0.0 + tau), np.tile([0.5, 0.0], (61, 1)), atol=1e-12)
    # sinusoidal: vx = 0.5, vy = 2 sin(0.1 tau)
    v = prof.velocity(40.0 + tau)
    np.testing.assert_allclose(v[:, 0], 0.5, atol=1e-12)
    np.testing.assert_allclose(v[:, 1], 2.0 * np.sin(0.1 * tau), atol=1e-12)
    # circular: vx = 0.2 + 2 sin(0.25 tau), vy = 2 cos(0.25 tau)
    v = prof.velocity(102.8 + tau)
    np.testing.assert_allclose(v[:, 0], 0.2 + 2.0 * np.sin(0.25 * tau), atol=1e-12)
    np.testing.assert_allclose(v[:, 1], 2.0 * np.cos(0.25 * tau), atol=1e-12)


def test_l23_is_the_sinusoidal_phase_alone():
    prof = l23_profile()
    assert prof.phase_names == ("sinusoidal",)
    assert prof.total_duration == pytest.approx(62.8)
    t = np.linspace(0, 62.7, 50)  # 62.8 + 40 is already the circular phase of L24
    np.testing.assert_allclose(prof.velocity(t), l24_profile().velocity(t + 40.0), atol=1e-12)


def test_velocity_jumps_at_the_circular_boundary_as_specified():
    prof = l24_profile()
    before, after = prof.velocity([102.8 - 1e-9, 102.8])
    assert abs(before[1]) < 0.01 and after[1] == pytest.approx(2.0)


def test_phase_index_including_boundaries_and_beyond_the_end():
    prof = l24_profile()
    t = np.array([-1.0, 0.0, 39.99, 40.0, 102.79, 102.8, 153.1, 1000.0])
    np.testing.assert_array_equal(prof.phase_index(t), [0, 0, 0, 1, 1, 2, 2, 2])
    assert prof.phase_index(50.0) == 1
    assert prof.phase_index(t).dtype.kind == "i"


def test_acceleration_is_the_derivative_of_velocity():
    prof = l24_profile()
    # avoid the boundaries, where velocity may jump
    t = np.concatenate([np.linspace(1, 39, 40), np.linspace(41, 102, 60), np.linspace(104, 200, 80)])
    h = 1e-5
    fd = (prof.velocity(t + h) - prof.velocity(t - h)) / (2 * h)
    np.testing.assert_allclose(prof.acceleration(t), fd, atol=1e-7)


def test_position_integrates_velocity_across_phases():
    prof = l24_profile()
    start = (3.0, -2.0)
    t = np.linspace(0.0, 160.0, 160_001)  # runs past the end: the last phase continues
    dt = t[1] - t[0]
    v_mid = prof.velocity(t[:-1] + 0.5 * dt)  # midpoint rule: exact across the velocity jumps on the grid
    cum = np.concatenate([np.zeros((1, 2)), np.cumsum(v_mid * dt, axis=0)])
    np.testing.assert_allclose(prof.position(t, start), start + cum, atol=1e-6)
    np.testing.assert_allclose(prof.position(0.0, start), start)
    # linear phase in closed form
    np.testing.assert_allclose(prof.position(40.0), [20.0, 0.0], atol=1e-12)


def test_position_derivative_is_velocity():
    prof = l24_profile()
    t = np.array([5.0, 60.0, 120.0, 150.0])
    h = 1e-5
    fd = (prof.position(t + h) - prof.position(t - h)) / (2 * h)
    np.testing.assert_allclose(fd, prof.velocity(t), atol=1e-7)


def test_scalar_and_array_shapes():
    prof = l24_profile()
    assert prof.velocity(3.0).shape == (2,)
    assert prof.acceleration(np.zeros((3, 4))).shape == (3, 4, 2)
    assert prof.position(np.zeros(5)).shape == (5, 2)


def test_phase_validates_its_fields():
    with pytest.raises(ValueError):
        Phase("bad", 0.0)
    with pytest.raises(ValueError):
        Phase("bad", 1.0, c=(1.0, 2.0, 3.0))
    with pytest.raises(ValueError):
        VelocityProfile(())
    ph = Phase("p", 2, c=[1, 2], phi=(0, math.pi))
    assert ph.c == (1.0, 2.0) and isinstance(ph.duration, float)


def test_a_climbing_profile_keeps_its_planar_motion_and_its_height_is_the_integral_of_its_climb_rate():
    import math

    from swarmtrack.vehicles.profile import Phase, VelocityProfile, l24_profile

    flat = l24_profile()
    climbing = VelocityProfile(tuple(
        Phase(p.name, p.duration, p.c, p.amplitude, p.omega, p.phi, p.accel, vertical=v)
        for p, v in zip(flat, [(0.0, 0.0, 0.0, 0.0, 0.02), (0.0, 0.5, 0.2, 0.3, 0.0), (0.1, 0.0, 0.0, 0.0, 0.0)],
                        strict=True)))
    t = np.linspace(-1.0, 160.0, 4001)
    assert climbing.climbs and not flat.climbs
    np.testing.assert_array_equal(climbing.velocity(t), flat.velocity(t))
    np.testing.assert_array_equal(climbing.position(t), flat.position(t))
    assert not flat.vertical_velocity(t).any()
    np.testing.assert_array_equal(flat.height(t, 2.0), 2.0)
    # the height is the exact integral of the climb rate, across the phases' jumps of climb rate
    from scipy.integrate import quad

    for when in (20.0, 40.0, 70.0, 102.8, 130.0, 160.0):
        integral = quad(climbing.vertical_velocity, 0.0, when, points=[40.0, 102.8], limit=200)[0]
        assert math.isclose(float(climbing.height(when, 3.0)), 3.0 + integral, rel_tol=1e-10)
    fine = np.linspace(0.0, 150.0, 30001)
    # the climb acceleration is the derivative of the climb rate inside each phase
    inside = fine[(fine > 41.0) & (fine < 100.0)]
    h = 1e-5
    slope = (climbing.vertical_velocity(inside + h) - climbing.vertical_velocity(inside - h)) / (2 * h)
    np.testing.assert_allclose(climbing.vertical_acceleration(inside), slope, atol=1e-8)
    assert math.isclose(climbing.vertical_velocity(45.0), 0.5 * math.sin(0.2 * (45.0 - 40.0) + 0.3))
