"""The simulated vehicle's telemetry streams and their commands (PX4's default rates per MAVLink mode,
SET_MESSAGE_INTERVAL, REQUEST_MESSAGE), its battery model and the local ↔ global conversion: requests encoded by a
pymavlink client, replies decoded from the bytes the vehicle's MAVLink object wrote, on a simulated clock."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink
from tests.autopilot.wire import Wire

from swarmtrack.autopilot.geodesy import EARTH_RADIUS, PX4_SITL, Origin
from swarmtrack.autopilot.params import Parameters
from swarmtrack.autopilot.state import VehicleState
from swarmtrack.autopilot.telemetry import (
    CAPABILITIES,
    NORMAL,
    ONBOARD,
    UID_BASE,
    Battery,
    Streams,
    quaternion,
)

SYSTEM, COMPONENT = 3, mavlink.MAV_COMP_ID_AUTOPILOT1
ID = {name: getattr(mavlink, f"MAVLINK_MSG_ID_{name}") for name in (
    "HEARTBEAT", "SYS_STATUS", "ATTITUDE", "HOME_POSITION", "GLOBAL_POSITION_INT", "AUTOPILOT_VERSION",
    "LOCAL_POSITION_NED", "GPS_RAW_INT", "HIGHRES_IMU", "BATTERY_STATUS")}


def _state(**kw) -> VehicleState:
    s = VehicleState(system=SYSTEM, boot_ms=kw.pop("boot_ms", 1000))
    for k, v in kw.items():
        setattr(s, k, np.asarray(v, dtype=float) if k in ("position", "velocity", "attitude", "home") else v)
    return s


def _long(cmd: int, *params: float, target=(SYSTEM, COMPONENT)):
    p = list(params) + [0.0] * (7 - len(params))
    return mavlink.MAVLink_command_long_message(*target, cmd, 0, *p)


def _run(streams: Streams, wire: Wire, seconds: float, state: VehicleState, dt: float = 0.001) -> Counter:
    """Tick every ``dt`` for ``seconds``; how many of each message went out."""
    for k in range(int(round(seconds / dt))):
        streams.tick(k * dt, state)
    return Counter(m.get_type() for m in wire.replies())


def test_default_rates_are_px4s_for_each_mode():
    w = Wire(SYSTEM)
    onboard, normal = Streams(w.mav, ONBOARD), Streams(w.mav, NORMAL)
    assert onboard.interval(ID["ATTITUDE"]) == pytest.approx(1 / 100) and normal.interval(ID["ATTITUDE"]) == \
        pytest.approx(1 / 15)
    assert onboard.interval(ID["GLOBAL_POSITION_INT"]) == pytest.approx(1 / 50)
    assert normal.interval(ID["SYS_STATUS"]) == pytest.approx(1.0) and onboard.interval(ID["SYS_STATUS"]) == \
        pytest.approx(0.2)
    assert onboard.interval(ID["GPS_RAW_INT"]) == pytest.approx(0.1)  # PX4's "unlimited", here 10 Hz
    assert onboard.interval(ID["AUTOPILOT_VERSION"]) is None  # on request only
    assert onboard.interval(ID["LOCAL_POSITION_NED"]) is None  # the vehicle's own
    assert Streams(w.mav, NORMAL, local_position=True).interval(ID["LOCAL_POSITION_NED"]) == pytest.approx(1.0)
    with pytest.raises(ValueError):
        Streams(w.mav, "gimbal")


def test_a_second_of_ticks_sends_each_stream_at_its_rate():
    w = Wire(SYSTEM)
    counts = _run(Streams(w.mav, NORMAL), w, 2.0, _state(home=[0, 0, 0]))
    assert counts["ATTITUDE"] == 30 and counts["ATTITUDE_QUATERNION"] == 20 and counts["GLOBAL_POSITION_INT"] == 10
    assert counts["SYS_STATUS"] == 2 and counts["EXTENDED_SYS_STATE"] == 2 and counts["VFR_HUD"] == 8
    assert counts["HOME_POSITION"] == 1 and counts["BATTERY_STATUS"] == 1 and counts["GPS_RAW_INT"] == 10
    assert counts["AUTOPILOT_VERSION"] == 0 and counts["LOCAL_POSITION_NED"] == 0 and counts["HEARTBEAT"] == 0
    w2 = Wire(SYSTEM)
    counts = _run(Streams(w2.mav, ONBOARD), w2, 1.0, _state())
    assert counts["ATTITUDE"] == 100 and counts["GLOBAL_POSITION_INT"] == 50 and counts["SYS_STATUS"] == 5
    assert counts["HOME_POSITION"] == 0  # no home yet: PX4 sends none


def test_a_stream_is_sent_at_most_once_per_tick():
    w = Wire(SYSTEM)
    counts = _run(Streams(w.mav, ONBOARD), w, 1.0, _state(), dt=0.05)  # ticking at 20 Hz
    assert counts["ATTITUDE"] == 20 and counts["SYS_STATUS"] == 5


def test_set_message_interval_sets_stops_and_restores_as_px4():
    w = Wire(SYSTEM)
    s = Streams(w.mav, NORMAL)
    state = _state()
    assert s.handle(w.received(_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, ID["ATTITUDE"], 200000)), state)
    (ack,) = w.replies()
    assert ack.get_type() == "COMMAND_ACK" and ack.result == mavlink.MAV_RESULT_ACCEPTED
    assert (ack.target_system, ack.target_component) == (255, 190)
    assert _run(s, w, 1.0, state)["ATTITUDE"] == 5
    s.handle(w.received(_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, ID["ATTITUDE"], -1)), state)
    w.replies()
    assert _run(s, w, 1.0, state)["ATTITUDE"] == 0
    s.handle(w.received(_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, ID["ATTITUDE"], 0)), state)
    w.replies()
    assert s.interval(ID["ATTITUDE"]) == pytest.approx(1 / 15)
    for bad in ((ID["HEARTBEAT"], 1e5), (ID["HIGHRES_IMU"], 1e5), (ID["ATTITUDE"], 1e5, 0, 0, 0, 0, 2)):
        s.handle(w.received(_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, *bad)), state)
        (ack,) = w.replies()
        assert ack.result == mavlink.MAV_RESULT_FAILED
    assert s.interval(ID["ATTITUDE"]) == pytest.approx(1 / 15)
    command_int = mavlink.MAVLink_command_int_message(SYSTEM, COMPONENT, 0, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
                                                      0, 0, ID["SYS_STATUS"], 500000, 0, 0, 0, 0, 0)
    assert s.handle(w.received(command_int), state)
    (ack,) = w.replies()
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED and s.interval(ID["SYS_STATUS"]) == pytest.approx(0.5)
    s.handle(w.received(_long(mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, ID["SYS_STATUS"])), state)
    interval, ack = w.replies()
    assert interval.get_type() == "MESSAGE_INTERVAL" and interval.interval_us == 500000
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED


def test_autopilot_version_on_request_then_the_ack():
    w = Wire(SYSTEM)
    s = Streams(w.mav)
    assert s.handle(w.received(_long(mavlink.MAV_CMD_REQUEST_MESSAGE, ID["AUTOPILOT_VERSION"])), _state())
    version, ack = w.replies()
    assert version.get_type() == "AUTOPILOT_VERSION" and ack.result == mavlink.MAV_RESULT_ACCEPTED
    for cap in ("MISSION_INT", "COMMAND_INT", "PARAM_ENCODE_BYTEWISE", "SET_POSITION_TARGET_LOCAL_NED", "MAVLINK2"):
        assert version.capabilities & getattr(mavlink, f"MAV_PROTOCOL_CAPABILITY_{cap}")
    assert not version.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_FTP
    assert version.capabilities == CAPABILITIES
    assert (version.flight_sw_version >> 24, (version.flight_sw_version >> 16) & 0xFF) == (1, 14)
    assert version.uid == UID_BASE + SYSTEM - 1 and version.uid2[-1] == SYSTEM
    # the older command, to any component of this system or broadcast
    s.handle(w.received(_long(mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1, target=(0, 0))), _state())
    assert [m.get_type() for m in w.replies()] == ["AUTOPILOT_VERSION", "COMMAND_ACK"]


def test_home_position_is_denied_before_home_and_sent_after():
    w = Wire(SYSTEM)
    s = Streams(w.mav, origin=Origin(10.0, 20.0, 100.0))
    s.handle(w.received(_long(mavlink.MAV_CMD_REQUEST_MESSAGE, ID["HOME_POSITION"])), _state())
    (ack,) = w.replies()
    assert ack.result == mavlink.MAV_RESULT_DENIED
    s.handle(w.received(_long(mavlink.MAV_CMD_GET_HOME_POSITION)), _state(home=[100.0, 0.0, -5.0]))
    home, ack = w.replies()
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED and home.get_type() == "HOME_POSITION"
    assert home.latitude * 1e-7 == pytest.approx(10.0 + math.degrees(100.0 / EARTH_RADIUS), abs=2e-7)
    assert home.longitude == 200000000 and home.altitude == 105000 and (home.x, home.y, home.z) == (100.0, 0.0, -5.0)


def test_global_position_and_attitude_come_from_the_state():
    w = Wire(SYSTEM)
    s = Streams(w.mav, origin=PX4_SITL)
    state = _state(boot_ms=4321, position=[1000.0, -500.0, -20.0], velocity=[1.5, -2.25, -0.5],
                   attitude=[0.1, -0.2, -math.pi / 2], home=[0.0, 0.0, -2.0])
    s.send(ID["GLOBAL_POSITION_INT"], state)
    s.send(ID["ATTITUDE"], state)
    g, a = w.replies()
    lat, lon, alt = PX4_SITL.to_global(1000.0, -500.0, -20.0)
    assert (g.lat, g.lon, g.alt) == (round(lat * 1e7), round(lon * 1e7), 508000)
    assert g.lat > PX4_SITL.lat * 1e7 and g.lon < PX4_SITL.lon * 1e7  # north and west of the origin
    assert g.relative_alt == 18000 and (g.vx, g.vy, g.vz) == (150, -225, -50) and g.hdg == 27000
    assert g.time_boot_ms == 4321 and a.time_boot_ms == 4321
    assert (a.roll, a.pitch, a.yaw) == pytest.approx((0.1, -0.2, -math.pi / 2))


def test_sys_status_and_extended_sys_state():
    w = Wire(SYSTEM)
    s = Streams(w.mav)
    s.send(mavlink.MAVLINK_MSG_ID_SYS_STATUS, _state())
    s.send(mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, _state(landed=mavlink.MAV_LANDED_STATE_IN_AIR))
    status, ext = w.replies()
    for bit in (mavlink.MAV_SYS_STATUS_SENSOR_GPS, mavlink.MAV_SYS_STATUS_PREARM_CHECK,
                mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO):
        assert status.onboard_control_sensors_present & bit and status.onboard_control_sensors_health & bit
    assert not status.onboard_control_sensors_present & mavlink.MAV_SYS_STATUS_SENSOR_RC_RECEIVER
    assert status.voltage_battery == 16200 and status.battery_remaining == 100
    assert ext.landed_state == mavlink.MAV_LANDED_STATE_IN_AIR and ext.vtol_state == mavlink.MAV_VTOL_STATE_UNDEFINED


def test_battery_drains_as_px4_sitls_while_armed():
    params = Parameters()
    b = Battery(params)
    b.update(False, 0)
    assert b.remaining == 1.0 and b.voltage == pytest.approx(4 * 4.05, rel=1e-6)
    b.update(True, 1000)
    b.update(True, 11000)
    b.update(True, 11000)  # a second link's update at the same time changes nothing
    assert b.remaining == pytest.approx(1 - 10 / 60)
    assert b.voltage == pytest.approx(4 * (3.6 + (1 - 10 / 60) * 0.45), rel=1e-6)
    b.update(True, 100000)
    assert b.remaining == pytest.approx(0.5)  # SIM_BAT_MIN_PCT
    params.set("SIM_BAT_MIN_PCT", 0.0)
    b.update(True, 200000)
    assert b.remaining == 0.0 and b.charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_EMERGENCY
    b.update(False, 201000)
    assert b.remaining == 1.0 and b.charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_OK
    w = Wire(SYSTEM)
    s = Streams(w.mav, battery=b)
    s.tick(0.0, _state(armed=True, boot_ms=0))
    s.tick(0.0, _state(armed=True, boot_ms=30000))
    s.send(ID["BATTERY_STATUS"], _state(armed=True, boot_ms=30000))
    status = w.replies()[-1]
    assert status.get_type() == "BATTERY_STATUS" and status.battery_remaining == 50
    assert status.voltages[0] == round(b.voltage * 1000) and status.voltages[1] == 65535


def test_commands_for_others_are_left_to_the_vehicle():
    w = Wire(SYSTEM)
    s = Streams(w.mav)
    assert not s.handle(w.received(_long(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)), _state())
    assert not s.handle(w.received(_long(mavlink.MAV_CMD_REQUEST_MESSAGE, 148, target=(SYSTEM + 1, 1))), _state())
    assert not s.handle(w.received(_long(mavlink.MAV_CMD_REQUEST_MESSAGE, 148, target=(SYSTEM, 191))), _state())
    assert not s.handle(w.received(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3)), _state())
    assert w.out == []


def test_geodesy_is_pxs_projection():
    o = Origin(47.397742, 8.545594, 488.0)
    lat, lon, alt = o.to_global(1000.0, 0.0, -30.0)
    assert lat == pytest.approx(o.lat + math.degrees(1000.0 / EARTH_RADIUS), abs=1e-12) and lon == o.lon
    assert alt == 518.0
    for n, e, d in ((1234.5, -987.25, 12.0), (-3000.0, 4000.0, -100.0), (0.0, 0.0, 0.0)):
        assert o.to_local(*o.to_global(n, e, d)) == pytest.approx((n, e, d), abs=1e-6)
    _, lon_east, _ = o.to_global(0.0, 1000.0, 0.0)
    assert (lon_east - o.lon) == pytest.approx(math.degrees(1000.0 / EARTH_RADIUS) / math.cos(math.radians(o.lat)),
                                               rel=1e-6)


def test_quaternion_of_euler_angles():
    assert quaternion(0.0, 0.0, math.pi / 2) == pytest.approx((math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)))
    w, x, y, z = quaternion(0.3, -0.2, 1.0)
    assert w * w + x * x + y * y + z * z == pytest.approx(1.0)
    assert math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)) == pytest.approx(0.3)  # roll back


def test_flight_information_on_request_gives_the_arming_and_takeoff_times():
    w = Wire(SYSTEM)
    s = Streams(w.mav, NORMAL)
    ground, air = mavlink.MAV_LANDED_STATE_ON_GROUND, mavlink.MAV_LANDED_STATE_IN_AIR
    for ms, armed, landed in ((500, False, ground), (1000, True, ground), (1500, True, ground), (2000, True, air),
                              (2500, True, air)):
        s.tick(ms / 1000, _state(boot_ms=ms, armed=armed, landed=landed))
    w.replies()
    request = _long(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_FLIGHT_INFORMATION)
    s.handle(w.received(request), _state(boot_ms=3000, armed=True, landed=air))
    info, ack = w.replies()
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED and info.get_type() == "FLIGHT_INFORMATION"
    # PX4's boot-relative µs in the _utc fields, as MAVSDK reads them (3 s since boot, armed 2 s, flying 1 s)
    assert (info.time_boot_ms, info.arming_time_utc, info.takeoff_time_utc) == (3000, 1_000_000, 2_000_000)
    s.tick(3.5, _state(boot_ms=3500, armed=False, landed=ground))
    w.replies()
    s.handle(w.received(request), _state(boot_ms=4000))
    info, _ = w.replies()
    assert (info.arming_time_utc, info.takeoff_time_utc) == (0, 0)
