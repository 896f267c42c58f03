"""The simulated PX4-like vehicle and the world's fleet of them (autopilot/vehicle.py, fleet.py) on loopback UDP, driven
by a pymavlink client in the companion computer's place (and one in a ground station's)."""

from __future__ import annotations

import socket
import time

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot import px4
from swarmtrack.autopilot.endpoint import free_base
from swarmtrack.autopilot.fleet import Fleet, check_ports, gcs_port_of
from swarmtrack.autopilot.vehicle import MavlinkVehicle, VehicleError, hold

COMPANION, GCS = mavlink.MAV_COMP_ID_ONBOARD_COMPUTER, 190
NAN = float("nan")


class Client:
    """A MAVLink peer on loopback: bound to ``port`` (0: any), sending to ``to`` as (system, component)."""

    def __init__(self, port: int = 0, to: tuple[str, int] | None = None, system: int = 1,
                 component: int = COMPANION):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", port))
        self.to = to
        self.mav = mavlink.MAVLink(self, system, component)
        self.rx = mavlink.MAVLink(None)
        self.rx.robust_parsing = True
        self.got: list = []

    def write(self, buf: bytes) -> None:
        self.sock.sendto(buf, self.to)

    def pump(self, seconds: float = 0.0) -> None:
        """Take what came, and what comes for ``seconds``."""
        deadline = time.monotonic() + seconds
        while True:
            left = deadline - time.monotonic()
            self.sock.settimeout(left if left > 0 else 0.0)  # 0: what is there, without waiting
            try:
                data, _ = self.sock.recvfrom(65536)
            except (TimeoutError, BlockingIOError):
                return
            self.got += [m for m in self.rx.parse_buffer(data) or [] if m.get_type() != "BAD_DATA"]

    def wait(self, kind: str, cond=lambda m: True, timeout: float = 3.0):
        """The first ``kind`` message that holds ``cond`` (from what came and what comes), None after ``timeout``."""
        deadline = time.monotonic() + timeout
        while True:
            for m in self.got:
                if m.get_type() == kind and cond(m):
                    self.got.remove(m)
                    return m
            if time.monotonic() >= deadline:
                return None
            self.pump(0.02)

    def text(self, cond=lambda t: True, timeout: float = 3.0):
        """The first STATUSTEXT whose whole text (its chunks joined, MAVLink 2) holds ``cond``: (severity, text)."""
        deadline = time.monotonic() + timeout
        while True:
            texts, parts = [], {}
            for m in self.of("STATUSTEXT"):
                if m.id == 0:
                    texts.append((m.severity, m.text))
                else:
                    parts.setdefault(m.id, []).append(m)
            for chunks in parts.values():
                chunks.sort(key=lambda c: c.chunk_seq)
                if len(chunks[-1].text) < 50:
                    texts.append((chunks[0].severity, "".join(c.text for c in chunks)))
            found = [t for t in texts if cond(t[1])]
            if found or time.monotonic() >= deadline:
                return found[0] if found else None
            self.pump(0.02)

    def of(self, kind: str) -> list:
        return [m for m in self.got if m.get_type() == kind]

    def command(self, cmd: int, *params: float, target=(1, 1), kind: str = "long"):
        """Send a command; its COMMAND_ACK (None if none came)."""
        p = [*params, *[0.0] * (7 - len(params))]
        if kind == "long":
            self.mav.command_long_send(*target, cmd, 0, *p)
        else:
            self.mav.command_int_send(*target, mavlink.MAV_FRAME_GLOBAL, cmd, 0, 0, *p[:4], round(p[4]), round(p[5]),
                                      p[6])
        return self.wait("COMMAND_ACK", lambda m: m.command == cmd)

    def accelerate(self, a_ned, ms: int = 0, mask: int = px4.ACCELERATION, frame=mavlink.MAV_FRAME_LOCAL_NED):
        self.mav.set_position_target_local_ned_send(ms, 1, 1, frame, mask, 0, 0, 0, 0, 0, 0, *a_ned, 0, 0, 0)

    def close(self) -> None:
        self.sock.close()


def _mode(hb) -> tuple[int, int]:
    return px4.main_mode(hb.custom_mode), px4.sub_mode(hb.custom_mode)


class Polled:
    """A fleet polled by its own thread, the world's clock ``clock[0]``."""

    def __init__(self, n: int, base: int, **kwargs):
        self.clock = [0.0]
        self.fleet = Fleet(n, lambda: self.clock[0], base, **kwargs)


@pytest.fixture
def fleet():
    base = free_base(2)
    f = Polled(2, base)
    agent = Client(base, ("127.0.0.1", base + 40))  # UAV 1's companion computer, where PX4 SITL's 14540 would be
    yield f, agent, base
    agent.close()
    f.fleet.close()


def test_the_fleet_starts_armed_in_the_air_in_position_mode(fleet):
    f, agent, _ = fleet
    hb = agent.wait("HEARTBEAT")
    assert hb.get_srcSystem() == 1 and hb.autopilot == mavlink.MAV_AUTOPILOT_PX4 and _mode(hb) == (px4.POSCTL, 0)
    assert hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    f.fleet.publish(0.0, np.array([[10.0, -20.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]]), [0, 1])
    lp = agent.wait("LOCAL_POSITION_NED")
    assert (lp.x, lp.y, lp.z) == (-20.0, 10.0, -2.5)  # NED; its own altitude: MIS_TAKEOFF_ALT
    f.fleet.publish(0.1, np.zeros((2, 4)), [0, 1], altitude=np.array([40.0, 50.0]))
    assert agent.wait("LOCAL_POSITION_NED", lambda m: m.time_boot_ms == 100).z == -40.0  # a 3-D world's


def test_setpoints_wait_only_for_vehicles_in_offboard_mode_and_fly_the_acceleration_exactly(fleet):
    f, agent, _ = fleet
    agent.wait("HEARTBEAT")
    for _ in range(5):
        agent.accelerate([0.1, 0.2, 0.0])
        time.sleep(0.02)
    assert agent.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                         px4.OFFBOARD).result == mavlink.MAV_RESULT_ACCEPTED
    assert f.fleet.flying_offboard([0, 1]) == [0]
    nav = np.array([[5.0, 6.0, 1.0, -2.0], [1.0, 2.0, 3.0, 4.0]])
    a = np.array([0.3, -1.7, 0.0], dtype=np.float32)
    agent.accelerate(a.tolist(), ms=250)
    started = time.monotonic()
    assert f.fleet.setpoints(0.25, [0, 1], None) == {0}  # UAV 2 is its pilot's: nobody waits for it
    assert time.monotonic() - started < 2.0
    u = f.fleet.commands(nav, 0.25)
    assert np.array_equal(u[0], [a[1], a[0]])  # ENU, bit for bit float32's
    stop = nav[1, :2] + nav[1, 2:] * np.linalg.norm(nav[1, 2:]) / (2 * 3.0)  # Position mode brakes and holds there
    assert np.allclose(u[1], hold(nav[1], stop))


def test_a_taken_port_stops_the_fleet_naming_it_and_leaves_nothing_open():
    base = free_base(3)
    taken = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    taken.bind(("127.0.0.1", base + 40 + 1))  # UAV 2's offboard link's (PX4 SITL instance 1 holds 14581)
    try:
        with pytest.raises(VehicleError, match=f"UAV 2's autopilot's offboard link: UDP port {base + 41} on "
                                               "127.0.0.1 is taken"):
            Fleet(3, lambda: 0.0, base)
    finally:
        taken.close()
    taken = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    taken.bind(("127.0.0.1", base + 4030 + 2))  # UAV 3's ground-station link's (18572)
    try:
        with pytest.raises(VehicleError, match=f"UAV 3's autopilot's ground-station link: UDP port {base + 4032}"):
            check_ports(3, base)
    finally:
        taken.close()
    check_ports(3, base)  # all free: nothing raised, nothing kept
    f = Fleet(3, lambda: 0.0, base)  # UAV 1's ports were closed
    try:
        with pytest.raises(VehicleError, match=f"UDP port {base + 40}"):
            Fleet(1, lambda: 0.0, base)  # a second world on the same ports
        assert f.gcs_ports == [gcs_port_of(base, i) for i in range(3)] == [base + 4030 + i for i in range(3)]
    finally:
        f.close()


def test_the_heartbeat_carries_px4s_sub_mode_at_once_and_commands_come_as_long_or_int(fleet):
    f, agent, _ = fleet
    agent.wait("HEARTBEAT")
    ack = agent.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, px4.AUTO,
                        px4.AUTO_LOITER, kind="int")
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED and ack.target_component == COMPANION
    assert agent.wait("HEARTBEAT", lambda m: _mode(m) == (px4.AUTO, px4.AUTO_LOITER), timeout=0.5) is not None
    assert agent.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0.0).result == mavlink.MAV_RESULT_TEMPORARILY_REJECTED
    assert agent.wait("STATUSTEXT").text == "Disarming denied: not landed"
    assert agent.command(mavlink.MAV_CMD_DO_FOLLOW, 1.0).result == mavlink.MAV_RESULT_UNSUPPORTED
    ack = agent.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0.0, px4.FORCE_MAGIC, kind="int")
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED and not f.fleet.vehicles[0].armed  # a kill


def test_the_ground_station_link_is_silent_until_claimed_and_forwards_to_and_from_the_companion(fleet):
    f, agent, base = fleet
    gcs = Client(0, ("127.0.0.1", gcs_port_of(base, 0)), system=255, component=GCS)
    try:
        gcs.pump(1.3)
        assert gcs.got == []  # nothing sent before it is claimed
        gcs.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        assert gcs.wait("HEARTBEAT", lambda m: m.get_srcComponent() == 1) is not None
        assert gcs.wait("SYS_STATUS") is not None  # the normal-mode streams
        agent.pump(0.1)  # what piled up unread (a socket left unread ~1 s overflows at the onboard streams' rates)
        gcs.mav.command_long_send(1, COMPANION, mavlink.MAV_CMD_NAV_GUIDED_ENABLE, 0, 1, 0, 0, 0, 0, 0, 0)
        cmd = agent.wait("COMMAND_LONG")
        assert (cmd.command, cmd.param1, cmd.target_component, cmd.get_srcSystem()) == (92, 1.0, COMPANION, 255)
        agent.mav.command_ack_send(92, mavlink.MAV_RESULT_ACCEPTED, 255, GCS)
        agent.mav.statustext_send(mavlink.MAV_SEVERITY_INFO, b"UAV 1 engaged")
        ack = gcs.wait("COMMAND_ACK", lambda m: m.command == 92)
        assert ack.get_srcComponent() == COMPANION and ack.result == mavlink.MAV_RESULT_ACCEPTED
        assert gcs.wait("STATUSTEXT", lambda m: m.text == "UAV 1 engaged") is not None
        assert f.fleet.vehicles[0].forwarded == {"to_companion": 1, "to_gcs": 2} or \
            f.fleet.vehicles[0].forwarded["to_gcs"] >= 2  # and the companion's heartbeats, if it sent any
        hold_ack = gcs.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, px4.AUTO,
                               px4.AUTO_LOITER)  # the ground station's own command: answered on its link
        assert hold_ack.result == mavlink.MAV_RESULT_ACCEPTED and agent.of("COMMAND_ACK") == []
    finally:
        gcs.close()


def test_a_configured_ground_station_port_gets_the_vehicle_at_once():
    base = free_base(1)
    station = Client(0)
    f = Polled(1, base, gcs_port=station.sock.getsockname()[1])
    try:
        hb = station.wait("HEARTBEAT")
        assert hb is not None and hb.get_srcSystem() == 1
    finally:
        f.fleet.close()
        station.close()


def test_an_unsupported_setpoint_is_refused_said_and_counted(fleet):
    f, agent, _ = fleet
    agent.wait("HEARTBEAT")
    agent.accelerate([1.0, 0.0, 0.0], frame=mavlink.MAV_FRAME_LOCAL_OFFSET_NED)
    severity, text = agent.text(lambda t: t.startswith("SET_POSITION"))
    assert text == "SET_POSITION_TARGET_LOCAL_NED coordinate frame 7 unsupported"  # 61 bytes: in 2 chunks
    assert severity == mavlink.MAV_SEVERITY_CRITICAL and f.fleet.vehicles[0].refused[text] == 1
    ack = agent.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, px4.OFFBOARD)
    assert ack.result == mavlink.MAV_RESULT_TEMPORARILY_REJECTED  # it was no offboard signal


def test_the_offboard_loss_failsafe_is_said_on_both_links_and_the_heartbeat_shows_position(fleet):
    f, agent, base = fleet
    gcs = Client(0, ("127.0.0.1", gcs_port_of(base, 0)), system=255, component=GCS)
    try:
        gcs.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        agent.wait("HEARTBEAT")
        agent.accelerate([0.0, 0.0, 0.0])
        agent.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, px4.OFFBOARD)
        f.clock[0] = 1.5  # the world's clock: 1.5 s without a setpoint (COM_OF_LOSS_T: 1 s)
        for who in (agent, gcs):
            assert who.wait("STATUSTEXT", lambda m: m.text == "Failsafe activated") is not None
        assert agent.wait("HEARTBEAT", lambda m: _mode(m) == (px4.POSCTL, 0)) is not None
        assert f.fleet.vehicles[0].commander.failsafes == [(1.5, "Position")]
    finally:
        gcs.close()


def test_a_lone_vehicle_starts_landed_and_disarmed_and_refuses_as_configured():
    port = free_base(1)
    agent = Client(port, ("127.0.0.1", port + 40))
    v = MavlinkVehicle(0, port, refuse={"arm": mavlink.MAV_RESULT_DENIED}, gcs=False)
    try:
        v.poll(0.0)
        hb = agent.wait("HEARTBEAT")
        assert not hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED and hb.system_status == mavlink.MAV_STATE_STANDBY
        agent.mav.command_long_send(1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
        time.sleep(0.05)
        v.poll(0.0)
        assert agent.wait("COMMAND_ACK").result == mavlink.MAV_RESULT_DENIED and not v.armed
        v.publish(0.1, np.array([3.0, 4.0, 0.0, 0.0]))
        assert np.array_equal(v.state.home, [4.0, 3.0, 0.0])  # home before arming, as PX4 sets it on the ground
    finally:
        v.close()
        agent.close()


def test_a_reposition_flies_to_the_point_in_hold_and_attitude_targets_are_said_unsupported(fleet):
    f, agent, _ = fleet
    agent.wait("HEARTBEAT")
    v = f.fleet.vehicles[0]
    f.fleet.publish(0.0, np.zeros((2, 4)), [0, 1])
    lat, lon, alt = v.origin.to_global(30.0, -20.0, -12.0)  # 30 m north, 20 m west, 12 m up
    ack = agent.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 1, 0, NAN, lat * 1e7, lon * 1e7, alt, kind="int")
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED and (v.mode, v.sub_mode) == (px4.AUTO, px4.AUTO_LOITER)
    assert np.allclose(v.commander.anchor, [30.0, -20.0, -12.0], atol=0.01)
    agent.mav.set_attitude_target_send(0, 1, 1, 0, [1, 0, 0, 0], 0, 0, 0, 0.5)
    _, text = agent.text(lambda t: t.startswith("SET_ATTITUDE_TARGET"))
    assert text == "SET_ATTITUDE_TARGET not supported by this simulated vehicle"
