"""The simulated vehicle's commander (autopilot/commander.py): PX4's arming rules, modes, commands and the offboard
setpoint stream's failsafe, without sockets."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot import px4
from swarmtrack.autopilot.commander import ACCEPTED, DENIED, REJECTED, UNSUPPORTED, Commander
from swarmtrack.autopilot.params import Parameters

ARM, MODE = mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavlink.MAV_CMD_DO_SET_MODE
CUSTOM = float(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
NAN = math.nan


def _commander(airborne=True, **values):
    said = []
    c = Commander(Parameters(values), lambda severity, text: said.append((severity, text)), airborne=airborne)
    return c, said


def _p(*params):
    return (*params, *[0.0] * (7 - len(params)))


def _setpoint(time_boot_ms=0, mask=px4.ACCELERATION, frame=mavlink.MAV_FRAME_LOCAL_NED):
    return mavlink.MAVLink_set_position_target_local_ned_message(time_boot_ms, 1, 1, frame, mask, 0, 0, 0, 0, 0, 0,
                                                                 0.5, 0.25, 0, 0, 0)


def _offboard(c, now=0.0):
    assert c.take_setpoint(_setpoint(), now)
    assert c.command(MODE, _p(CUSTOM, px4.OFFBOARD), now, False, np.zeros(3)) == ACCEPTED and c.offboard()


def test_a_disarm_in_flight_is_refused_as_px4_refuses_it_unless_forced():
    c, said = _commander()
    assert c.command(ARM, _p(0.0), 0.0, False, np.zeros(3)) == REJECTED and c.armed
    assert said == [(mavlink.MAV_SEVERITY_CRITICAL, "Disarming denied: not landed")]
    assert c.command(ARM, _p(0.0, px4.FORCE_MAGIC), 0.0, False, np.zeros(3)) == ACCEPTED and not c.armed
    c, _ = _commander()
    assert c.command(ARM, _p(0.0), 0.0, True, np.zeros(3)) == ACCEPTED and not c.armed  # landed: no force needed


def test_arming_on_the_ground_sets_home_there():
    c, _ = _commander(airborne=False)
    assert not c.armed and c.home is None
    assert c.command(ARM, _p(1.0), 0.0, True, np.array([3.0, 4.0, 0.0])) == ACCEPTED and c.armed
    assert np.array_equal(c.home, [3.0, 4.0, 0.0])


@pytest.mark.parametrize("main, sub, result, mode", [
    (px4.AUTO, px4.AUTO_LOITER, ACCEPTED, (px4.AUTO, px4.AUTO_LOITER)),  # Hold keeps its sub mode
    (px4.AUTO, px4.AUTO_LAND, ACCEPTED, (px4.AUTO, px4.AUTO_LAND)),
    (px4.AUTO, px4.AUTO_RTL, ACCEPTED, (px4.AUTO, px4.AUTO_RTL)),
    (px4.AUTO, 0, REJECTED, (px4.POSCTL, 0)),  # Mission (Auto without sub mode): nothing to fly
    (px4.AUTO, 42, DENIED, (px4.POSCTL, 0)),  # "Unsupported auto mode"
    (px4.ACRO, 0, REJECTED, (px4.POSCTL, 0)),
    (px4.OFFBOARD, 0, REJECTED, (px4.POSCTL, 0)),  # no offboard signal
])
def test_do_set_mode_with_main_and_sub_modes(main, sub, result, mode):
    c, said = _commander()
    c.home = np.zeros(3)
    assert c.command(MODE, _p(CUSTOM, main, sub), 0.0, False, np.zeros(3)) == result
    assert (c.main, c.sub) == mode
    if result == REJECTED:
        assert said[-1][1] == f"Switching to {px4.mode_name(main, sub or px4.AUTO_MISSION)} is currently not available"


def test_return_needs_a_home_and_an_unknown_command_is_unsupported():
    c, _ = _commander(airborne=False)
    assert c.command(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, _p(), 0.0, True, np.zeros(3)) == REJECTED
    assert c.command(mavlink.MAV_CMD_DO_REPOSITION, _p(), 0.0, True, np.zeros(3)) == UNSUPPORTED
    assert c.command(MODE, _p(0.0, px4.POSCTL), 0.0, True, np.zeros(3)) == DENIED  # base mode switching


def test_offboard_needs_a_fresh_stream_and_its_loss_after_com_of_loss_t_is_the_failsafe():
    c, said = _commander()
    assert c.take_setpoint(_setpoint(), 0.0)
    assert c.command(MODE, _p(CUSTOM, px4.OFFBOARD), 1.5, False, np.zeros(3)) == REJECTED  # 1.5 s old
    _offboard(c, now=2.0)
    c.update(2.99, False, -3.0)  # 0.99 s after the setpoint: still fresh (COM_OF_LOSS_T = 1 s)
    assert c.main == px4.OFFBOARD and not [t for _, t in said if "Failsafe" in t]
    c.update(3.01, False, -3.0)
    assert (c.main, c.sub) == (px4.POSCTL, 0) and c.armed  # COM_OBL_RC_ACT 0: Position
    assert said[-1] == (mavlink.MAV_SEVERITY_CRITICAL, "Failsafe activated") and c.failsafes == [(3.01, "Position")]
    c.update(5.0, False, -3.0)
    assert [t for _, t in said].count("Failsafe activated") == 1


@pytest.mark.parametrize("action, mode, armed", [
    (5, (px4.AUTO, px4.AUTO_LOITER), True), (3, (px4.AUTO, px4.AUTO_RTL), True), (4, (px4.AUTO, px4.AUTO_LAND), True),
    (1, (px4.ALTCTL, 0), True), (7, (px4.POSCTL, 0), False),
])
def test_the_offboard_loss_action_is_com_obl_rc_act(action, mode, armed):
    c, _ = _commander(COM_OBL_RC_ACT=action, COM_OF_LOSS_T=0.5)
    _offboard(c)
    c.update(0.6, False, -3.0)
    assert (c.main, c.sub) == mode and c.armed == armed


def test_setpoints_px4_drops_are_counted_and_said_once_a_second():
    c, said = _commander()
    for k in range(10):
        assert not c.take_setpoint(_setpoint(frame=mavlink.MAV_FRAME_LOCAL_OFFSET_NED), 0.05 * k)
    assert c.refused == {"SET_POSITION_TARGET_LOCAL_NED coordinate frame 7 unsupported": 10}
    assert [t for _, t in said] == ["SET_POSITION_TARGET_LOCAL_NED coordinate frame 7 unsupported"]
    assert c.setpoint is None and c.setpoint_ms == -1  # no offboard signal


def test_auto_disarm_after_landing_and_before_takeoff():
    c, said = _commander(COM_DISARM_LAND=2.0)
    c.update(0.0, False, -3.0)
    c.update(1.0, True, 0.0)  # touched down
    c.update(2.9, True, 0.0)
    assert c.armed
    c.update(3.0, True, 0.0)
    assert not c.armed and said[-1] == (mavlink.MAV_SEVERITY_INFO, "Disarmed by landing")
    c, said = _commander(airborne=False, COM_DISARM_PRFLT=10.0)
    c.command(ARM, _p(1.0), 5.0, True, np.zeros(3))
    c.update(14.9, True, 0.0)
    assert c.armed
    c.update(15.0, True, 0.0)
    assert not c.armed and [t for _, t in said] == ["Armed by external command", "Disarmed by auto preflight disarming"]


def test_takeoff_climbs_to_mis_takeoff_alt_then_holds_there():
    c, said = _commander(airborne=False)
    c.command(ARM, _p(1.0), 0.0, True, np.zeros(3))
    assert c.command(mavlink.MAV_CMD_NAV_TAKEOFF, _p(0, 0, 0, NAN, NAN, NAN, NAN), 0.0, True, np.zeros(3)) == ACCEPTED
    _, az = c.fly(0.0, np.zeros(3), np.zeros(3), True)
    assert az < 0 and c.target_z == -2.5  # up, to 2.5 m above home
    c.update(0.5, True, 0.0)
    c.update(1.0, False, -2.45)
    assert (c.main, c.sub) == (px4.AUTO, px4.AUTO_LOITER) and c.anchor[2] == -2.5
    assert said[-1] == (mavlink.MAV_SEVERITY_INFO, "Takeoff detected")
    c.update(9.0, True, 0.0)
    assert said[-1] == (mavlink.MAV_SEVERITY_INFO, "Landing detected")


def test_nan_parameters_are_unset_as_px4_reads_mavsdks_commands():
    c, _ = _commander(airborne=False)
    nans = (NAN,) * 6
    assert c.command(ARM, (1.0, *nans), 0.0, True, np.zeros(3)) == ACCEPTED and c.armed  # MAVSDK's arm()
    c.command(mavlink.MAV_CMD_NAV_TAKEOFF, _p(0, 0, 0, NAN, NAN, NAN, NAN), 0.0, True, np.zeros(3))
    c.update(5.0, False, -2.5)
    assert c.command(ARM, (0.0, *nans), 5.0, False, np.zeros(3)) == REJECTED and c.armed  # NaN is no force
    assert c.command(MODE, (CUSTOM, px4.AUTO, px4.AUTO_LAND, NAN, NAN, NAN, NAN), 5.0, False, np.zeros(3)) == ACCEPTED


def _simulate(c: Commander, p, v, seconds: float, t0: float = 0.0, dt: float = 0.02):
    """The commander flying a point mass and its own vertical channel for ``seconds``: (t, p, v, modes seen)."""
    from swarmtrack.autopilot.flight import Vertical

    ch, p, v, seen, t = Vertical(p[2]), np.array(p[:2], float), np.array(v[:2], float), [], t0
    for _ in range(int(seconds / dt)):
        c.update(t, ch.on_ground, ch.z)
        acc, az = c.fly(t, np.array([*p, ch.z]), np.array([*v, ch.vz]), ch.on_ground)
        ch.advance(dt, az, c.armed)
        if ch.on_ground:
            v[:] = 0.0
        else:
            p, v = p + dt * v + 0.5 * dt * dt * acc, v + dt * acc
        t += dt
        if not seen or seen[-1] != (c.main, c.sub, c.phase, c.armed):
            seen.append((c.main, c.sub, c.phase, c.armed))
    return t, np.array([*p, ch.z]), v, seen


def test_hold_brakes_at_mpc_acc_hor_and_holds_where_it_stops():
    c, _ = _commander()
    assert c.command(MODE, _p(CUSTOM, px4.AUTO, px4.AUTO_LOITER), 0.0, False, np.zeros(3)) == ACCEPTED
    _, p, v, _ = _simulate(c, (0.0, 0.0, -10.0), (6.0, 0.0), 20.0)
    assert np.linalg.norm(v) < 0.01 and abs(p[0] - 6.0) < 0.05 and abs(p[1]) < 1e-9 and abs(p[2] + 10) < 0.01


def test_return_climbs_flies_home_descends_and_lands_then_disarms():
    c, _ = _commander(RTL_RETURN_ALT=8.0, RTL_DESCEND_ALT=4.0, COM_DISARM_LAND=1.0)
    c.home = np.array([0.0, 0.0, 0.0])
    assert c.command(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, _p(), 0.0, False, np.zeros(3)) == ACCEPTED
    _, p, _, seen = _simulate(c, (30.0, -40.0, -3.0), (0.0, 0.0), 60.0)
    phases = [s[2] for s in seen if s[3]]
    assert phases == ["climb", "return", "descend", "land"] and seen[-1][3] is False  # disarmed on the ground
    assert np.linalg.norm(p[:2]) < 0.6 and p[2] == 0.0


def test_a_setpoint_stamped_in_the_callers_future_is_no_offboard_signal():
    c, _ = _commander()
    assert c.take_setpoint(_setpoint(), 1.7e9)  # a clock that was not the run's (issue 37)
    assert not c.fresh(3.0) and c.command(MODE, _p(CUSTOM, px4.OFFBOARD), 3.0, False, np.zeros(3)) == REJECTED


def test_return_with_rtl_land_delay_minus_one_hovers_above_home_for_good():
    c, _ = _commander(RTL_RETURN_ALT=8.0, RTL_DESCEND_ALT=4.0, RTL_LAND_DELAY=-1.0)
    c.home = np.zeros(3)
    c.command(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, _p(), 0.0, False, np.zeros(3))
    _, p, _, seen = _simulate(c, (30.0, -40.0, -3.0), (0.0, 0.0), 60.0)
    assert [s[2] for s in seen] == ["climb", "return", "descend"] and c.armed
    assert np.linalg.norm(p[:2]) < 0.05 and abs(p[2] + 4.0) < 0.05
