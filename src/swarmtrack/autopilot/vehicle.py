"""A simulated UAV's autopilot as PX4 SITL (v1.14) presents it to an offboard program and to a ground station, for
tests and demos (the world's side). It composes:

- two links (:mod:`~swarmtrack.autopilot.endpoint`), as PX4 SITL instance ``i``: the offboard (onboard) link from
  local port ``port + 40`` (14580 + i) to ``host:port`` (14540 + i), and the ground-station link from local port
  ``port + 4030`` (18570 + i), sending only once claimed (a ground station sent to it first) or configured
  (``gcs_port``). A port taken by another process is :class:`~swarmtrack.autopilot.endpoint.VehicleError`;
- the commander (:mod:`~swarmtrack.autopilot.commander`): modes, arming, commands, offboard setpoints, the
  offboard-loss failsafe, and what each mode flies through PX4's position control
  (:mod:`~swarmtrack.autopilot.flight`);
- the services: its parameters (:class:`~swarmtrack.autopilot.params.Parameters`), missions
  (:class:`~swarmtrack.autopilot.mission.Missions`) and each link's telemetry streams at PX4's default rates
  (:class:`~swarmtrack.autopilot.telemetry.Streams`: onboard rates on the offboard link, normal ones on the ground
  station's);
- ``HEARTBEAT`` on each link every second of wall-clock time, and at once when the mode or arming changes (a
  quadrotor, PX4, the armed flag and PX4's main and sub mode);
- ``LOCAL_POSITION_NED`` on the offboard link each time the world publishes the UAV's navigation, stamped with the
  world's time (in lockstep the link matches it to the step); its streams send ``ATTITUDE`` (the world's when it gives
  one, else derived from the acceleration it flies) at their rates;
- forwarding, as PX4's ``MAV_x_FORWARD``: a ``COMMAND_LONG``/``COMMAND_INT`` from the ground station addressed to
  another component of this system (the companion computer, ``MAV_COMP_ID_ONBOARD_COMPUTER``) goes to the offboard
  link, and the companion's ``COMMAND_ACK``, ``STATUSTEXT`` and ``HEARTBEAT`` go to the ground station.

Dispatch of what comes in: the commands the streams serve (message intervals, requests) → the link's streams;
``PARAM_*`` → parameters; ``MISSION_*`` → missions; ``SET_POSITION_TARGET_LOCAL_NED``, ``..._GLOBAL_INT`` and the
other commands → the commander; the setpoints PX4 flies and this vehicle does not (:data:`NOT_FLOWN`: attitude and
actuator targets) are counted in :attr:`MavlinkVehicle.refused` and said once a second; anything else is ignored, as
PX4 ignores what it has no handler for.

The vehicle's vertical channel is its own when the world is planar (:class:`~swarmtrack.autopilot.flight.Vertical`):
it climbs, holds and lands as its modes fly it; a 3-D world's altitude, when given to :meth:`MavlinkVehicle.publish`,
is the one reported. Times: ``now`` is the caller's clock (simulated seconds in lockstep; the run's seconds in real
time); heartbeats and streams run on wall-clock monotonic time. Not thread-safe: one thread (or a lock) drives it.
"""

from __future__ import annotations

import math
import time

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot import px4
from swarmtrack.autopilot.commander import Commander
from swarmtrack.autopilot.endpoint import Endpoint, VehicleError
from swarmtrack.autopilot.flight import Limits, Setpoint, Vertical, attitude_of, horizontal
from swarmtrack.autopilot.frames import enu_to_ned, ned_to_enu, yaw_enu_to_ned
from swarmtrack.autopilot.geodesy import PX4_SITL, Origin
from swarmtrack.autopilot.mission import Missions
from swarmtrack.autopilot.params import Parameters
from swarmtrack.autopilot.state import VehicleState
from swarmtrack.autopilot.telemetry import NORMAL, ONBOARD, Battery, Streams

__all__ = ["MavlinkVehicle", "VehicleError", "hold"]

AUTOPILOT = mavlink.MAV_COMP_ID_AUTOPILOT1
#: What the companion computer sends that the ground station is forwarded.
FORWARDED_TO_GCS = ("COMMAND_ACK", "STATUSTEXT", "HEARTBEAT")
#: Offboard setpoints PX4 flies and this vehicle does not: counted and said (STATUSTEXT), never flown.
NOT_FLOWN = ("SET_ATTITUDE_TARGET", "SET_ACTUATOR_CONTROL_TARGET")
#: The altitude (m) a vehicle starting in the air holds when the world gives none: PX4's ``MIS_TAKEOFF_ALT``.
AIRBORNE_ALTITUDE = 2.5


def hold(nav: np.ndarray, anchor: np.ndarray) -> np.ndarray:
    """The acceleration (2,) (ENU) with which PX4's Hold holds a UAV at ``anchor`` (2,) (ENU), from its navigation
    ``[x, y, vx, vy]`` (ENU): the position cascade with PX4's default gains, speed ``MPC_XY_CRUISE`` and acceleration
    ``MPC_ACC_HOR`` (:func:`~swarmtrack.autopilot.flight.horizontal`)."""
    sp = Setpoint(position=np.array([anchor[1], anchor[0], 0.0]))
    return ned_to_enu(horizontal(sp, np.array([nav[1], nav[0]]), np.array([nav[3], nav[2]]), Limits(),
                                 own_mode=True))


def _base_mode(armed: bool, main: int) -> int:
    """``HEARTBEAT.base_mode`` as PX4's ``get_mavlink_mode_state`` sets it."""
    flags = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mavlink.MAV_MODE_FLAG_SAFETY_ARMED if armed else 0)
    if main in (px4.MANUAL, px4.ALTCTL, px4.POSCTL, px4.STABILIZED, px4.ACRO):
        flags |= mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
    if main != px4.MANUAL:
        flags |= mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
    if main in (px4.POSCTL, px4.AUTO, px4.OFFBOARD):
        flags |= mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
    if main in (px4.AUTO, px4.OFFBOARD):
        flags |= mavlink.MAV_MODE_FLAG_AUTO_ENABLED
    return flags


class MavlinkVehicle:
    """UAV ``uav``'s simulated autopilot (MAVLink system ``uav + 1``, component 1), its offboard link sending to
    ``host:port`` from ``local_port`` (default ``port + 40``), its ground-station link bound to ``gcs_local_port``
    (default ``port + 4030``; ``gcs=False``: none) sending to ``host:gcs_port`` when given, else to whoever claims it.
    ``airborne``: it starts armed, in the air (at ``altitude`` m, default :data:`AIRBORNE_ALTITUDE`), in Position
    mode, home below it; else landed and disarmed (PX4 at boot). ``params``: parameter values by PX4 name (or a
    :class:`~swarmtrack.autopilot.params.Parameters`); ``origin``: the geodetic point of the local origin (PX4
    SITL's by default); ``refuse``: results that replace the acceptance of ``"arm"``, ``"offboard"`` or ``"mode"``
    (tests). Raises VehicleError when a port is taken."""

    def __init__(self, uav: int, port: int, host: str = "127.0.0.1", refuse: dict[str, int] | None = None, *,
                 local_port: int | None = None, gcs_local_port: int | None = None, gcs_port: int | None = None,
                 gcs: bool = True, airborne: bool = False, altitude: float | None = None,
                 params: dict[str, float] | Parameters | None = None, origin: Origin = PX4_SITL):
        self.uav, self.system = uav, uav + 1
        name = f"UAV {uav + 1}'s autopilot"
        self.links: list[Endpoint] = []
        try:
            self.offboard_link = Endpoint(host, port + 40 if local_port is None else local_port, (host, port),
                                          self.system, AUTOPILOT, f"{name}'s offboard link")
            self.links.append(self.offboard_link)
            self.gcs_link = None
            if gcs:
                self.gcs_link = Endpoint(host, port + 4030 if gcs_local_port is None else gcs_local_port,
                                         None if gcs_port is None else (host, gcs_port), self.system, AUTOPILOT,
                                         f"{name}'s ground-station link")
                self.links.append(self.gcs_link)
        except VehicleError:
            self.close()
            raise
        self.params = params if isinstance(params, Parameters) else Parameters(params)
        self.missions = Missions()
        battery = Battery(self.params)
        self.streams = {id(self.offboard_link): Streams(self.offboard_link.mav, ONBOARD, origin, self.params, battery)}
        if self.gcs_link is not None:
            self.streams[id(self.gcs_link)] = Streams(self.gcs_link.mav, NORMAL, origin, self.params, battery,
                                                      local_position=True)
        self.commander = Commander(self.params, self._say, airborne=airborne, refuse=refuse)
        self.commander.home_amsl, self.origin = origin.alt, origin
        start = (AIRBORNE_ALTITUDE if altitude is None else float(altitude)) if airborne else 0.0
        self.vertical = Vertical(-start)
        self.state = VehicleState(system=self.system)
        self.state.position[2] = -start
        self._home_pending = True  # home: below its first navigation (PX4 sets it once its position is valid)
        self._world_attitude = False  # the world gives its attitude (else derived from what it flies)
        self.faults: list[str] = []  # messages whose handling failed (the vehicle goes on)
        self.world_altitude: float | None = None  # the 3-D world's altitude, when it gives one
        self._beat = -math.inf
        self._flown_at: float | None = None  # the caller's time of the latest command
        self._acc = np.zeros(2)  # the latest horizontal acceleration flown (NED)
        self._az = 0.0  # the latest vertical acceleration flown (NED)
        self.forwarded = {"to_companion": 0, "to_gcs": 0}
        self._text_id = 0  # the id of the latest STATUSTEXT sent in chunks

    # -- what the others read ---------------------------------------------------------------------------------------

    @property
    def armed(self) -> bool:
        return self.commander.armed

    @property
    def mode(self) -> int:
        """PX4's main mode."""
        return self.commander.main

    @property
    def sub_mode(self) -> int:
        return self.commander.sub

    @property
    def setpoint(self) -> Setpoint | None:
        """The latest accepted offboard setpoint (None: none came)."""
        return self.commander.setpoint

    @property
    def setpoint_ms(self) -> int:
        """Its ``time_boot_ms`` (−1: none came)."""
        return self.commander.setpoint_ms

    @property
    def refused(self):
        """Setpoints dropped as PX4 drops them, by PX4's text."""
        return self.commander.refused

    def offboard(self) -> bool:
        """Whether it flies the offboard program's setpoints: armed, in Offboard mode."""
        return self.commander.offboard()

    def sockets(self) -> list[Endpoint]:
        """Its links (each has ``fileno()``), to wait on with ``select``."""
        return list(self.links)

    # -- the links --------------------------------------------------------------------------------------------------

    def _say(self, severity: int, text: str) -> None:
        """``STATUSTEXT`` on every link (PX4's ``mavlink_log`` goes to all its instances); a text over 50 bytes in
        chunks of one ``id`` (``chunk_seq`` 0, 1, ..., the last one shorter than 50 bytes), as MAVLink 2 and PX4's
        ``MavlinkStreamStatustext`` send it."""
        raw = text.encode()
        if len(raw) <= 50:
            chunks, ident = [raw], 0
        else:
            self._text_id = self._text_id % 65535 + 1
            ident = self._text_id
            chunks = [raw[k:k + 50] for k in range(0, len(raw) + 1, 50)]  # ends with a chunk under 50 bytes
        for link in self.links:
            for seq, chunk in enumerate(chunks):
                link.mav.statustext_send(severity, chunk, ident, seq)

    def heartbeat(self, force: bool = False) -> None:
        """``HEARTBEAT`` on every link, at most once a second of wall-clock time (``force``: now)."""
        if not force and time.monotonic() - self._beat < 1.0:
            return
        self._beat = time.monotonic()
        c = self.commander
        status = mavlink.MAV_STATE_ACTIVE if c.armed else mavlink.MAV_STATE_STANDBY
        for link in (link for link in self.links if link.remote is not None):
            link.mav.heartbeat_send(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, _base_mode(c.armed, c.main),
                                    px4.custom_mode(c.main, c.sub), status)

    def poll(self, now: float) -> None:
        """Take every message that came on its links (non-blocking), answer, forward; then what time does (the
        failsafe, auto-disarm), heartbeats and streams. ``now``: the caller's clock."""
        self._state(now)
        for link in self.links:
            for msg in link.receive():
                try:
                    self._take(msg, link, now)
                except Exception as exc:  # noqa: BLE001 - one bad message must not stop the vehicle
                    self.faults.append(f"{msg.get_type()}: {type(exc).__name__}: {exc}")
                    del self.faults[:-20]
        self._update(now)
        if self.commander.changed:
            self.commander.changed = False
            self.heartbeat(force=True)
        else:
            self.heartbeat()
        wall = time.monotonic()
        for link in self.links:
            if link.remote is not None:  # an unclaimed ground-station link encodes nothing
                self.streams[id(link)].tick(wall, self.state)

    def _take(self, msg, link: Endpoint, now: float) -> None:
        kind = msg.get_type()
        mav = link.mav
        if kind in ("COMMAND_LONG", "COMMAND_INT"):
            self._command(msg, link, now)
        elif kind.startswith("PARAM_"):
            self.params.handle(msg, mav)
        elif kind.startswith("MISSION_"):
            self.missions.handle(msg, mav)
        elif kind in ("SET_POSITION_TARGET_LOCAL_NED", "SET_POSITION_TARGET_GLOBAL_INT"):
            if msg.target_system in (0, self.system) and msg.target_component in (0, AUTOPILOT):
                self.commander.take_setpoint(msg, now, self.origin)
        elif kind in NOT_FLOWN:
            text = f"{kind} not supported by this simulated vehicle"
            self.commander.refused[text] += 1
            self.commander._say_once(text, now)
        elif (link is self.offboard_link and self.gcs_link is not None and kind in FORWARDED_TO_GCS
              and msg.get_srcComponent() != AUTOPILOT):
            self._forward(msg, self.gcs_link, "to_gcs")

    def _forward(self, msg, to: Endpoint, counter: str) -> None:
        if to.remote is not None:
            to.write(msg.get_msgbuf())
            self.forwarded[counter] += 1

    def _command(self, msg, link: Endpoint, now: float) -> None:
        if msg.target_system not in (0, self.system):
            return
        if msg.target_component not in (0, AUTOPILOT):  # another component of this system: forwarded
            if link is self.gcs_link:
                self._forward(msg, self.offboard_link, "to_companion")
            return
        if self.streams[id(link)].handle(msg, self.state):
            return
        if msg.get_type() == "COMMAND_LONG":
            params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)
        else:
            params = (msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x), float(msg.y), msg.z)
        if msg.command == mavlink.MAV_CMD_DO_REPOSITION:
            result = self.commander.reposition(self._target(msg, params), int(params[1] or 0) & 1 == 1
                                               if math.isfinite(params[1]) else False, now, self.vertical.on_ground)
        else:
            result = self.commander.command(msg.command, params, now, self.vertical.on_ground, self.state.position)
        link.mav.command_ack_send(msg.command, result, target_system=msg.get_srcSystem(),
                                  target_component=msg.get_srcComponent())
        if self.commander.changed:  # the new state is told at once
            self.commander.changed = False
            self.heartbeat(force=True)

    def _target(self, msg, params: tuple) -> np.ndarray:
        """The NED point of a reposition: latitude and longitude (``COMMAND_INT``'s ``x, y`` in 1e-7 degrees, or
        ``COMMAND_LONG``'s ``param5, param6`` in degrees) and altitude AMSL (``param7`` / ``z``); an unset one (NaN,
        or 0 in ``COMMAND_INT``) is the vehicle's own."""
        scale = 1e-7 if msg.get_type() == "COMMAND_INT" else 1.0
        lat, lon, alt = params[4] * scale, params[5] * scale, params[6]
        here = self.state.position
        n, e, d = self.origin.to_local(lat, lon, alt if math.isfinite(alt) else self.origin.alt - here[2])
        given = math.isfinite(lat) and math.isfinite(lon) and not (scale != 1.0 and params[4] == 0 == params[5])
        return np.array([n if given else here[0], e if given else here[1], d])

    # -- the world's side -------------------------------------------------------------------------------------------

    def _update(self, now: float) -> None:
        self.commander.update(now, self.vertical.on_ground, self.vertical.z)
        self._state(now)

    def _state(self, now: float) -> None:
        s, c = self.state, self.commander
        s.boot_ms = max(0, int(round(now * 1000)))
        s.armed, s.main_mode, s.sub_mode = c.armed, c.main, c.sub
        s.landed = c.landed_state(self.vertical.on_ground, self.vertical.vz)
        s.position[2] = -self.world_altitude if self.world_altitude is not None else self.vertical.z
        s.velocity[2] = self.vertical.vz
        s.home = None if c.home is None else c.home.copy()

    def publish(self, t: float, nav: np.ndarray, attitude: np.ndarray | None = None,
                altitude: float | None = None) -> None:
        """Send the UAV's navigation ``[x, y, vx, vy]`` (ENU) at time ``t`` (s) as ``LOCAL_POSITION_NED`` on the
        offboard link, its altitude the world's ``altitude`` (m up) when given, else the vehicle's own; and its
        ``attitude`` ``[roll, pitch, yaw]`` (ENU yaw) when given, which its streams send as ``ATTITUDE`` (else one
        derived from the acceleration it flies)."""
        if altitude is not None and self.world_altitude is None:
            self.vertical.z = -float(altitude)  # its own channel starts at the world's altitude
        self.world_altitude = None if altitude is None else float(altitude)
        s = self.state
        s.position[:2] = enu_to_ned([nav[0], nav[1]])
        s.velocity[:2] = enu_to_ned([nav[2], nav[3]])
        if self._home_pending:
            self.commander.home = np.array([s.position[0], s.position[1], 0.0])
            self._home_pending = False
        self._state(t)
        if attitude is not None:
            s.attitude = np.array([attitude[0], attitude[1], float(yaw_enu_to_ned(attitude[2]))])
            self._world_attitude = True
        self.offboard_link.mav.local_position_ned_send(int(round(t * 1000)), *s.position.tolist(),
                                                       *s.velocity.tolist())

    def command(self, nav: np.ndarray, now: float) -> np.ndarray:
        """The horizontal acceleration (2,) (ENU) it flies now from the navigation ``nav`` ``[x, y, vx, vy]``
        (ENU): the latest offboard setpoint while armed in Offboard mode and fresh (an acceleration setpoint exactly
        as it came), else its mode's own control (Position or Hold: brake and hold; Takeoff, Land, Return) or the
        failsafe's. Its own vertical channel advances to ``now`` under the vertical acceleration it flew."""
        if self._flown_at is not None and now > self._flown_at:
            self.vertical.advance(now - self._flown_at, self._az, self.commander.armed)
        self._flown_at = now if self._flown_at is None else max(self._flown_at, now)
        p = np.array([nav[1], nav[0], self.vertical.z])
        v = np.array([nav[3], nav[2], self.vertical.vz])
        self._update(now)
        acc, self._az = self.commander.fly(now, p, v, self.vertical.on_ground)
        self._acc = acc
        if not self._world_attitude:
            self.state.attitude = attitude_of(acc if np.isfinite(acc).all() else np.zeros(2), self.commander.yaw)
        return np.array([acc[1], acc[0]])

    def close(self) -> None:
        for link in self.links:
            link.close()
