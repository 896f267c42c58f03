import numpy as np
import pytest

from swarmtrack.vehicles import QuadrotorParams, l24_profile, quadrotor, velocity_tracking_accel

P = QuadrotorParams()
DT = 0.01


def run(state, accel, steps, params=P, disturbance=None):
    for _ in range(steps):
        state = quadrotor.step(state, accel, params, DT, disturbance)
    return state


def test_iris_defaults():
    assert (P.mass, P.Ixx, P.Iyy, P.g) == (1.5, 0.029, 0.029, 9.81)
    assert P.max_thrust == pytest.approx(2 * 1.5 * 9.81)
    assert P.max_horizontal_accel == pytest.approx(9.81 * np.tan(0.6))


def test_hovers_in_place_with_zero_command():
    pos = np.array([[0.0, 0.0], [5.0, -3.0], [-1.0, 2.0]])
    state = run(quadrotor.hover_state(pos), np.zeros((3, 2)), 1000)
    np.testing.assert_array_equal(state[:, 0:2], pos)
    np.testing.assert_array_equal(state[:, 2:], 0.0)


def test_step_response_reaches_commanded_acceleration_fast_without_large_overshoot():
    state = quadrotor.hover_state(np.zeros((1, 2)))
    cmd = np.array([[1.0, 0.0]])
    ax = []
    for _ in range(100):
        state = quadrotor.step(state, cmd, P, DT)
        ax.append(quadrotor.achieved_acceleration(state, P)[0, 0])
    ax = np.array(ax)
    assert abs(ax[49] - 1.0) < 0.02  # within 2 % at 0.5 s
    assert ax.max() < 1.05  # < 5 % overshoot


def test_reaches_commanded_acceleration_in_steady_state():
    cmds = np.array([[1.0, 0.0], [0.0, -2.0], [3.0, 4.0], [-2.5, 1.5]])
    state = run(quadrotor.hover_state(np.zeros((4, 2))), cmds, 300)
    np.testing.assert_allclose(quadrotor.achieved_acceleration(state, P), cmds, atol=1e-6)
    # velocity then grows at that rate (one more step)
    nxt = quadrotor.step(state, cmds, P, DT)
    np.testing.assert_allclose((nxt[:, 2:4] - state[:, 2:4]) / DT, cmds, atol=1e-6)


def test_acceleration_beyond_the_tilt_limit_is_clipped_in_norm_keeping_direction():
    cmd = np.array([[30.0, 40.0]])
    state = run(quadrotor.hover_state(np.zeros((1, 2))), cmd, 300)
    acc = quadrotor.achieved_acceleration(state, P)[0]
    np.testing.assert_allclose(np.linalg.norm(acc), P.max_horizontal_accel, rtol=1e-6)
    np.testing.assert_allclose(acc / np.linalg.norm(acc), [0.6, 0.8], atol=1e-6)
    assert quadrotor.tilt(state)[0] == pytest.approx(P.max_tilt, abs=1e-6)


def test_tilt_setpoint_never_exceeds_max_tilt():
    rng = np.random.default_rng(1)
    cmds = rng.normal(0.0, 30.0, (1000, 2))
    ang = quadrotor.desired_attitude(cmds, P)
    tilt = np.arccos(np.cos(ang[:, 0]) * np.cos(ang[:, 1]))
    assert tilt.max() <= P.max_tilt + 1e-12


def test_achieved_tilt_never_exceeds_max_tilt_beyond_inner_loop_overshoot():
    # max_tilt limits the setpoint (as PX4 MPC_TILTMAX_AIR); the zeta = 0.8 loop overshoots by < 2 %.
    rng = np.random.default_rng(0)
    state = quadrotor.hover_state(np.zeros((32, 2)))
    worst = 0.0
    for k in range(1000):
        if k % 25 == 0:
            cmd = rng.normal(0.0, 15.0, (32, 2))
        state = quadrotor.step(state, cmd, P, DT)
        worst = max(worst, quadrotor.tilt(state).max())
    assert P.max_tilt * 0.99 < worst <= P.max_tilt * 1.02


def test_moments_are_clipped_to_max_moment():
    state = quadrotor.hover_state(np.zeros((1, 2)))
    nxt = quadrotor.step(state, np.array([[50.0, 0.0]]), P, DT)
    assert nxt[0, 7] == pytest.approx(P.max_moment / P.Iyy * DT)


def test_disturbance_adds_acceleration():
    state = quadrotor.hover_state(np.zeros((2, 2)))
    wind = np.array([[0.3, -0.1], [0.0, 0.0]])
    state = run(state, np.zeros((2, 2)), 100, disturbance=wind)
    np.testing.assert_allclose(state[0, 2:4], wind[0] * 100 * DT, atol=1e-12)
    np.testing.assert_array_equal(state[1], 0.0)


def test_step_is_pure_and_accepts_any_layout():
    rng = np.random.default_rng(3)
    state_c = np.ascontiguousarray(rng.normal(0.0, 0.1, (3, 8)))
    before = state_c.copy()
    cmd = rng.normal(0.0, 2.0, (3, 2))
    a = quadrotor.step(state_c, cmd, P, DT)
    b = quadrotor.step(np.asfortranarray(state_c), cmd, P, DT)
    np.testing.assert_array_equal(state_c, before)
    np.testing.assert_array_equal(a, b)
    assert a.shape == (3, 8)


def test_batch_of_vehicles_equals_single_runs():
    rng = np.random.default_rng(7)
    m = 5
    state0 = quadrotor.hover_state(rng.normal(0.0, 3.0, (m, 2)))
    cmds = rng.normal(0.0, 4.0, (200, m, 2))
    wind = rng.normal(0.0, 0.2, (m, 2))
    batch = state0
    for k in range(200):
        batch = quadrotor.step(batch, cmds[k], P, DT, wind)
    for i in range(m):
        single = state0[i : i + 1]
        for k in range(200):
            single = quadrotor.step(single, cmds[k, i : i + 1], P, DT, wind[i : i + 1])
        np.testing.assert_array_equal(batch[i], single[0])


def test_velocity_tracking_accel_is_feedforward_plus_proportional():
    out = velocity_tracking_accel(np.array([[1.0, 2.0]]), np.array([[0.5, 2.5]]), np.array([[0.1, 0.0]]), 2.0)
    np.testing.assert_allclose(out, [[1.1, -1.0]])
    np.testing.assert_allclose(velocity_tracking_accel([1.0, 0.0], np.zeros(2), None, 1.5), [1.5, 0.0])


@pytest.mark.slow
def test_target_flying_l24_profile_tracks_velocity_on_linear_and_sinusoidal_phases():
    prof = l24_profile()
    n = int(round(prof.total_duration / DT))
    t = np.arange(n) * DT
    v_cmd = prof.velocity(t)
    a_ff = prof.acceleration(t)
    state = quadrotor.hover_state(np.zeros((1, 2)))
    vel = np.empty((n, 2))
    for k in range(n):
        state = quadrotor.step(state, velocity_tracking_accel(v_cmd[k], state[:, 2:4], a_ff[k], 1.5), P, DT)
        vel[k] = state[0, 2:4]
    err = vel - prof.velocity(t + DT)
    phase = prof.phase_index(t + DT)
    for name, idx in (("linear", 0), ("sinusoidal", 1)):
        rms = np.sqrt(np.mean(np.sum(err[phase == idx] ** 2, axis=1)))
        assert rms < 0.15, (name, rms)
    # the circular phase starts with a velocity jump the controller smooths; it converges afterwards
    late = (phase == 2) & (t > 102.8 + 10.0)
    assert np.sqrt(np.mean(np.sum(err[late] ** 2, axis=1))) < 0.15


def test_unequal_inertias_limit_each_axis_by_its_own_moment():
    params = quadrotor.QuadrotorParams(Ixx=0.02, Iyy=0.04, max_moment=0.2)
    state = quadrotor.hover_state(np.zeros((3, 2)))
    new = quadrotor.step(state, np.full((3, 2), 20.0), params, 0.01)
    rates = new[:, 6:8]  # one step from hover: |rate| = dt·max_moment/I on each saturated axis
    np.testing.assert_allclose(np.abs(rates[:, 0]), 0.01 * 0.2 / 0.02)
    np.testing.assert_allclose(np.abs(rates[:, 1]), 0.01 * 0.2 / 0.04)


# --- W20 Sec. 5.4.2: roll and pitch saturated at 5° per axis (``max_roll_pitch``) -------------------------------------
LIMIT = np.radians(5.0)
W20 = QuadrotorParams(max_roll_pitch=LIMIT)


def test_roll_and_pitch_setpoints_are_saturated_each_at_max_roll_pitch():
    rng = np.random.default_rng(5)
    cmds = rng.normal(0.0, 3.0, (2000, 2))
    ang = quadrotor.desired_attitude(cmds, W20)
    assert np.abs(ang).max() == LIMIT  # reached, never exceeded
    free = quadrotor.desired_attitude(cmds, P)
    inside = np.all(np.abs(free) <= LIMIT, axis=1)
    assert 0 < inside.sum() < len(cmds)
    np.testing.assert_array_equal(ang[inside], free[inside])  # a command under the limit is not touched
    np.testing.assert_array_equal(ang[~inside], np.clip(free[~inside], -LIMIT, LIMIT))


def test_achieved_roll_and_pitch_stay_within_the_limit_plus_the_inner_loop_overshoot():
    # the limit acts on the setpoints, as max_tilt does; the zeta = 0.8 attitude loop overshoots by < 2 %
    rng = np.random.default_rng(0)
    state = quadrotor.hover_state(np.zeros((32, 2)))
    worst = 0.0
    for k in range(1000):
        if k % 25 == 0:
            cmd = rng.normal(0.0, 3.0, (32, 2))
        state = quadrotor.step(state, cmd, W20, DT)
        worst = max(worst, np.abs(state[:, 4:6]).max())
    assert LIMIT * 0.99 < worst <= LIMIT * 1.02


def test_a_saturated_diagonal_command_holds_both_angles_at_the_limit():
    # φ = −5°, θ = 5° with the altitude-hold thrust: ax = g·tan 5°/cos 5°, ay = g·tan 5° (0.86 m/s² per axis,
    # against the 3 m/s² the position controller may ask for)
    state = run(quadrotor.hover_state(np.zeros((1, 2))), np.array([[3.0, 3.0]]), 300, params=W20)
    np.testing.assert_allclose(state[0, 4:6], [-LIMIT, LIMIT], atol=1e-9)
    g_tan = W20.g * np.tan(LIMIT)
    np.testing.assert_allclose(quadrotor.achieved_acceleration(state, W20)[0], [g_tan / np.cos(LIMIT), g_tan],
                               rtol=1e-8)


def test_the_per_axis_limit_is_what_a_saturated_diagonal_command_gives_on_each_axis():
    """max_axis_accel (what the MPC plans within, issue 42): g·tan 5° with W20's limit, reached on both axes at once;
    the tilt-norm limit shared by the two axes without it."""
    assert W20.max_axis_accel == pytest.approx(W20.g * np.tan(LIMIT), rel=1e-15)
    state = run(quadrotor.hover_state(np.zeros((1, 2))), np.array([[3.0, -3.0]]), 300, params=W20)
    assert np.all(np.abs(quadrotor.achieved_acceleration(state, W20)[0]) >= W20.max_axis_accel * (1 - 1e-9))
    assert P.max_axis_accel == pytest.approx(P.max_horizontal_accel / np.sqrt(2), rel=1e-15)
    state = run(quadrotor.hover_state(np.zeros((1, 2))), np.array([[9.0, 9.0]]), 300)
    np.testing.assert_allclose(quadrotor.achieved_acceleration(state, P)[0], [P.max_axis_accel] * 2, rtol=1e-6)


def test_a_limit_that_never_binds_changes_no_bit():
    # the tilt-norm clip at 0.6 rad keeps each angle under 0.6 rad: a 0.61 rad per-axis limit never binds
    rng = np.random.default_rng(4)
    state = quadrotor.hover_state(rng.normal(0.0, 3.0, (8, 2)))
    loose = QuadrotorParams(max_roll_pitch=0.61)
    a = b = state
    for _ in range(300):
        cmd = rng.normal(0.0, 10.0, (8, 2))
        a, b = quadrotor.step(a, cmd, P, DT), quadrotor.step(b, cmd, loose, DT)
    np.testing.assert_array_equal(a, b)
    assert P.max_roll_pitch is None and P._consts[-1] == np.inf  # the default: no per-axis limit


@pytest.mark.parametrize("value", [0.0, -0.1, np.pi / 2, 3.0])
def test_a_max_roll_pitch_outside_zero_to_a_right_angle_is_refused(value):
    with pytest.raises(ValueError, match="max_roll_pitch"):
        QuadrotorParams(max_roll_pitch=value)
