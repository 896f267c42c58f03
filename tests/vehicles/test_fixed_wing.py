"""Properties of the IB21 Sec. 6 fixed-wing UAV."""

import numpy as np
import pytest

from swarmtrack.vehicles import fixed_wing as fw

P = fw.FixedWingParams()
DT = fw.T_D


def run(state, u, ticks, params=P):
    for _ in range(ticks):
        state = fw.step(state, u, params, DT)
    return state


def test_paper_constants_and_initial_state():
    assert (P.speed, P.altitude, P.yaw_rate_max, DT) == (16.6, 100.0, 0.6, 0.05)
    s = fw.initial_state([[1.0, 2.0], [3.0, 4.0]], [0.5, -1.0])
    np.testing.assert_array_equal(s, [[1, 2, 100, 0, 0.5, 0, 0], [3, 4, 100, 0, -1.0, 0, 0]])


def test_level_flight_with_zero_yaw_rate_is_straight_at_speed_v():
    psi = np.array([0.0, 0.7, -2.5])
    s0 = fw.initial_state(np.zeros((3, 2)), psi)
    s = run(s0, np.zeros(3), 200)
    expected = 200 * DT * P.speed * np.stack([np.cos(psi), np.sin(psi)], axis=-1)
    np.testing.assert_allclose(s[:, :2], expected, rtol=1e-12, atol=1e-9)
    np.testing.assert_array_equal(s[:, 2:], s0[:, 2:])
    np.testing.assert_allclose(np.hypot(*fw.truth4(s)[:, 2:].T), P.speed)


@pytest.mark.parametrize("omega", [0.1, 0.3, -0.6])
def test_constant_yaw_rate_flies_a_circle_of_radius_v_over_yaw_rate(omega):
    s = fw.initial_state([[0.0, 0.0]], [0.3])
    s[:, fw.PSI_DOT] = omega
    ticks = int(round(2 * np.pi / abs(omega) / DT))
    xy = np.empty((ticks, 2))
    for k in range(ticks):
        xy[k] = s[0, :2]
        s = fw.step(s, [0.0], P, DT)
    # centre of the circle through three of the points
    a, b, c = xy[0], xy[ticks // 3], xy[2 * ticks // 3]
    m = 2 * np.array([b - a, c - a])
    centre = np.linalg.solve(m, [b @ b - a @ a, c @ c - a @ a])
    r = np.hypot(*(xy - centre).T)
    # Euler's points are the vertices of a regular polygon inscribed in a circle of radius V·dt / (2 sin(ω dt / 2))
    np.testing.assert_allclose(r, P.speed * DT / (2 * np.sin(abs(omega) * DT / 2)), rtol=1e-9)
    np.testing.assert_allclose(r, P.speed / abs(omega), rtol=1e-3)
    (ax, ay), (bx, by) = xy[1] - xy[0], xy[2] - xy[1]
    turn = ax * by - ay * bx
    assert np.sign(turn) == np.sign(omega)  # left turn for ψ̇ > 0


def test_yaw_rate_saturates_at_the_limit_in_both_directions():
    s = fw.initial_state(np.zeros((2, 2)), [0.0, 0.0])
    rates = []
    for _ in range(200):
        s = fw.step(s, [0.5, -0.5], P, DT)
        rates.append(s[:, fw.PSI_DOT].copy())
    rates = np.array(rates)
    assert np.all(np.abs(rates) <= P.yaw_rate_max)
    np.testing.assert_array_equal(rates[-1], [P.yaw_rate_max, -P.yaw_rate_max])
    np.testing.assert_array_equal(s[:, fw.PSI_DDOT], [0.5, -0.5])  # x7 keeps the command
    # reached after 0.6 / 0.5 = 1.2 s plus the one-tick delay, not before
    first = np.argmax(rates[:, 0] >= P.yaw_rate_max)
    assert first == pytest.approx(1.2 / DT + 1, abs=1)
    # an unbounded vehicle keeps winding up
    free = run(fw.initial_state([[0.0, 0.0]], [0.0]), [0.5], 200, fw.FixedWingParams(yaw_rate_max=np.inf))
    assert free[0, fw.PSI_DOT] > 4.0


def test_the_input_reaches_the_yaw_rate_after_two_ticks_and_the_heading_after_three():
    s0 = fw.initial_state([[0.0, 0.0]], [0.0])
    s1 = fw.step(s0, [0.4], P, DT)
    s2 = fw.step(s1, [0.0], P, DT)
    s3 = fw.step(s2, [0.0], P, DT)
    assert (s1[0, fw.PSI_DDOT], s1[0, fw.PSI_DOT], s1[0, fw.PSI]) == (0.4, 0.0, 0.0)
    assert s2[0, fw.PSI_DOT] == pytest.approx(0.4 * DT) and s2[0, fw.PSI] == 0.0
    assert s3[0, fw.PSI] == pytest.approx(0.4 * DT * DT)
    assert s3[0, fw.Y] == 0.0  # the position lags the heading by one more tick


def test_truth4_is_position_and_ground_velocity():
    s = fw.initial_state([[1.0, 2.0]], [np.pi / 3])
    s[0, fw.GAMMA] = 0.1
    np.testing.assert_allclose(
        fw.truth4(s), [[1.0, 2.0, P.speed * np.cos(0.1) * 0.5, P.speed * np.cos(0.1) * np.sqrt(3) / 2]])


def test_the_compiled_step_equals_the_reference_bit_for_bit():
    """:func:`step_compiled` gives the shared kinematics' :func:`step` numbers exactly: in and beyond the yaw-rate
    saturation (both signs), climbing, with a NaN yaw rate, with the heading's cos and sin given (as the world
    does) or not."""
    rng = np.random.default_rng(5)
    for params in (P, fw.FixedWingParams(yaw_rate_max=np.inf)):
        for _ in range(200):
            s = fw.initial_state(rng.uniform(0, 400, (6, 2)), rng.uniform(-4, 4, 6), params)
            s[:, fw.GAMMA] = rng.uniform(-0.2, 0.2, 6) * (rng.random(6) < 0.5)
            s[:, fw.PSI_DOT] = rng.uniform(-0.7, 0.7, 6)
            s[:, fw.PSI_DDOT] = rng.uniform(-3, 3, 6)
            s[0, fw.PSI_DOT] = np.nan
            u = rng.uniform(-1, 1, (6, 1))
            ref = fw.step(s, u, params, DT)
            trig = (np.cos(s[:, fw.PSI]), np.sin(s[:, fw.PSI]))
            np.testing.assert_array_equal(fw.step(s, u, params, DT, trig=trig), ref)
            np.testing.assert_array_equal(fw.step_compiled(s, u, params, DT), ref)
            np.testing.assert_array_equal(fw.step_compiled(s, u[:, 0], params, DT, trig=trig), ref)
            np.testing.assert_array_equal(fw.truth4(s, params, trig=trig), fw.truth4(s, params))
