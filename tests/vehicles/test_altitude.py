"""The altitude channel (vehicles/altitude.py): a double integrator's climb is exact in velocity, a quadrotor's
thrust follows its command through the motors' lag and its limits, and the altitude hold settles on its reference."""

import numpy as np

from swarmtrack.vehicles import altitude

DT = 0.01
INF = np.inf


def test_a_double_integrator_climbs_at_its_commanded_acceleration():
    s = altitude.initial_state([2.0])
    for _ in range(100):
        s = altitude.step(s, np.array([0.5]), DT, np.zeros(1), np.full(1, INF), np.full(1, INF))
    t = 100 * DT
    np.testing.assert_allclose(s[0, altitude.VZ], 0.5 * t, rtol=1e-12)
    # semi-implicit Euler: the exact z0 + a t²/2 plus a·dt·t/2 (as the planar double integrator)
    np.testing.assert_allclose(s[0, altitude.Z], 2.0 + 0.5 * t**2 / 2 + 0.5 * DT * t / 2, rtol=1e-12)


def test_a_quadrotors_thrust_follows_its_command_through_the_motor_lag_and_its_limits():
    tau = altitude.QUADROTOR_THRUST_LAG
    lag, up, down = np.full(3, tau), np.full(3, 9.81), np.full(3, 9.81)
    s = altitude.initial_state(np.zeros(3))
    cmd = np.array([1.0, 30.0, -30.0])  # one within the limits, one above each
    for n in range(1, 6):
        s = altitude.step(s, cmd, DT, lag, up, down)
        rate = DT / tau
        np.testing.assert_allclose(s[0, altitude.AZ], 1.0 * (1 - (1 - rate) ** n), rtol=1e-12)
    np.testing.assert_allclose(s[1:, altitude.AZ], [9.81 * (1 - (1 - rate) ** 5), -9.81 * (1 - (1 - rate) ** 5)],
                               rtol=1e-12)
    fast = altitude.step(altitude.initial_state([0.0]), np.array([1.0]), DT, np.array([DT / 4]), up[:1], down[:1])
    assert fast[0, altitude.AZ] == 1.0  # a lag shorter than the step is reached within it


def test_the_altitude_hold_settles_on_its_reference_without_overshooting_much():
    s = altitude.initial_state([0.0, 5.0])
    z_ref = np.array([3.0, 2.0])
    lag, up, down = np.full(2, altitude.QUADROTOR_THRUST_LAG), np.full(2, 9.81), np.full(2, 9.81)
    peak = s[:, altitude.Z].copy()
    for _ in range(1500):
        s = altitude.step(s, altitude.hold(s, z_ref, kp=1.44, kd=2.16), DT, lag, up, down)
        peak[0] = max(peak[0], s[0, altitude.Z])
    np.testing.assert_allclose(s[:, altitude.Z], z_ref, atol=1e-3)
    assert peak[0] < 3.0 * 1.05  # damping 0.9: under 1 % overshoot in continuous time
