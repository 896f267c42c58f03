import numpy as np

from swarmtrack.vehicles import double_integrator as di


def test_constant_acceleration_velocity_exact_position_within_semi_implicit_bound():
    dt, n = 0.01, 500
    q0, p0, a = np.array([1.0, -2.0]), np.array([0.5, 0.3]), np.array([0.4, -1.2])
    state = np.array([[*q0, *p0], [0.0, 0.0, 0.0, 0.0]])
    accel = np.array([a, [0.0, 0.0]])
    for _ in range(n):
        state = di.step(state, accel, dt)
    t = n * dt
    np.testing.assert_allclose(state[0, 2:4], p0 + a * t, atol=1e-12)
    # semi-implicit Euler overshoots the exact position by exactly a·dt·t/2
    exact = q0 + p0 * t + 0.5 * a * t**2
    np.testing.assert_allclose(state[0, 0:2] - exact, 0.5 * a * dt * t, atol=1e-10)
    np.testing.assert_allclose(state[1], 0.0)


def test_norm_clipping_keeps_direction_and_leaves_small_commands():
    state = np.zeros((3, 4))
    accel = np.array([[3.0, 4.0], [0.3, 0.4], [0.0, 0.0]])
    new = di.step(state, accel, 1.0, accel_limit=1.0)
    np.testing.assert_allclose(new[:, 2:4], [[0.6, 0.8], [0.3, 0.4], [0.0, 0.0]])
    # per-axis clipping would have given (1, 1) for this one
    new = di.step(np.zeros((1, 4)), np.array([[5.0, 5.0]]), 1.0, accel_limit=1.0)
    np.testing.assert_allclose(np.linalg.norm(new[0, 2:4]), 1.0)
    np.testing.assert_allclose(new[0, 2], new[0, 3])


def test_step_is_pure():
    state = np.ones((2, 4))
    before = state.copy()
    di.step(state, np.ones((2, 2)), 0.1, accel_limit=0.5)
    np.testing.assert_array_equal(state, before)
