"""The UAV's MAVLink link against the simulated PX4-like vehicle, on loopback UDP (the vehicle polled by a thread, as
the world's loop would)."""

from __future__ import annotations

import socket
import threading
import time

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot import px4
from swarmtrack.autopilot.authority import Authority
from swarmtrack.autopilot.link import AutopilotError, AutopilotLink, AutopilotRefused, device_of
from swarmtrack.autopilot.vehicle import MavlinkVehicle, hold


def _port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Flying:
    """A vehicle polled every 5 ms by a thread, publishing ``nav`` at 50 Hz (wall-clock time)."""

    def __init__(self, port: int, **kwargs):
        self.vehicle = MavlinkVehicle(2, port, local_port=_port(), gcs=False, **kwargs)
        self.nav = np.array([10.0, -20.0, 1.5, -0.5])
        self.attitude = np.array([0.1, -0.2, 2.5])  # roll, pitch, yaw (ENU)
        self.t0, self._stop = time.monotonic(), False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def now(self) -> float:
        return time.monotonic() - self.t0

    def _run(self) -> None:
        last = -1.0
        while not self._stop:
            now = self.now()
            self.vehicle.poll(now)
            if now - last >= 0.02:
                self.vehicle.publish(now, self.nav, self.attitude)
                last = now
            time.sleep(0.005)

    def close(self) -> None:
        self._stop = True
        self.thread.join()
        self.vehicle.close()


@pytest.fixture
def flying(request):
    port = _port()
    f = Flying(port, **getattr(request, "param", {}))
    yield f, f"udp://127.0.0.1:{port}"
    f.close()


def test_the_link_engages_and_a_setpoint_arrives_as_sent_within_float32(flying):
    vehicle, url = flying
    link = AutopilotLink(url, 2)
    try:
        assert link.target == (3, mavlink.MAV_COMP_ID_AUTOPILOT1)  # system uav + 1
        Authority(link, prime=0.2).engage()
        assert vehicle.vehicle.offboard() and link.wait(lambda: link.armed and link.mode == px4.OFFBOARD, 2.0)
        nav = link.navigation()
        assert np.allclose(nav, vehicle.nav, rtol=2 ** -23, atol=0)  # ENU in, NED on the wire, ENU out (float32)
        assert np.allclose(link.attitude, vehicle.attitude, rtol=0, atol=1e-6)
        accel = np.array([0.3, -1.7])
        link.send_acceleration(accel, 1.25)
        deadline = time.monotonic() + 2
        while vehicle.vehicle.setpoint_ms != 1250 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert np.allclose(vehicle.vehicle.command(vehicle.nav, vehicle.now()), accel, rtol=2 ** -23, atol=0)
    finally:
        link.close()


@pytest.mark.parametrize("flying, what, result", [
    ({"refuse": {"arm": mavlink.MAV_RESULT_DENIED}}, "to arm", "MAV_RESULT_DENIED"),
    ({"refuse": {"offboard": mavlink.MAV_RESULT_FAILED}}, "offboard mode", "MAV_RESULT_FAILED"),
], indirect=["flying"])
def test_a_refusal_names_the_vehicle_and_the_acknowledgements_result(flying, what, result):
    vehicle, url = flying
    link = AutopilotLink(url, 2)
    try:
        with pytest.raises(AutopilotRefused, match=f"UAV 3's autopilot refused {what}: {result}"):
            Authority(link, prime=0.2).engage()
        assert not vehicle.vehicle.offboard()
    finally:
        link.close()


def test_offboard_mode_is_refused_without_a_setpoint_stream(flying):
    vehicle, url = flying
    link = AutopilotLink(url, 2)
    try:
        with pytest.raises(AutopilotRefused, match="MAV_RESULT_TEMPORARILY_REJECTED"):
            link.command(mavlink.MAV_CMD_DO_SET_MODE, 1.0, float(px4.OFFBOARD), what="offboard mode")
    finally:
        link.close()


@pytest.mark.slow  # setpoints stopped for longer than COM_OF_LOSS_T
@pytest.mark.parametrize("flying", [{"airborne": True}], indirect=True)
def test_setpoints_that_stop_trip_the_failsafe_which_holds_position_and_the_program_hands_over(flying):
    """The program stops streaming (it hangs): after COM_OF_LOSS_T the vehicle leaves offboard mode for its failsafe
    (Position: it brakes to hold where it is), says so, and the program's authority hands over, believing it the
    failsafe."""
    vehicle, url = flying
    link = AutopilotLink(url, 2)
    try:
        authority = Authority(link, prime=0.2)
        authority.engage()
        authority.fly(np.array([1.0, 1.0]), 0.0)
        time.sleep(0.1)
        assert np.allclose(vehicle.vehicle.command(vehicle.nav, vehicle.now()), [1.0, 1.0])
        link.stop_stream()
        time.sleep(px4.OFFBOARD_LOSS_S + 0.3)  # no setpoint for longer than COM_OF_LOSS_T
        u = vehicle.vehicle.command(vehicle.nav, vehicle.now())
        assert not vehicle.vehicle.offboard() and u @ vehicle.nav[2:] < 0  # it brakes to hold where it is
        assert link.wait(lambda: link.mode == px4.POSCTL and not authority.engaged, 2.0)
        assert [(e["mode"], e["cause"]) for e in authority.take(1.0)] == [("Position", "failsafe")]
        assert any("Failsafe activated" in text for _, text in link.texts)
    finally:
        link.close()


def test_the_failsafe_hold_brings_a_moving_uav_to_rest_at_its_anchor():
    nav, anchor, dt = np.array([0.0, 0.0, 2.0, -1.0]), np.zeros(2), 0.01
    for _ in range(2000):  # 20 s of a double integrator under the hold
        a = hold(nav, anchor)
        nav = np.concatenate([nav[:2] + dt * nav[2:], nav[2:] + dt * a])
    assert np.linalg.norm(nav[2:]) < 1e-3 and np.linalg.norm(nav[:2] - anchor) < 5e-3


@pytest.mark.parametrize("fault, cause", [("nan", "holds NaN or infinity"), ("back", "went back in time")])
def test_a_broken_navigation_stream_is_an_error_naming_the_uav_and_the_cause(flying, fault, cause):
    vehicle, url = flying
    link = AutopilotLink(url, 2)
    try:
        link.navigation()
        if fault == "nan":
            vehicle.nav = np.array([np.nan, 0.0, 0.0, 0.0])
        else:
            while link.nav_ms < 200:
                link.navigation(link.nav_ms)
            vehicle.vehicle.publish(0.1, vehicle.nav)  # a navigation stamped back in time
        with pytest.raises(AutopilotError, match=f"UAV 3: the autopilot at {url}: its navigation {cause}"):
            for _ in range(100):
                link.navigation(link.nav_ms, timeout=1.0)
    finally:
        link.close()


def test_no_heartbeat_and_bad_urls_are_errors_naming_the_uav():
    port = _port()
    t0 = time.monotonic()
    with pytest.raises(AutopilotError, match=f"UAV 1: no heartbeat from the autopilot at udp://127.0.0.1:{port} "
                                             "within 0.5 s"):
        AutopilotLink(f"udp://127.0.0.1:{port}", 0, timeout=0.5)
    assert time.monotonic() - t0 < 10  # it gave up after its timeout, not never (load may move the figure)
    with pytest.raises(AutopilotError, match="UAV 2: --autopilot tcp://x: expected udp"):
        AutopilotLink("tcp://x", 1)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        with pytest.raises(AutopilotError, match="cannot open the autopilot link"):  # a port in use
            AutopilotLink(f"udp://127.0.0.1:{s.getsockname()[1]}", 0, timeout=0.5)
    with pytest.raises(AutopilotError, match="UAV 1: cannot open the autopilot link serial:///dev/no-such-tty"):
        AutopilotLink("serial:///dev/no-such-tty:57600", 0)
    assert device_of("udp://:14540") == ("udpin:0.0.0.0:14540", 0)
    assert device_of("serial:///dev/ttyUSB0:57600") == ("/dev/ttyUSB0", 57600)
