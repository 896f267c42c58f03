"""The world-less simulated vehicle (autopilot/solo.py) flown in real time by a pymavlink client in the companion
computer's place: arm, take off, offboard by velocity, acceleration and position, land, return."""

from __future__ import annotations

import socket
import time

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink
from tests.autopilot.test_vehicle import Client

from swarmtrack.autopilot import px4
from swarmtrack.autopilot.endpoint import free_base
from swarmtrack.autopilot.solo import SoloVehicle

CUSTOM = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED


@pytest.fixture
def solo():
    port = free_base(1)
    client = Client(port, ("127.0.0.1", port + 40))
    vehicle = SoloVehicle(port, port + 40, position=(5.0, 7.0), params={"COM_DISARM_LAND": 0.5})
    yield vehicle, client
    vehicle.close()
    client.close()


def _latest(client: Client, kind: str):
    client.pump(0.05)
    found = client.of(kind)
    client.got.clear()
    return found[-1] if found else None


def _stream(client: Client, seconds: float, mask: int, pos=(0, 0, 0), vel=(0, 0, 0), acc=(0, 0, 0)):
    """Setpoints at 20 Hz for ``seconds`` (the offboard signal PX4 needs)."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        client.mav.set_position_target_local_ned_send(0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, mask, *pos, *vel, *acc,
                                                      0, 0)
        client.pump(0.05)


def _mode(client: Client):
    hb = client.wait("HEARTBEAT")
    return px4.main_mode(hb.custom_mode), px4.sub_mode(hb.custom_mode), bool(hb.base_mode & 128)


def test_it_starts_landed_disarmed_where_it_is_told_and_closes_its_thread_and_ports(solo):
    vehicle, client = solo
    assert _mode(client) == (px4.POSCTL, 0, False)
    client.pump(0.5)
    positions = client.of("LOCAL_POSITION_NED")
    assert len(positions) >= 15  # 50 Hz (0.5 s: 25; a loaded machine fewer)
    assert (positions[-1].x, positions[-1].y, positions[-1].z) == (7.0, 5.0, 0.0)  # NED of ENU (5, 7), on the ground
    assert all(b.time_boot_ms > a.time_boot_ms for a, b in zip(positions, positions[1:], strict=False))
    assert _latest(client, "EXTENDED_SYS_STATE").landed_state == mavlink.MAV_LANDED_STATE_ON_GROUND
    assert client.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0).result == mavlink.MAV_RESULT_ACCEPTED
    assert client.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0.0).result == mavlink.MAV_RESULT_ACCEPTED  # landed
    port = vehicle.vehicle.offboard_link.port
    vehicle.close()
    assert not vehicle._thread.is_alive()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", port))  # its port is free again


@pytest.mark.slow  # flies for about 14 s in real time
def test_takeoff_offboard_velocity_acceleration_position_then_land_and_disarm(solo):
    vehicle, client = solo
    client.wait("HEARTBEAT")
    assert client.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0).result == mavlink.MAV_RESULT_ACCEPTED
    nan = float("nan")
    assert client.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, nan, nan, nan, nan).result == 0
    deadline = time.monotonic() + 6
    while _mode(client)[:2] != (px4.AUTO, px4.AUTO_LOITER) and time.monotonic() < deadline:
        pass
    client.pump(0.5)
    lp = _latest(client, "LOCAL_POSITION_NED")
    assert abs(lp.z + 2.5) < 0.1 and abs(lp.x - 7.0) < 0.01  # MIS_TAKEOFF_ALT, straight up
    # velocity: (north 1, east -2) m/s, reached at MPC_XY_VEL_P_ACC (e^-1.8·2.5 = 1 % left)
    _stream(client, 0.3, px4.VELOCITY, vel=(1.0, -2.0, 0.0))
    assert client.command(mavlink.MAV_CMD_DO_SET_MODE, CUSTOM, px4.OFFBOARD).result == 0
    _stream(client, 2.5, px4.VELOCITY, vel=(1.0, -2.0, 0.0))
    lp = _latest(client, "LOCAL_POSITION_NED")
    assert np.hypot(lp.vx - 1.0, lp.vy + 2.0) < 0.05 * np.hypot(1, 2) and abs(lp.z + 2.5) < 0.1
    # acceleration: 1 m/s² north for 1 s, exactly what it flies
    v0, t0 = np.array([lp.vx, lp.vy]), lp.time_boot_ms
    _stream(client, 1.0, px4.ACCELERATION, acc=(1.0, 0.0, 0.0))
    lp = _latest(client, "LOCAL_POSITION_NED")
    dv, dt = np.array([lp.vx, lp.vy]) - v0, (lp.time_boot_ms - t0) / 1000
    assert abs(dv[0] - dt) < 0.15 and abs(dv[1]) < 0.05  # within one step (0.02 s) at each end, and the lag
    # position: back above (north 10, east 0) at 2.5 m
    _stream(client, 6.0, px4.POSITION, pos=(10.0, 0.0, -2.5))
    lp = _latest(client, "LOCAL_POSITION_NED")
    assert np.hypot(lp.x - 10.0, lp.y) < 0.3 and abs(lp.z + 2.5) < 0.1
    assert client.command(mavlink.MAV_CMD_NAV_LAND).result == mavlink.MAV_RESULT_ACCEPTED
    deadline = time.monotonic() + 8  # 2.5 m at 0.7 m/s, then COM_DISARM_LAND 0.5 s
    while _mode(client)[2] and time.monotonic() < deadline:
        pass
    assert not _mode(client)[2] and vehicle.altitude == 0.0
    client.got.clear()
    client.pump(1.1)  # EXTENDED_SYS_STATE comes at 5 Hz on the onboard link
    assert _latest(client, "EXTENDED_SYS_STATE").landed_state == mavlink.MAV_LANDED_STATE_ON_GROUND
