"""Issue 40's box targets: nearly constant velocity with white-noise acceleration, reflected at the box's walls."""

import numpy as np
import pytest

from swarmtrack.scenarios.loader import load_scenario
from swarmtrack.sim.build import truth_side
from swarmtrack.vehicles import nearly_cv as ncv

P = ncv.NearlyCVParams(speed=3.0, accel_noise=0.25, area=(-100.0, -100.0, 100.0, 100.0))


def test_inside_the_box_a_tick_is_the_semi_implicit_euler_step_written_out():
    s = ncv.initial_state([[1.0, 2.0], [-5.0, 3.0]], [0.3, -2.0], P)
    np.testing.assert_allclose(np.hypot(s[:, 2], s[:, 3]), 3.0)
    w = np.array([[0.5, -1.0], [2.0, 0.1]])
    out = ncv.step(s, w, P, 0.1)
    v = s[:, 2:4] + np.sqrt(0.25 * 0.1) * w
    np.testing.assert_array_equal(out[:, 2:4], v)
    np.testing.assert_array_equal(out[:, :2], s[:, :2] + 0.1 * v)
    np.testing.assert_array_equal(out[:, 4], np.arctan2(v[:, 1], v[:, 0]))


def test_a_wall_reflects_the_position_and_reverses_the_velocity_across_it():
    s = ncv.initial_state([[99.9, 0.0]], [0.0], P)  # heading +x at 3 m/s: crosses x = 100 within the tick
    out = ncv.step(s, np.zeros((1, 2)), P, 0.1)
    assert out[0, 0] == pytest.approx(100.0 - (99.9 + 0.3 - 100.0))
    assert out[0, 2] == pytest.approx(-3.0) and out[0, 3] == 0.0


def test_the_velocity_variance_grows_by_q_a_second_and_members_stay_in_the_box():
    rng = np.random.default_rng(3)
    n, dt, ticks = 2000, 0.1, 100
    s = ncv.initial_state(np.zeros((n, 2)), np.zeros(n), ncv.NearlyCVParams(speed=0.0, accel_noise=0.25,
                                                                                area=(-1e6, -1e6, 1e6, 1e6)))
    w = ncv.draw_inputs(rng, ticks, n)
    assert w.shape == (ticks, n, 2)
    for k in range(ticks):
        s = ncv.step(s, w[k], ncv.NearlyCVParams(speed=0.0, accel_noise=0.25, area=(-1e6, -1e6, 1e6, 1e6)), dt)
    assert np.var(s[:, 2:4]) == pytest.approx(0.25 * ticks * dt, rel=0.1)  # 10 s: variance 2.5 m²/s²
    world = truth_side(load_scenario("mtt-box-easy")).world
    for _ in range(100):
        world.advance({"uavs": np.zeros((4, 2))}, 10)
        p = world.truth()[:10, :2]
        assert (np.abs(p) <= 100.0).all()
