"""The UAV's own autopilot over MAVLink, as its offboard program (``swarmtrack agent --autopilot URL``).

``URL``: ``udp://[HOST]:PORT`` listens there for the autopilot (PX4 SITL instance i sends to port 14540 + i; a
companion computer usually listens on the port the autopilot's MAVLink instance sends to), or
``serial://DEVICE[:BAUD]`` (``serial:///dev/ttyUSB0:57600``). The link:

- waits for the autopilot's ``HEARTBEAT`` (:data:`HEARTBEAT_TIMEOUT` s, else :class:`AutopilotError`), then sends its
  own every second, as ``MAV_TYPE_ONBOARD_CONTROLLER`` of the vehicle's system, component
  ``MAV_COMP_ID_ONBOARD_COMPUTER``;
- asks the autopilot for the streams it reads, at the rates it needs (:data:`STREAMS`);
- reads everything the autopilot sends in a thread of its own (:meth:`AutopilotLink.wait` waits for a condition on
  what came): the navigation solution from ``LOCAL_POSITION_NED`` (NED, converted to the project's ENU:
  :mod:`~swarmtrack.autopilot.frames`; :meth:`AutopilotLink.navigation`), ``ATTITUDE`` (:attr:`AutopilotLink.attitude`,
  its yaw in ENU's convention), its mode and armed flag from ``HEARTBEAT``, its landed state from
  ``EXTENDED_SYS_STATE``, its ``STATUSTEXT`` messages, command acknowledgements, and the commands a ground station
  addresses to this companion computer (:attr:`AutopilotLink.requests`);
- sends the controller's planar acceleration as ``SET_POSITION_TARGET_LOCAL_NED`` with the acceleration type mask
  (:data:`~swarmtrack.autopilot.px4.ACCELERATION`; the quadrotor's command is an acceleration, tracked by its
  attitude loop), its ``time_boot_ms`` the control step's it answers, and repeats the latest at :data:`STREAM_RATE`
  from a thread while streaming (PX4 leaves offboard mode when its setpoints stop for ``COM_OF_LOSS_T``; a companion
  computer streams them, as MAVSDK's offboard plugin does).

Who may fly the vehicle (engaging offboard mode, handing it back to the operator) is
:mod:`~swarmtrack.autopilot.authority`'s. MAVLink's fields are float32: a position of 100 m travels with a resolution
of about 8 µm (2⁻²⁴ relative).
"""

from __future__ import annotations

import socket
import threading
import time
from collections import deque

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot import px4
from swarmtrack.autopilot.frames import enu_to_ned, ned_to_enu, yaw_ned_to_enu

#: Seconds to wait for the autopilot's first heartbeat, and for a command's acknowledgement.
HEARTBEAT_TIMEOUT, ACK_TIMEOUT = 5.0, 3.0
#: How often the latest setpoint is repeated while streaming (Hz): PX4 (v1.14) enters offboard mode only after
#: setpoints have come for over a second at more than 2 Hz, and leaves it when they stop for ``COM_OF_LOSS_T``.
STREAM_RATE = 20.0
#: A silence of the autopilot longer than this (s) is remembered (:attr:`AutopilotLink.gaps`): its streams come at
#: 1 Hz (heartbeat) and faster, so a longer one is a link that dropped.
GAP = 0.3
#: The autopilot's streams the link asks for at another rate (Hz; 0 stops one) when it opens, with
#: ``MAV_CMD_SET_MESSAGE_INTERVAL``, as a companion computer asks for what it reads: PX4's onboard link streams
#: ``ATTITUDE`` at 100 Hz and ``GLOBAL_POSITION_INT`` at 50 Hz, which the UAV's process would decode in Python for
#: nothing (its navigation is ``LOCAL_POSITION_NED``; its landed state ``EXTENDED_SYS_STATE``, kept at PX4's rate).
STREAMS = {"ATTITUDE": 10.0, "ATTITUDE_QUATERNION": 0.0, "GLOBAL_POSITION_INT": 0.0, "GPS_RAW_INT": 0.0,
           "ALTITUDE": 0.0, "VFR_HUD": 0.0}
#: The commands a ground station may address to this companion computer (``MAV_COMP_ID_ONBOARD_COMPUTER``).
REQUESTS = frozenset({mavlink.MAV_CMD_NAV_GUIDED_ENABLE})


class AutopilotError(Exception):
    """The autopilot link cannot be used (it does not open, no heartbeat): bad input, exit 2."""


class AutopilotRefused(Exception):
    """The autopilot refused to arm or to enter offboard mode (exit 3): the message names the vehicle and the
    acknowledgement's result."""


class AutopilotSilent(AutopilotRefused):
    """The autopilot did not answer in time (no acknowledgement, or its heartbeat did not follow): unlike a refusal,
    asking again may succeed."""


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
        self._send_lock, self._cond = threading.Lock(), threading.Condition()
        self.nav: np.ndarray | None = None  # the latest navigation solution [x, y, vx, vy] (ENU)
        self.nav_ms = -1  # its time_boot_ms
        self.mode: int | None = None  # from the autopilot's heartbeats
        self.sub_mode, self.armed = 0, False
        self.landed: int | None = None  # MAV_LANDED_STATE from EXTENDED_SYS_STATE (None: never told)
        self.heard = -np.inf  # when the autopilot was last heard (monotonic s)
        self.gaps: deque[tuple[float, float]] = deque(maxlen=16)  # its silences over GAP s: (ended at, seconds)
        self.texts: deque[tuple[float, str]] = deque(maxlen=16)  # its latest STATUSTEXTs, (monotonic s, text)
        self.requests: deque = deque()  # COMMAND_LONGs a ground station addressed to this companion computer
        self._acks: dict[int, int] = {}
        self._watchers: list = []  # called (under the link's condition) after each HEARTBEAT and request
        self.fault: str | None = None  # what is wrong with the autopilot's navigation stream
        self.attitude: np.ndarray | None = None  # the latest [roll, pitch, yaw] (rad; yaw ENU's, from east)
        self._streamed: tuple | None = None  # the setpoint repeated while streaming: (accel (2,), t)
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
        for name, hz in STREAMS.items():  # answered or not: an autopilot that keeps a stream is only heard more
            self.conn.mav.command_long_send(*self.target, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                                            getattr(mavlink, f"MAVLINK_MSG_ID_{name}"), 1e6 / hz if hz else -1.0,
                                            0, 0, 0, 0, 0)
        self._closed = False
        self._threads = [threading.Thread(target=f, name=f"mavlink-{name}", daemon=True)
                         for name, f in (("read", self._read), ("heartbeat", self._beat), ("stream", self._stream))]
        for thread in self._threads:
            thread.start()

    # the threads: what comes, this computer's heartbeat, the setpoint stream

    def _read(self) -> None:
        while not self._closed:
            try:
                msg = self.conn.recv_match(blocking=True, timeout=0.05)
            except OSError:  # closed under it
                return
            if msg is not None:
                with self._cond:
                    self._take(msg)
                    self._cond.notify_all()

    def _beat(self) -> None:
        while not self._closed:
            with self._send_lock:
                self.conn.mav.heartbeat_send(mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                             mavlink.MAV_STATE_ACTIVE)
            self._sleep(1.0)

    def _stream(self) -> None:
        while not self._closed:
            with self._send_lock:
                if self._streamed is not None:
                    self._send_setpoint(*self._streamed)
            self._sleep(1.0 / STREAM_RATE)

    def _sleep(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while not self._closed and (left := deadline - time.monotonic()) > 0:
            time.sleep(min(left, 0.05))

    def _take(self, msg) -> None:
        kind = msg.get_type()
        if kind == "COMMAND_LONG":  # a ground station's, to this computer (forwarded by the autopilot)
            if msg.target_component == mavlink.MAV_COMP_ID_ONBOARD_COMPUTER and msg.command in REQUESTS:
                self.requests.append(msg)
                self._watch()
            return
        if msg.get_srcSystem() != self.target[0] or msg.get_srcComponent() != self.target[1]:
            return  # another component's, or a ground station's own heartbeat
        now = time.monotonic()
        if GAP < now - self.heard < np.inf:
            self.gaps.append((now, now - self.heard))
        self.heard = now
        if kind == "HEARTBEAT":
            self.mode, self.sub_mode = px4.main_mode(msg.custom_mode), px4.sub_mode(msg.custom_mode)
            self.armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            self._watch()
        elif kind == "EXTENDED_SYS_STATE":
            self.landed = msg.landed_state
        elif kind == "STATUSTEXT":
            self.texts.append((self.heard, msg.text))
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

    def _watch(self) -> None:
        for watcher in self._watchers:
            watcher()

    def watch(self, watcher) -> None:
        """Call ``watcher()`` after every heartbeat and every request that comes (in the reading thread, holding the
        link's condition: it must not wait on the link)."""
        self._watchers.append(watcher)

    # what the UAV's process asks of it

    def wait(self, until, timeout: float) -> bool:
        """Wait up to ``timeout`` s until ``until()`` holds (checked whenever something came); returns whether it
        does."""
        with self._cond:
            return self._cond.wait_for(until, timeout)

    def command(self, command: int, *params: float, what: str) -> None:
        """Send ``COMMAND_LONG`` ``command`` to the autopilot and wait for its acknowledgement
        (:class:`AutopilotRefused` naming ``what`` unless it is accepted, :class:`AutopilotSilent` if unanswered)."""
        with self._cond:
            self._acks.pop(command, None)
        with self._send_lock:
            self.conn.mav.command_long_send(*self.target, command, 0, *params, *[0.0] * (7 - len(params)))
        if not self.wait(lambda: command in self._acks, ACK_TIMEOUT):
            raise AutopilotSilent(f"UAV {self.uav + 1}'s autopilot did not acknowledge {what} within "
                                  f"{ACK_TIMEOUT:g} s")
        if self._acks[command] != mavlink.MAV_RESULT_ACCEPTED:
            raise AutopilotRefused(f"UAV {self.uav + 1}'s autopilot refused {what}: "
                                   f"{px4.result_name(self._acks[command])}")

    def acknowledge(self, request, result: int, text: str | None = None) -> None:
        """Answer a ground station's ``request`` (:attr:`requests`) with ``result``, and ``text`` as a STATUSTEXT."""
        with self._send_lock:
            if text is not None:
                self.conn.mav.statustext_send(mavlink.MAV_SEVERITY_INFO if result == mavlink.MAV_RESULT_ACCEPTED
                                              else mavlink.MAV_SEVERITY_WARNING, text.encode()[:50])
            self.conn.mav.command_ack_send(request.command, result, target_system=request.get_srcSystem(),
                                           target_component=request.get_srcComponent())

    def navigation(self, after_ms: int = -1, timeout: float = HEARTBEAT_TIMEOUT) -> np.ndarray:
        """The latest navigation solution ``[x, y, vx, vy]`` (ENU), waiting up to ``timeout`` s for one newer than
        ``after_ms`` (``time_boot_ms``); :class:`AutopilotError` if none comes, or if the stream held a NaN or went
        back in time (the UAV's process then stops, and its autopilot's failsafe holds it)."""
        if not self.wait(lambda: self.nav_ms > after_ms or self.fault is not None, timeout):
            raise AutopilotError(f"UAV {self.uav + 1}: no navigation from the autopilot at {self.url} within "
                                 f"{timeout:g} s")
        if self.fault is not None:
            raise AutopilotError(f"UAV {self.uav + 1}: the autopilot at {self.url}: {self.fault}")
        assert self.nav is not None  # wait() returned with a navigation solution
        return self.nav.copy()

    def send_acceleration(self, accel: np.ndarray, t: float) -> None:
        """The planar acceleration ``accel`` (2,) (ENU, m/s²) as an offboard setpoint stamped ``t`` (s), sent now and
        repeated from then at :data:`STREAM_RATE` until the next (or :meth:`stop_stream`)."""
        with self._send_lock:
            self._streamed = (np.asarray(accel, dtype=float).copy(), t)
            self._send_setpoint(*self._streamed)

    def stop_stream(self) -> None:
        """No setpoint is sent from now (until the next :meth:`send_acceleration`)."""
        with self._send_lock:
            self._streamed = None

    def _send_setpoint(self, accel: np.ndarray, t: float) -> None:
        a = enu_to_ned([accel[0], accel[1], 0.0])
        self.conn.mav.set_position_target_local_ned_send(
            int(round(t * 1000)), *self.target, mavlink.MAV_FRAME_LOCAL_NED, px4.ACCELERATION,
            0.0, 0.0, 0.0, 0.0, 0.0, 0.0, *a.tolist(), 0.0, 0.0)

    def close(self) -> None:
        """Stop its threads (joined), then the connection."""
        self._closed = True
        for thread in getattr(self, "_threads", []):
            thread.join(timeout=2.0)
        self.conn.close()
