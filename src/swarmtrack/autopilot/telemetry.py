"""A simulated vehicle's telemetry streams on one MAVLink link, at PX4's default rates, and the commands that set and
request them.

PX4 keeps, per MAVLink instance, a set of streams with an interval each, set at start from the instance's mode
(``Mavlink::configure_streams_to_default`` in PX4-Autopilot ``src/modules/mavlink/mavlink_main.cpp``, main of
2025-2026, file commit 000f5fdb): PX4 SITL's link to the offboard computer (UDP 14540 + i) runs in mode ``onboard``,
its ground-station link (UDP 18570 + i) in mode ``normal``. :class:`Streams` is one such instance: :data:`STREAMS`
lists what it sends and at which default rate in each mode, each message filled as PX4's stream of that name fills it
(``src/modules/mavlink/streams/<NAME>.hpp``) from the vehicle's :class:`~swarmtrack.autopilot.state.VehicleState`.

Commands (``COMMAND_LONG`` or ``COMMAND_INT`` to this system and its component, or to all components), answered as
PX4's ``MavlinkReceiver::handle_message_command_both`` answers them (``src/modules/mavlink/mavlink_receiver.cpp``):

- ``MAV_CMD_SET_MESSAGE_INTERVAL`` (511): ``param2`` µs > 0 sets the interval, −1 stops the stream, 0 restores this
  mode's default; HEARTBEAT, a message without a stream here, or a non-zero ``param3``/``param4``/``param7``
  (response target) → ``MAV_RESULT_FAILED``;
- ``MAV_CMD_GET_MESSAGE_INTERVAL`` (510): ``MESSAGE_INTERVAL`` (µs; −1 stopped; 0 no such stream), then accepted;
- ``MAV_CMD_REQUEST_MESSAGE`` (512), ``MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES`` (520, any component),
  ``MAV_CMD_GET_HOME_POSITION`` (410): the message is sent, then ``MAV_RESULT_ACCEPTED``; ``MAV_RESULT_DENIED`` when
  it cannot be (HOME_POSITION before home is set, a message not served here). AUTOPILOT_VERSION and
  FLIGHT_INFORMATION (MAVSDK's ``info``) are sent only on request, as PX4 streams neither by default;
- ``MAV_CMD_REQUEST_PROTOCOL_VERSION`` (519): ``MAV_RESULT_UNSUPPORTED`` (PROTOCOL_VERSION is not in pymavlink's
  common dialect; PX4 sends it).

The acknowledgement follows the message, as in PX4. :meth:`Streams.handle` returns False for other commands and for
commands to another system or component, which the vehicle serves (arming, modes) or forwards.

A stream is sent at most once per :meth:`Streams.tick`: its rate is the lower of its interval's and the caller's tick
rate. PX4's "unlimited" streams (``-1``: every new sample) are sent at :data:`UNLIMITED_HZ`. Not modelled, sent as
MAVLink's "unknown": angular rates (0), the CPU load (0), the battery current (−1), GPS accuracy and satellites
(``UINT16_MAX``/255).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot.geodesy import PX4_SITL, Origin
from swarmtrack.autopilot.params import Parameters
from swarmtrack.autopilot.state import VehicleState

NORMAL, ONBOARD = "normal", "onboard"
#: The rate (Hz) of PX4's "unlimited" streams here.
UNLIMITED_HZ = 10.0
UNLIMITED = -1.0


@dataclass(frozen=True)
class Stream:
    """A message PX4 streams, and its default rate (Hz; 0 only on request, −1 unlimited) in each mode."""

    name: str
    normal: float
    onboard: float

    @property
    def id(self) -> int:
        return getattr(mavlink, f"MAVLINK_MSG_ID_{self.name}")


#: What a link sends, with PX4's defaults (``configure_streams_to_default``, modes normal and onboard).
#: LOCAL_POSITION_NED is the vehicle's own unless ``Streams(local_position=True)``.
STREAMS: tuple[Stream, ...] = (
    Stream("SYS_STATUS", 1.0, 5.0),
    Stream("EXTENDED_SYS_STATE", 1.0, 5.0),
    Stream("HOME_POSITION", 0.5, 0.5),
    Stream("GLOBAL_POSITION_INT", 5.0, 50.0),
    Stream("LOCAL_POSITION_NED", 1.0, 30.0),
    Stream("ATTITUDE", 15.0, 100.0),
    Stream("ATTITUDE_QUATERNION", 10.0, 50.0),
    Stream("ALTITUDE", 1.0, 10.0),
    Stream("VFR_HUD", 4.0, 10.0),
    Stream("GPS_RAW_INT", 5.0, UNLIMITED),
    Stream("BATTERY_STATUS", 0.5, 0.5),
    Stream("AUTOPILOT_VERSION", 0.0, 0.0),
    Stream("FLIGHT_INFORMATION", 0.0, 0.0),
)
BY_ID = {s.id: s for s in STREAMS}

#: SYS_STATUS's sensors and controllers present, enabled and healthy (a healthy PX4 SITL quadrotor without RC),
#: with MAV_SYS_STATUS_EXTENSION_USED as PX4 sets it. MAVSDK's health reads the GPS bit (global and local position
#: ok), the gyro/accelerometer/magnetometer bits (calibration ok) and the pre-arm bit (armable).
SENSORS = (mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO | mavlink.MAV_SYS_STATUS_SENSOR_3D_ACCEL
           | mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG | mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
           | mavlink.MAV_SYS_STATUS_SENSOR_GPS | mavlink.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
           | mavlink.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION | mavlink.MAV_SYS_STATUS_SENSOR_YAW_POSITION
           | mavlink.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL | mavlink.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
           | mavlink.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS | mavlink.MAV_SYS_STATUS_AHRS
           | mavlink.MAV_SYS_STATUS_SENSOR_BATTERY | mavlink.MAV_SYS_STATUS_PREARM_CHECK
           | mavlink.MAV_SYS_STATUS_EXTENSION_USED)

#: AUTOPILOT_VERSION's capabilities: PX4's (``Mavlink::send_autopilot_capabilities``) without those of services this
#: vehicle does not have (FTP, SET_ATTITUDE_TARGET, FLIGHT_TERMINATION). MAVSDK uses the mission protocol only when
#: MISSION_INT is set, and reads parameters bytewise from a PX4.
CAPABILITIES = (mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
                | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
                | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
                | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2 | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
                | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY)
#: The flight software version it reports: PX4 1.14.0, an official release (major, minor, patch, FIRMWARE_VERSION_TYPE
#: packed as PX4's ``px4_firmware_version``), the release whose behaviour the simulated vehicle follows.
FLIGHT_SW_VERSION = (1 << 24) | (14 << 16) | (0 << 8) | mavlink.FIRMWARE_VERSION_TYPE_OFFICIAL
#: The vehicle's unique ids: PX4 SITL adds ``system − 1`` to its board's (``CONFIG_ARCH_BOARD_PX4_SITL``); here the
#: base is b"swarmtrk" as an integer, and uid2 is "swarmtrack" followed by the system id.
UID_BASE = int.from_bytes(b"swarmtrk", "big")
#: PX4's battery warning thresholds (BAT_LOW_THR, BAT_CRIT_THR, BAT_EMERGEN_THR defaults), as fractions remaining.
LOW, CRITICAL, EMERGENCY = 0.15, 0.07, 0.05
COMMANDS = {mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAV_CMD_GET_MESSAGE_INTERVAL,
            mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
            mavlink.MAV_CMD_GET_HOME_POSITION, mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION}


class Battery:
    """PX4 SITL's simulated battery (``BatterySimulator::Run``, ``src/modules/simulation/battery_simulator``): full
    while disarmed; armed, its charge falls linearly, by the elapsed time over ``SIM_BAT_DRAIN`` (60 s from full to
    empty), never below ``SIM_BAT_MIN_PCT`` (50 %); the voltage is ``BAT1_N_CELLS`` cells each at
    ``BAT1_V_EMPTY + remaining·(BAT1_V_CHARGED − BAT1_V_EMPTY)`` (4 × 3.6-4.05 V). PX4's battery library inverts that
    same linear map, so the remaining charge it reports is this one. Times are the vehicle's ``boot_ms``; one battery
    per vehicle, shared by its links' :class:`Streams` (a second update at the same ``boot_ms`` changes nothing)."""

    def __init__(self, params: Parameters | None = None):
        self.params = params if params is not None else Parameters()
        self.remaining = 1.0
        self._last_ms: int | None = None

    def update(self, armed: bool, boot_ms: int) -> None:
        drain = float(self.params.get("SIM_BAT_DRAIN"))
        if not armed:
            self.remaining, self._last_ms = 1.0, None
        else:
            if self._last_ms is not None and drain > 0 and boot_ms > self._last_ms:
                self.remaining -= (boot_ms - self._last_ms) / 1000.0 / drain
            self._last_ms = boot_ms if self._last_ms is None else max(self._last_ms, boot_ms)
        self.remaining = max(self.remaining, float(self.params.get("SIM_BAT_MIN_PCT")) / 100.0)

    @property
    def voltage(self) -> float:
        """The pack's voltage (V)."""
        empty, full = float(self.params.get("BAT1_V_EMPTY")), float(self.params.get("BAT1_V_CHARGED"))
        return int(self.params.get("BAT1_N_CELLS")) * (empty + self.remaining * (full - empty))

    @property
    def charge_state(self) -> int:
        """``MAV_BATTERY_CHARGE_STATE`` by PX4's warning thresholds."""
        if self.remaining < EMERGENCY:
            return mavlink.MAV_BATTERY_CHARGE_STATE_EMERGENCY
        if self.remaining < CRITICAL:
            return mavlink.MAV_BATTERY_CHARGE_STATE_CRITICAL
        if self.remaining < LOW:
            return mavlink.MAV_BATTERY_CHARGE_STATE_LOW
        return mavlink.MAV_BATTERY_CHARGE_STATE_OK


def quaternion(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """(w, x, y, z) of the Euler angles (ZYX: yaw, then pitch, then roll), as PX4's ``Quatf(Eulerf(...))``."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy)


def _int16(x: float) -> int:
    return int(max(-32768, min(32767, round(x))))


class Streams:
    """One MAVLink link's telemetry (module docstring): ``mav`` the link's pymavlink ``MAVLink`` object (its
    ``srcSystem``/``srcComponent`` the vehicle's), ``mode`` PX4's mode of that link (``"onboard"``: the offboard
    computer's link; ``"normal"``: a ground station's), ``origin`` the geodetic point of the local frame's origin
    (PX4 SITL's default start), ``battery`` the vehicle's (one per vehicle; a new one from ``params`` if None),
    ``local_position`` whether this link sends LOCAL_POSITION_NED itself (the vehicle sends it by default). Not
    thread-safe: the vehicle calls it from one thread (or under its lock)."""

    def __init__(self, mav, mode: str = ONBOARD, origin: Origin = PX4_SITL, params: Parameters | None = None,
                 battery: Battery | None = None, local_position: bool = False):
        if mode not in (NORMAL, ONBOARD):
            raise ValueError(f"mode {mode!r}: expected {NORMAL!r} or {ONBOARD!r}")
        self.mav, self.mode, self.origin = mav, mode, origin
        self.battery = battery if battery is not None else Battery(params)
        self._served = {s.id for s in STREAMS if local_position or s.name != "LOCAL_POSITION_NED"}
        self._interval: dict[int, float] = {}  # message id -> seconds between sends (absent: stopped)
        self._due: dict[int, float] = {}
        self._armed_ms = self._takeoff_ms = 0  # boot_ms of the arming and of the takeoff (0: not armed, on ground)
        for sid in self._served:
            self._default(sid)

    def _default(self, msg_id: int) -> None:
        hz = getattr(BY_ID[msg_id], self.mode)
        self._due.pop(msg_id, None)
        if hz == 0:
            self._interval.pop(msg_id, None)
        else:
            self._interval[msg_id] = 1.0 / (UNLIMITED_HZ if hz == UNLIMITED else hz)

    def interval(self, msg_id: int) -> float | None:
        """Seconds between two ``msg_id`` messages on this link; None when it is not streamed."""
        return self._interval.get(msg_id)

    # -- the stream loop --------------------------------------------------------------------------------------------

    def tick(self, now: float, state: VehicleState) -> None:
        """Send every stream that is due at ``now`` (monotonic seconds) from ``state``."""
        self.battery.update(state.armed, state.boot_ms)
        self._flight(state)
        for msg_id, interval in self._interval.items():
            due = self._due.get(msg_id, now)
            if now >= due:
                self.send(msg_id, state)
                self._due[msg_id] = due + interval if now - due < interval else now + interval

    def send(self, msg_id: int, state: VehicleState) -> bool:
        """Send one ``msg_id`` message now; False when it cannot be (not served here, HOME_POSITION without home)."""
        if msg_id not in self._served:
            return False
        return getattr(self, "_" + BY_ID[msg_id].name.lower())(state) is not False

    def _flight(self, state: VehicleState) -> None:
        """The arming and takeoff times PX4 keeps in ``vehicle_status`` (``armed_time``, ``takeoff_time``: since boot,
        cleared at disarming), as this link sees them at its ticks."""
        if not state.armed:
            self._armed_ms = self._takeoff_ms = 0
            return
        if not self._armed_ms:
            self._armed_ms = max(1, state.boot_ms)
        if not self._takeoff_ms and state.landed in (mavlink.MAV_LANDED_STATE_IN_AIR, mavlink.MAV_LANDED_STATE_TAKEOFF):
            self._takeoff_ms = max(1, state.boot_ms)

    # -- commands ---------------------------------------------------------------------------------------------------

    def handle(self, msg, state: VehicleState) -> bool:
        """Answer ``msg`` if it is one of this module's commands to this autopilot (module docstring)."""
        if msg.get_type() not in ("COMMAND_LONG", "COMMAND_INT") or msg.command not in COMMANDS:
            return False
        broadcast = msg.command in (mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
                                    mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION)
        to_us = msg.target_system == self.mav.srcSystem or (broadcast and msg.target_system == 0)
        if not to_us or not (broadcast or msg.target_component in (self.mav.srcComponent, mavlink.MAV_COMP_ID_ALL)):
            return False
        p7 = msg.param7 if msg.get_type() == "COMMAND_LONG" else msg.z
        cmd = msg.command
        if cmd == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL:
            result = self._set_interval(int(msg.param1 + 0.5), msg.param2, (msg.param3, msg.param4, p7))
        elif cmd == mavlink.MAV_CMD_GET_MESSAGE_INTERVAL:
            msg_id = int(msg.param1 + 0.5)
            known = msg_id in self._served
            interval = self._interval.get(msg_id)
            self.mav.message_interval_send(msg_id, int(round(interval * 1e6)) if interval else (-1 if known else 0))
            result = mavlink.MAV_RESULT_ACCEPTED
        elif cmd == mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION:
            result = mavlink.MAV_RESULT_UNSUPPORTED
        else:
            msg_id = {mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
                      mavlink.MAV_CMD_GET_HOME_POSITION: mavlink.MAVLINK_MSG_ID_HOME_POSITION}.get(cmd)
            if msg_id is None:
                msg_id = int(round(msg.param1))
            result = mavlink.MAV_RESULT_ACCEPTED if self.send(msg_id, state) else mavlink.MAV_RESULT_DENIED
        self.mav.command_ack_send(cmd, result, target_system=msg.get_srcSystem(),
                                  target_component=msg.get_srcComponent())
        return True

    def _set_interval(self, msg_id: int, interval_us: float, extra: tuple[float, float, float]) -> int:
        if msg_id == mavlink.MAVLINK_MSG_ID_HEARTBEAT or msg_id not in self._served:
            return mavlink.MAV_RESULT_FAILED
        if any(math.isfinite(p) and int(p + 0.5) != 0 for p in extra):
            return mavlink.MAV_RESULT_FAILED  # PX4: "param3/param4 not supported", "response target not supported"
        if interval_us < -0.00001:
            self._interval.pop(msg_id, None)
            self._due.pop(msg_id, None)
        elif interval_us > 0.00001:
            self._interval[msg_id] = interval_us / 1e6
            self._due.pop(msg_id, None)
        else:
            self._default(msg_id)
        return mavlink.MAV_RESULT_ACCEPTED

    # -- the messages (PX4's streams/<NAME>.hpp) --------------------------------------------------------------------

    def _global(self, state: VehicleState) -> tuple[float, float, float]:
        n, e, d = (float(v) for v in state.position)
        return self.origin.to_global(n, e, d)

    def _relative_alt(self, state: VehicleState) -> float:
        home_down = float(state.home[2]) if state.home is not None else 0.0
        return -(float(state.position[2]) - home_down)

    def _sys_status(self, state: VehicleState) -> None:
        health = SENSORS if getattr(state, "armable", True) else SENSORS & ~mavlink.MAV_SYS_STATUS_PREARM_CHECK
        b = self.battery
        self.mav.sys_status_send(SENSORS, SENSORS, health, 0, int(round(b.voltage * 1000)), -1,
                                 int(math.ceil(b.remaining * 100)), 0, 0, 0, 0, 0, 0)

    def _extended_sys_state(self, state: VehicleState) -> None:
        self.mav.extended_sys_state_send(mavlink.MAV_VTOL_STATE_UNDEFINED, int(state.landed))

    def _home_position(self, state: VehicleState) -> bool:
        if state.home is None:
            return False  # PX4 sends it only once home is valid
        n, e, d = (float(v) for v in state.home)
        lat, lon, alt = self.origin.to_global(n, e, d)
        self.mav.home_position_send(int(round(lat * 1e7)), int(round(lon * 1e7)), int(round(alt * 1000)), n, e, d,
                                    [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0, time_usec=state.boot_ms * 1000)
        return True

    def _global_position_int(self, state: VehicleState) -> None:
        lat, lon, alt = self._global(state)
        v = np.asarray(state.velocity, dtype=float) * 100.0
        hdg = math.degrees(float(state.attitude[2]) % (2 * math.pi)) * 100.0
        self.mav.global_position_int_send(state.boot_ms, int(round(lat * 1e7)), int(round(lon * 1e7)),
                                          int(round(alt * 1000)), int(round(self._relative_alt(state) * 1000)),
                                          _int16(v[0]), _int16(v[1]), _int16(v[2]), min(int(hdg), 35999))

    def _local_position_ned(self, state: VehicleState) -> None:
        p, v = (float(x) for x in state.position), (float(x) for x in state.velocity)
        self.mav.local_position_ned_send(state.boot_ms, *p, *v)

    def _attitude(self, state: VehicleState) -> None:
        r, p, y = (float(a) for a in state.attitude)
        self.mav.attitude_send(state.boot_ms, r, p, y, 0.0, 0.0, 0.0)

    def _attitude_quaternion(self, state: VehicleState) -> None:
        self.mav.attitude_quaternion_send(state.boot_ms, *quaternion(*(float(a) for a in state.attitude)),
                                          0.0, 0.0, 0.0)

    def _altitude(self, state: VehicleState) -> None:
        amsl = self._global(state)[2]
        self.mav.altitude_send(state.boot_ms * 1000, amsl, amsl, -float(state.position[2]),
                               self._relative_alt(state), math.nan, math.nan)

    def _vfr_hud(self, state: VehicleState) -> None:
        ground = math.hypot(float(state.velocity[0]), float(state.velocity[1]))
        heading = int(math.degrees(float(state.attitude[2]) % (2 * math.pi))) % 360
        self.mav.vfr_hud_send(ground, ground, heading, 0, self._global(state)[2], -float(state.velocity[2]))

    def _gps_raw_int(self, state: VehicleState) -> None:
        lat, lon, alt = self._global(state)
        vn, ve = float(state.velocity[0]), float(state.velocity[1])
        speed = math.hypot(vn, ve)
        cog = int(math.degrees(math.atan2(ve, vn)) % 360 * 100) if speed > 0.1 else 65535
        self.mav.gps_raw_int_send(state.boot_ms * 1000, mavlink.GPS_FIX_TYPE_3D_FIX, int(round(lat * 1e7)),
                                  int(round(lon * 1e7)), int(round(alt * 1000)), 65535, 65535,
                                  int(round(speed * 100)), min(cog, 65535), 255)

    def _battery_status(self, state: VehicleState) -> None:
        b = self.battery
        voltages = [int(round(b.voltage * 1000))] + [65535] * 9  # the total in the first cell, as PX4 without cells
        self.mav.battery_status_send(0, mavlink.MAV_BATTERY_FUNCTION_ALL, mavlink.MAV_BATTERY_TYPE_LIPO, 32767,
                                     voltages, -1, -1, -1, int(round(b.remaining * 100)), 0, b.charge_state)

    def _flight_information(self, state: VehicleState) -> None:
        # PX4 fills the "_utc" fields with its boot-relative µs (FLIGHT_INFORMATION.hpp), as MAVSDK reads them;
        # flight_uuid (COM_FLIGHT_UUID, PX4's count of flights) is not kept here: 0
        self.mav.flight_information_send(state.boot_ms, self._armed_ms * 1000, self._takeoff_ms * 1000, 0)

    def _autopilot_version(self, state: VehicleState) -> None:
        uid2 = list(b"swarmtrack".ljust(17, b"\0")) + [state.system & 0xFF]
        self.mav.autopilot_version_send(CAPABILITIES, FLIGHT_SW_VERSION, FLIGHT_SW_VERSION, 0, 0, [0] * 8, [0] * 8,
                                        [0] * 8, 0, 0, UID_BASE + state.system - 1, uid2)
