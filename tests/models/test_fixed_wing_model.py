"""The shared IB21 Sec. 6 fixed-wing kinematics: batched stepping equals the rows written out, a rollout equals
held inputs stepped tick by tick, and the truth side integrates this very function."""

import numpy as np

from swarmtrack.models import fixed_wing as fw

P = fw.FixedWingParams()


def _random_states(rng, shape):
    n = int(np.prod(shape))
    s = np.column_stack([rng.uniform(-50, 50, (n, 2)), rng.uniform(80, 120, n), rng.uniform(-0.2, 0.2, n),
                         rng.uniform(-4, 4, n), rng.uniform(-0.7, 0.7, n), rng.uniform(-1, 1, n)])
    return s.reshape(*shape, 7)


def test_batched_step_equals_the_sec6_rows_with_saturation_on_every_leading_axis():
    rng = np.random.default_rng(11)
    s = _random_states(rng, (2, 3))
    s[0, 0, fw.PSI_DOT:] = (0.59, 0.5)  # saturates
    s[1, 2, fw.PSI_DOT:] = (-0.6, -0.9)  # saturates the other way
    u = rng.uniform(-0.5, 0.5, (2, 3))
    V, T = P.speed, fw.T_D
    x1, x2, x3, x4, x5, x6, x7 = np.moveaxis(s, -1, 0)
    expected = np.stack([
        x1 + T * np.cos(x4) * np.cos(x5) * V,
        x2 + T * np.cos(x4) * np.sin(x5) * V,
        x3 + T * np.sin(x4) * V,
        x4,
        x5 + T * x6,
        np.clip(x6 + T * x7, -P.yaw_rate_max, P.yaw_rate_max),
        u,
    ], axis=-1)
    np.testing.assert_allclose(fw.step(s, u, P, T), expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fw.step(s, u[..., None], P, T), expected, rtol=0, atol=1e-12)
    assert (np.abs(x6 + T * x7) > P.yaw_rate_max).any()  # the saturation was exercised


def test_one_state_steps_with_many_inputs_by_broadcasting():
    s = _random_states(np.random.default_rng(2), (1,))[0]
    u = np.array([-0.5, 0.0, 0.5])
    out = fw.step(s, u, P)
    assert out.shape == (3, 7)
    for k in range(3):
        np.testing.assert_array_equal(out[k], fw.step(s[None], u[k:k + 1], P)[0])


def test_rollout_equals_held_inputs_stepped_tick_by_tick():
    rng = np.random.default_rng(5)
    s0 = _random_states(rng, (4,))
    plans = rng.choice([-0.5, -0.25, 0.0, 0.25, 0.5], size=(4, 3))
    out = fw.rollout(s0, plans, 10, P)
    assert out.shape == (4, 3, 7)
    s = s0
    for m in range(3):
        for _ in range(10):
            s = fw.step(s, plans[:, m], P)
        np.testing.assert_array_equal(out[:, m], s)
    # one state, many candidate plans
    many = fw.rollout(s0[0], plans, 10, P)
    np.testing.assert_array_equal(many[1], fw.rollout(s0[:1], plans[1:2], 10, P)[0])


def test_the_first_held_input_reaches_the_heading_only_after_the_one_tick_delay():
    s0 = np.array([0.0, 0.0, 100.0, 0.0, 0.0, 0.0, 0.0])
    two_ticks = fw.rollout(s0, [[0.4]], 2, P)[0, 0]
    assert two_ticks[fw.PSI] == 0.0 and two_ticks[fw.PSI_DOT] == 0.4 * fw.T_D


def test_the_vehicle_integrates_the_shared_kinematics():
    from swarmtrack.vehicles import fixed_wing as vehicle

    assert vehicle.step is fw.step and vehicle.FixedWingParams is fw.FixedWingParams


def test_rollout_equals_its_numpy_reference_bit_for_bit():
    rng = np.random.default_rng(8)
    nav = _random_states(rng, (6, 1))
    nav[0, 0, fw.PSI_DOT:] = (0.59, 0.5)  # saturates
    nav[1, 0, fw.PSI_DOT:] = (-0.6, -0.9)
    cands = rng.choice([-0.5, -0.25, 0.0, 0.25, 0.5], size=(1, 25, 2))
    for params in (P, fw.FixedWingParams(yaw_rate_max=np.inf)):
        for ticks in (1, 10):
            out = fw.rollout(nav, cands, ticks, params)
            assert out.shape == (6, 25, 2, 7)
            np.testing.assert_array_equal(out, fw.rollout_reference(nav, cands, ticks, params))
    one = fw.rollout(nav[0, 0], cands[0, :3], 10, P, 0.05)
    np.testing.assert_array_equal(one, fw.rollout_reference(nav[0, 0], cands[0, :3], 10, P, 0.05))
