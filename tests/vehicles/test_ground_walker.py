"""Properties of the IB21 Sec. 6 targets and decoys (ground walkers reflected at the area's border)."""

import math

import numpy as np
import pytest

from swarmtrack.vehicles import ground_walker as gw

P = gw.WalkerParams()
DT = gw.T_D
VDT = P.speed * DT


def test_paper_constants():
    assert (P.speed, P.yaw_accel_bound, P.area, DT) == (1.0, math.pi / 8, (0.0, 0.0, 400.0, 400.0), 0.05)
    with pytest.raises(ValueError, match="not a box"):
        gw.WalkerParams(area=(0.0, 0.0, 0.0, 10.0))


def test_draw_inputs_are_uniform_in_plus_minus_the_bound():
    v = gw.draw_inputs(np.random.default_rng(0), 1000, 50, P)
    assert v.shape == (1000, 50)
    assert np.all(np.abs(v) <= P.yaw_accel_bound)
    assert v.max() > 0.99 * P.yaw_accel_bound and v.min() < -0.99 * P.yaw_accel_bound
    assert np.std(v) == pytest.approx(P.yaw_accel_bound / math.sqrt(3), rel=0.02)


def test_one_step_inside_the_area_equals_the_sec6_rows_written_out():
    rng = np.random.default_rng(1)
    s = np.column_stack([rng.uniform(10, 390, (6, 2)), rng.uniform(-4, 4, 6), rng.uniform(-1, 1, 6),
                         rng.uniform(-0.4, 0.4, 6)])
    v = rng.uniform(-0.4, 0.4, 6)
    x1, x2, x3, x4, x5 = s.T
    expected = np.column_stack([x1 + DT * np.cos(x3) * P.speed, x2 + DT * np.sin(x3) * P.speed, x3 + DT * x4,
                                x4 + DT * x5, v])
    np.testing.assert_allclose(gw.step(s, v, P, DT), expected, rtol=0, atol=1e-12)


def test_reflection_at_a_vertical_wall_a_horizontal_wall_and_a_corner():
    s = gw.initial_state([[399.99, 200.0], [200.0, 0.01], [0.02, 399.98], [0.0, 0.0]],
                         [0.0, -math.pi / 4, 3 * math.pi / 4, math.pi / 2])
    out = gw.step(s, np.zeros(4), P, DT)
    # east wall: the 0.05 m path hits x = 400 after 0.01 m and comes back 0.04 m, heading 0 -> π
    np.testing.assert_allclose(out[0, :3], [399.96, 200.0, math.pi], atol=1e-12)
    # south wall, heading -π/4 -> π/4
    d = VDT / math.sqrt(2)
    np.testing.assert_allclose(out[1, :3], [200.0 + d, abs(0.01 - d), math.pi / 4], atol=1e-12)
    # north-west corner, heading 3π/4 crosses both walls -> -π/4
    np.testing.assert_allclose(out[2, :3], [d - 0.02, 400 - (d - 0.02), -math.pi / 4],
                               atol=1e-12)
    # on the wall, moving along it: no reflection
    np.testing.assert_allclose(out[3, :3], [0.0, VDT, math.pi / 2], atol=1e-12)


def test_the_reflected_heading_mirrors_the_tick_heading_including_its_yaw_rate_update():
    s = gw.initial_state([[399.99, 200.0]], [0.1])
    s[0, gw.YAW_RATE] = 0.4
    out = gw.step(s, [0.0], P, DT)
    assert out[0, gw.HEADING] == pytest.approx(math.pi - (0.1 + DT * 0.4))
    assert out[0, gw.YAW_RATE] == 0.4  # not mirrored


def _walk(state, params, ticks, rng):
    """Walk ``ticks`` ticks; return the largest displacement per tick, whether every state stayed in the closed
    area, and the last state."""
    x0, y0, x1, y1 = params.area
    v = gw.draw_inputs(rng, ticks, len(state), params)
    xy = np.empty((ticks + 1, len(state), 2))
    xy[0] = state[:, :2]
    for k in range(ticks):
        state = gw.step(state, v[k], params, DT)
        xy[k + 1] = state[:, :2]
    worst = float(np.max(np.hypot(*np.diff(xy, axis=0).T)))
    inside = bool(np.all((xy[..., 0] >= x0) & (xy[..., 0] <= x1) & (xy[..., 1] >= y0) & (xy[..., 1] <= y1)))
    return worst, inside, state


@pytest.mark.slow
def test_1e5_steps_near_the_border_stay_in_the_closed_area_and_move_at_most_v_dt_per_tick():
    # a 2 x 1 m area keeps every object within a few ticks of a wall all the time; starts on walls and corners
    params = gw.WalkerParams(area=(-1.0, 3.0, 1.0, 4.0))
    rng = np.random.default_rng(7)
    n = 16
    xy = np.column_stack([rng.choice([-1.0, 1.0, 0.3], n), rng.choice([3.0, 4.0, 3.5], n)])
    state = gw.initial_state(xy, rng.uniform(-math.pi, math.pi, n))
    worst, inside, state = _walk(state, params, 100_000, rng)
    assert inside
    assert worst <= VDT + 1e-12
    assert np.ptp(state[:, 0]) > 0.5  # they did move around


@pytest.mark.slow
def test_an_area_thinner_than_one_step_folds_every_path_inside():
    params = gw.WalkerParams(area=(0.0, 0.0, 0.03, 0.011))  # several walls crossed per tick
    rng = np.random.default_rng(8)
    state = gw.initial_state(np.column_stack([rng.uniform(0, 0.03, 64), rng.uniform(0, 0.011, 64)]),
                             rng.uniform(-math.pi, math.pi, 64))
    worst, inside, _ = _walk(state, params, 5_000, rng)
    assert inside and worst <= VDT + 1e-12


def test_objects_pushed_into_every_wall_of_the_paper_area_stay_inside():
    rng = np.random.default_rng(9)
    n = 400
    side = rng.integers(0, 4, n)
    t = rng.uniform(0, 400, n)
    xy = np.where(side[:, None] == 0, np.column_stack([np.zeros(n), t]),
                  np.where(side[:, None] == 1, np.column_stack([np.full(n, 400.0), t]),
                           np.where(side[:, None] == 2, np.column_stack([t, np.zeros(n)]),
                                    np.column_stack([t, np.full(n, 400.0)]))))
    outward = np.array([math.pi, 0.0, -math.pi / 2, math.pi / 2])[side] + rng.uniform(-1.5, 1.5, n)
    state = gw.initial_state(xy, outward)
    state[:, gw.YAW_RATE] = rng.uniform(-2, 2, n)  # tight circles against the walls
    worst, inside, _ = _walk(state, P, 2_000, rng)
    assert inside and worst <= VDT + 1e-12


@pytest.mark.slow
def test_yaw_rate_spreads_like_the_random_walk_of_the_equation():
    # x5 is white (x5 = v), so x4 after K ticks sums K - 1 draws: std = T_d·(π/8)/√3·√(K - 1)
    rng = np.random.default_rng(11)
    n = 4000
    state = gw.initial_state(rng.uniform(0, 400, (n, 2)), rng.uniform(-math.pi, math.pi, n))
    v = gw.draw_inputs(rng, 801, n, P)
    spread = {}
    for k in range(801):
        state = gw.step(state, v[k], P, DT)
        np.testing.assert_array_equal(state[:, gw.YAW_ACCEL], v[k])  # white: the fresh draw itself
        if k + 1 in (201, 801):
            spread[k + 1] = np.std(state[:, gw.YAW_RATE])
    per_tick = DT * P.yaw_accel_bound / math.sqrt(3)
    assert per_tick == pytest.approx(0.01134, abs=1e-5)
    assert spread[201] == pytest.approx(per_tick * math.sqrt(200), rel=0.05)
    assert spread[801] == pytest.approx(per_tick * math.sqrt(800), rel=0.05)
    assert spread[801] / spread[201] == pytest.approx(2.0, rel=0.08)  # grows like √t


def test_truth4_is_position_and_velocity():
    s = gw.initial_state([[1.0, 2.0]], [math.pi / 2])
    np.testing.assert_allclose(gw.truth4(s, gw.WalkerParams(speed=1.6)), [[1.0, 2.0, 0.0, 1.6]], atol=1e-15)


def _walkers(rng, n, near_wall):
    """``n`` walker states anywhere in the paper area, or within a tick of its walls (headings towards them too)."""
    xy = rng.uniform(0.0, 400.0, (n, 2))
    if near_wall:
        xy = np.where(rng.random((n, 2)) < 0.5, rng.uniform(0.0, VDT, (n, 2)), 400.0 - rng.uniform(0.0, VDT, (n, 2)))
    return np.column_stack([xy, rng.uniform(-4, 4, n), rng.uniform(-1, 1, n), rng.uniform(-0.4, 0.4, n)])


@pytest.mark.parametrize("near_wall", [False, True])
def test_the_compiled_step_equals_the_reference_bit_for_bit(near_wall):
    """:func:`step_compiled` gives :func:`step`'s very numbers: compiled inside the area, the reference itself for a
    tick where a walker crosses a wall; with the heading's cos and sin given (as the world does) or not."""
    rng = np.random.default_rng(7)
    crossed = 0
    for _ in range(300):
        s = _walkers(rng, 6, near_wall)
        v = rng.uniform(-P.yaw_accel_bound, P.yaw_accel_bound, 6)
        ref = gw.step(s, v, P, DT)
        trig = (np.cos(s[:, gw.HEADING]), np.sin(s[:, gw.HEADING]))
        np.testing.assert_array_equal(gw.step(s, v, P, DT, trig=trig), ref)
        np.testing.assert_array_equal(gw.step_compiled(s, v, P, DT), ref)
        np.testing.assert_array_equal(gw.step_compiled(s, v, P, DT, trig=trig), ref)
        crossed += not np.array_equal(ref[:, :2], s[:, :2] + VDT * np.column_stack(trig))
    assert (crossed > 100) == near_wall  # the walls were (or were not) reached


def test_truth4_takes_the_heading_cos_and_sin_it_is_given():
    s = _walkers(np.random.default_rng(3), 5, False)
    trig = (np.cos(s[:, gw.HEADING]), np.sin(s[:, gw.HEADING]))
    np.testing.assert_array_equal(gw.truth4(s, P, trig=trig), gw.truth4(s, P))
