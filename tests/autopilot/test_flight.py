"""PX4's position control as the simulated vehicle flies it (autopilot/flight.py): setpoints built from
SET_POSITION_TARGET_LOCAL_NED as PX4's receiver builds them, and the position → velocity → acceleration cascade."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot import px4
from swarmtrack.autopilot.flight import (
    G,
    Limits,
    Setpoint,
    Vertical,
    attitude_of,
    constrain_xy,
    global_setpoint_of,
    horizontal,
    setpoint_of,
    stopping_point,
    vertical,
)


def _wire(mask: int, frame: int = mavlink.MAV_FRAME_LOCAL_NED, pos=(0, 0, 0), vel=(0, 0, 0), acc=(0, 0, 0),
          yaw=0.0):
    """A SET_POSITION_TARGET_LOCAL_NED as it arrives: encoded (float32) and decoded by pymavlink."""
    codec = mavlink.MAVLink(None, 1, 191)
    msg = mavlink.MAVLink_set_position_target_local_ned_message(0, 1, 1, frame, mask, *pos, *vel, *acc, yaw, 0.0)
    return codec.decode(bytearray(msg.pack(codec)))


def _fly(sp: Setpoint, p, v, seconds: float, lim: Limits | None = None, dt: float = 0.005):
    """A double integrator flown by the horizontal cascade for ``seconds``: (position, velocity, max speed)."""
    p, v, top, lim = np.array(p, float), np.array(v, float), 0.0, lim or Limits()
    for _ in range(int(seconds / dt)):
        a = horizontal(sp, p, v, lim)
        v = v + dt * a
        p = p + dt * v
        top = max(top, float(np.linalg.norm(v)))
    return p, v, top


def test_an_acceleration_setpoint_is_flown_exactly_as_its_float32_value_even_beyond_the_tilt_limit():
    rng = np.random.default_rng(5)
    for acc in [*rng.normal(0, 3, size=(50, 2)), np.array([30.0, -25.0])]:
        sp, why = setpoint_of(_wire(px4.ACCELERATION, acc=(*acc, 0.0)), 0.0)
        assert why is None
        a = horizontal(sp, np.array([100.0, -40.0]), np.array([3.0, 4.0]), Limits())
        assert np.array_equal(a, np.asarray(acc, dtype=np.float32).astype(float))  # bit for bit
    assert np.linalg.norm(a) > G  # beyond g·tan(45°): not clipped


def test_a_velocity_setpoint_is_reached_with_pxs_velocity_gain():
    sp, _ = setpoint_of(_wire(px4.VELOCITY, vel=(1.0, -2.0, 0.0)), 0.0)
    _, v, _ = _fly(sp, (0, 0), (0, 0), 3.0)
    # first order at MPC_XY_VEL_P_ACC = 1.8/s: e^(-5.4) = 0.5 % left after 3 s
    assert np.allclose(v, [1.0, -2.0], atol=0.01 * math.sqrt(5)) and not np.allclose(v, [1.0, -2.0], atol=1e-4)


def test_a_position_setpoint_is_reached_without_overshoot_and_at_most_at_mpc_xy_vel_max():
    sp, _ = setpoint_of(_wire(px4.POSITION, pos=(200.0, 0.0, -5.0)), 0.0)
    p, v, top = _fly(sp, (0, 0), (0, 0), 40.0)
    assert np.linalg.norm(p - [200.0, 0.0]) < 0.05 and np.linalg.norm(v) < 0.05
    assert 11.5 < top <= Limits().xy_vel_max + 1e-9  # it did fly at the limit, never above
    near, _, _ = _fly(sp, (190, 0), (0, 0), 15.0)
    assert near[0] <= 200.0 + 0.2  # damped (ζ = 0.69): under 2 % of 10 m


def test_position_with_velocity_feed_forward_tracks_a_moving_point():
    lim, dt, p, v = Limits(), 0.005, np.zeros(2), np.zeros(2)
    target_v = np.array([2.0, 1.0])
    for k in range(int(20 / dt)):
        t = k * dt
        sp = Setpoint(position=np.array([*(3.0 + target_v * t), 0.0]), velocity=np.array([*target_v, 0.0]))
        a = horizontal(sp, p, v, lim)
        v, p = v + dt * a, p + dt * (v + dt * a)
    assert np.linalg.norm(p - (3.0 + target_v * 20)) < 0.01


def test_constrain_xy_keeps_the_position_term_first_as_px4():
    v0, v1 = np.array([3.0, 0.0]), np.array([0.0, 10.0])
    out = constrain_xy(v0, v1, 5.0)
    assert math.isclose(np.linalg.norm(out), 5.0) and math.isclose(out[0], 3.0) and math.isclose(out[1], 4.0)
    assert np.allclose(constrain_xy(np.array([8.0, 0.0]), v1, 5.0), [5.0, 0.0])  # v0 alone exceeds it
    assert np.allclose(constrain_xy(np.array([1.0, 1.0]), np.array([1.0, 0.0]), 5.0), [2.0, 1.0])  # within


@pytest.mark.parametrize("mask, frame, text", [
    (px4.ACCELERATION, mavlink.MAV_FRAME_LOCAL_OFFSET_NED, "coordinate frame 7 unsupported"),
    (px4.ACCELERATION, mavlink.MAV_FRAME_GLOBAL, "coordinate frame 0 unsupported"),
    (px4.ACCELERATION | mavlink.POSITION_TARGET_TYPEMASK_FORCE_SET, mavlink.MAV_FRAME_LOCAL_NED, "force not supported"),
    (0xFFF, mavlink.MAV_FRAME_LOCAL_NED, "invalid"),
])
def test_setpoints_px4_drops_are_refused_with_its_text(mask, frame, text):
    sp, why = setpoint_of(_wire(mask, frame, acc=(1.0, 1.0, 0.0)), 0.0)
    assert sp is None and why == f"SET_POSITION_TARGET_LOCAL_NED {text}"


def test_body_ned_velocity_is_rotated_by_the_vehicles_yaw_and_has_no_position():
    sp, _ = setpoint_of(_wire(px4.VELOCITY, mavlink.MAV_FRAME_BODY_NED, pos=(9, 9, 9), vel=(1.0, 0.0, 0.5)),
                        math.pi / 2)  # facing east: forward is east
    assert np.allclose(sp.velocity, [0.0, 1.0, 0.5], atol=1e-12) and np.isnan(sp.position).all()


def test_an_x_without_y_is_invalid_and_brakes_as_pxs_failsafe_setpoint():
    sp = Setpoint(position=np.array([5.0, math.nan, 0.0]))
    assert not sp.horizontal_valid()
    v = np.array([2.0, -1.0])
    assert np.allclose(horizontal(sp, np.zeros(2), v, Limits()), -1.8 * v)


def test_vertical_climb_is_limited_and_the_channel_lands_and_falls():
    lim, ch = Limits(), Vertical(0.0)
    sp = Setpoint(position=np.array([math.nan, math.nan, -10.0]))
    top = 0.0
    for _ in range(1000):  # 10 s towards 10 m at a 1.5 m/s climb limit
        ch.advance(0.01, vertical(sp, ch.z, ch.vz, lim, climb=1.5), True)
        top = max(top, -ch.vz)
    assert abs(ch.z + 10.0) < 0.05 and 1.45 < top <= 1.5 + 1e-6
    ch.advance(5.0, 0.0, False)  # disarmed: it falls, and stops on the ground
    assert ch.on_ground and ch.z == 0.0 and ch.vz == 0.0


def test_stopping_point_and_attitude():
    assert np.allclose(stopping_point(np.zeros(2), np.array([6.0, 0.0]), 3.0), [6.0, 0.0])  # v²/2a
    roll, pitch, yaw = attitude_of(np.array([G, 0.0]), 0.0)  # forward (north) at g: nose down 45°
    assert math.isclose(pitch, -math.pi / 4) and abs(roll) < 1e-12 and yaw == 0.0
    roll, pitch, _ = attitude_of(np.array([0.0, 1.0]), 0.0)  # to the right (east): roll right
    assert roll > 0 and math.isclose(roll, math.atan2(1.0, G)) and abs(pitch) < 1e-12


def test_a_global_position_setpoint_is_projected_about_the_origin_as_px4_does():
    from swarmtrack.autopilot.geodesy import PX4_SITL

    lat, lon, alt = PX4_SITL.to_global(120.0, -35.0, -20.0)
    codec = mavlink.MAVLink(None, 1, 191)
    mask = px4.POSITION
    for frame, z_alt, home, z in [(mavlink.MAV_FRAME_GLOBAL_INT, alt, None, -20.0),
                                  (mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 15.0, np.array([0, 0, -1.0]), -16.0)]:
        msg = mavlink.MAVLink_set_position_target_global_int_message(0, 1, 1, frame, mask, round(lat * 1e7),
                                                                     round(lon * 1e7), z_alt, 0, 0, 0, 0, 0, 0, 0, 0)
        sp, why = global_setpoint_of(codec.decode(bytearray(msg.pack(codec))), PX4_SITL, home)
        assert why is None and np.allclose(sp.position, [120.0, -35.0, z], atol=0.02)  # 1e-7° ≈ 1.1 cm
    msg = mavlink.MAVLink_set_position_target_global_int_message(0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, mask, 0, 0, 0,
                                                                 0, 0, 0, 0, 0, 0, 0, 0)
    assert global_setpoint_of(msg, PX4_SITL, None) == (None,
                                                       "SET_POSITION_TARGET_GLOBAL_INT invalid coordinate frame 1")
