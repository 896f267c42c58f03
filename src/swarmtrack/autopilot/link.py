"""The UAV's own autopilot over MAVLink, as its offboard program (``swarmtrack agent --autopilot URL``).

``URL``: ``udp://[HOST]:PORT`` listens there for the autopilot (PX4 SITL instance i sends to port 14540 + i; a
companion computer usually listens on the port the autopilot's MAVLink instance sends to), or
``serial://DEVICE[:BAUD]`` (``serial:///dev/ttyUSB0:57600``). The link:

- waits for the autopilot's ``HEARTBEAT`` (:data:`HEARTBEAT_TIMEOUT` s, else :class:`AutopilotError`), then sends its
  own every second, as ``MAV_TYPE_ONBOARD_CONTROLLER`` of the vehicle's system, component
  ``MAV_COMP_ID_ONBOARD_COMPUTER``;
- engages (:meth:`AutopilotLink.engage`): arms (``MAV_CMD_COMPONENT_ARM_DISARM``; PX4 enters offboard mode only
  armed), streams zero setpoints for 1.2 s (PX4 enters it only after setpoints have come for over a second), and
  switches to offboard mode (``MAV_CMD_DO_SET_MODE``, PX4 main mode 6); a refusal stops it with
  :class:`AutopilotRefused`, naming the vehicle and the acknowledgement's result;
- reads the navigation solution from ``LOCAL_POSITION_NED`` (NED, converted to the project's ENU:
  :mod:`~swarmtrack.autopilot.frames`), keeping the latest (:meth:`AutopilotLink.navigation`), and ``ATTITUDE``
  (:attr:`AutopilotLink.attitude`, its yaw in ENU's convention; the planar controllers do not read it);
- sends the controller's planar acceleration as ``SET_POSITION_TARGET_LOCAL_NED`` with the acceleration type mask
  (:data:`~swarmtrack.autopilot.px4.ACCELERATION`; the quadrotor's command is an acceleration, tracked by its
  attitude loop), its ``time_boot_ms`` the navigation's it answers.

MAVLink's fields are float32: a position of 100 m travels with a resolution of about 8 µm (2⁻²⁴ relative).
"""

from __future__ import annotations

import socket
import threading
import time

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot import px4
from swarmtrack.autopilot.frames import enu_to_ned, ned_to_enu, yaw_ned_to_enu

#: Seconds to wait for the autopilot's first heartbeat, and for a command's acknowledgement.
HEARTBEAT_TIMEOUT, ACK_TIMEOUT = 5.0, 3.0
#: Zero setpoints sent before asking for offboard mode, and their rate (Hz): PX4 (v1.14) enters offboard mode only
#: after the setpoints have come for over a second at more than 2 Hz.
PRIME, PRIME_RATE = 24, 20.0


class AutopilotError(Exception):
    """The autopilot link cannot be used (it does not open, no heartbeat): bad input, exit 2."""


class AutopilotRefused(Exception):
    """The autopilot refused to arm or to enter offboard mode (exit 3): the message names the vehicle and the
    acknowledgement's result."""


def device_of(url: str) -> tuple[str, int]:
    """pymavlink's device string and baud rate of a link ``url`` (module docstring); ValueError for another form."""
    if url.startswith("udp://"):
        host, _, port = url[len("udp://"):].rpartition(":")
        if not port.isdigit() or not 0 < int(port) < 65536:
            raise ValueError(f"{url}: expected udp://[HOST]:PORT, PORT 1..65535")
        return f"udpin:{host or '0.0.0.0'}:{port}", 0
    if url.startswith("serial://"):
        device, _, baud = url[len("serial://"):].rpartition(":")
        if not baud.isdigit():
            device, baud = url[len("serial://"):], "57600"
        return device, int(baud)
    raise ValueError(f"{url}: expected udp://[HOST]:PORT or serial://DEVICE[:BAUD]")


def check_free(device: str) -> None:
    """Refuse a UDP port another process listens on (``OSError``): pymavlink binds with ``SO_REUSEADDR``, which on
    Linux lets a second link bind a port where another one (pymavlink's too) listens, and then hear nothing (its
    autopilot's messages go to the other): the link would wait for a heartbeat that never comes. Bound here without
    it, the port is refused at once, naming it."""
    host, _, port = device[len("udpin:"):].rpartition(":")
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind((host, int(port)))
        except OSError as exc:
            raise OSError(exc.errno, f"UDP port {port} is in use by another process") from None


class AutopilotLink:
    """UAV ``uav``'s autopilot at ``url`` (module docstring)."""

    def __init__(self, url: str, uav: int, timeout: float = HEARTBEAT_TIMEOUT):
        self.url, self.uav = url, uav
        try:
            device, baud = device_of(url)
            if device.startswith("udpin:"):
                check_free(device)
            self.conn = px4.connect(device, baud=baud or 115200, source_component=mavlink.MAV_COMP_ID_ONBOARD_COMPUTER)
        except ValueError as exc:
            raise AutopilotError(f"UAV {uav + 1}: --autopilot {exc}") from None
        except OSError as exc:
            raise AutopilotError(f"UAV {uav + 1}: cannot open the autopilot link {url}: "
                                 f"{exc.strerror or exc}") from None
        self._send_lock = threading.Lock()
        self.nav: np.ndarray | None = None  # the latest navigation solution [x, y, vx, vy] (ENU)
        self.nav_ms = -1  # its time_boot_ms
        self.mode, self.armed = None, False  # from the autopilot's heartbeats
        self._acks: dict[int, int] = {}
        self.fault: str | None = None  # what is wrong with the autopilot's navigation stream
        self.attitude: np.ndarray | None = None  # the latest [roll, pitch, yaw] (rad; yaw ENU's, from east)
        heartbeat, deadline = None, time.monotonic() + timeout
        while heartbeat is None and time.monotonic() < deadline:  # the autopilot's, not a ground station's
            beat = self.conn.recv_match(type="HEARTBEAT", blocking=True, timeout=deadline - time.monotonic())
            if beat is not None and beat.autopilot != mavlink.MAV_AUTOPILOT_INVALID:
                heartbeat = beat
        if heartbeat is None:
            self.conn.close()
            raise AutopilotError(f"UAV {uav + 1}: no heartbeat from the autopilot at {url} within {timeout:g} s")
        self.target = (heartbeat.get_srcSystem(), heartbeat.get_srcComponent())
        self.conn.mav.srcSystem = self.target[0]  # a companion computer shares its vehicle's system id
        self._take(heartbeat)
        self._closed = False
        threading.Thread(target=self._beat, name="mavlink-heartbeat", daemon=True).start()

    def _beat(self) -> None:
        while not self._closed:
            with self._send_lock:
                self.conn.mav.heartbeat_send(mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                             mavlink.MAV_STATE_ACTIVE)
            time.sleep(1.0)

    def _take(self, msg) -> None:
        kind = msg.get_type()
        if kind == "HEARTBEAT" and msg.get_srcComponent() == self.target[1]:
            self.mode = px4.main_mode(msg.custom_mode)
            self.armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        elif kind == "LOCAL_POSITION_NED":
            if not np.isfinite([msg.x, msg.y, msg.z, msg.vx, msg.vy, msg.vz]).all():
                self.fault = "its navigation holds NaN or infinity"
            elif msg.time_boot_ms < self.nav_ms:
                self.fault = (f"its navigation went back in time ({self.nav_ms} ms, then {msg.time_boot_ms} ms: "
                              "did it reboot?)")
            else:
                p, v = ned_to_enu([msg.x, msg.y, msg.z]), ned_to_enu([msg.vx, msg.vy, msg.vz])
                self.nav, self.nav_ms = np.concatenate([p[:2], v[:2]]), msg.time_boot_ms
        elif kind == "ATTITUDE":
            self.attitude = np.array([msg.roll, msg.pitch, float(yaw_ned_to_enu(msg.yaw))])
        elif kind == "COMMAND_ACK":
            self._acks[msg.command] = msg.result

    def pump(self, timeout: float = 0.0, until=None) -> bool:
        """Take the messages that came; then, unless ``until()`` holds (None: take what is there), wait up to
        ``timeout`` s for more until it does. Returns whether it holds."""
        deadline = time.monotonic() + timeout
        while True:
            while (msg := self.conn.recv_match(blocking=False)) is not None:
                self._take(msg)
            if until is None or until():
                return True
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            msg = self.conn.recv_match(blocking=True, timeout=min(0.05, left))
            if msg is not None:
                self._take(msg)

    def _command(self, command: int, *params: float, what: str) -> None:
        self._acks.pop(command, None)
        with self._send_lock:
            self.conn.mav.command_long_send(*self.target, command, 0, *params, *[0.0] * (7 - len(params)))
        if not self.pump(ACK_TIMEOUT, lambda: command in self._acks):
            raise AutopilotRefused(f"UAV {self.uav + 1}'s autopilot did not acknowledge {what} within "
                                   f"{ACK_TIMEOUT:g} s")
        if self._acks[command] != mavlink.MAV_RESULT_ACCEPTED:
            raise AutopilotRefused(f"UAV {self.uav + 1}'s autopilot refused {what}: "
                                   f"{px4.result_name(self._acks[command])}")

    def engage(self) -> None:
        """Arm, stream zero setpoints, enter offboard mode (:class:`AutopilotRefused` on a refusal)."""
        if not self.armed:
            self._command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0, what="to arm")
        self.offboard()

    def offboard(self) -> None:
        """Stream zero setpoints, then enter offboard mode (again, after a failsafe)."""
        for _ in range(PRIME):
            self.send_acceleration(np.zeros(2), max(self.nav_ms, 0) / 1000)
            time.sleep(1.0 / PRIME_RATE)
        self._command(mavlink.MAV_CMD_DO_SET_MODE, float(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED),
                      float(px4.OFFBOARD), what="offboard mode")

    def navigation(self, after_ms: int = -1, timeout: float = HEARTBEAT_TIMEOUT) -> np.ndarray:
        """The latest navigation solution ``[x, y, vx, vy]`` (ENU), waiting up to ``timeout`` s for one newer than
        ``after_ms`` (``time_boot_ms``); :class:`AutopilotError` if none comes, or if the stream held a NaN or went
        back in time (the UAV's process then stops, and its autopilot's failsafe holds it)."""
        if not self.pump(timeout, lambda: self.nav_ms > after_ms or self.fault is not None):
            raise AutopilotError(f"UAV {self.uav + 1}: no navigation from the autopilot at {self.url} within "
                                 f"{timeout:g} s")
        if self.fault is not None:
            raise AutopilotError(f"UAV {self.uav + 1}: the autopilot at {self.url}: {self.fault}")
        return self.nav.copy()

    def send_acceleration(self, accel: np.ndarray, t: float) -> None:
        """The planar acceleration ``accel`` (2,) (ENU, m/s²) as an offboard setpoint stamped ``t`` (s)."""
        a = enu_to_ned([accel[0], accel[1], 0.0])
        with self._send_lock:
            self.conn.mav.set_position_target_local_ned_send(
                int(round(t * 1000)), *self.target, mavlink.MAV_FRAME_LOCAL_NED, px4.ACCELERATION,
                0.0, 0.0, 0.0, 0.0, 0.0, 0.0, *a.tolist(), 0.0, 0.0)

    def close(self) -> None:
        self._closed = True
        self.conn.close()
