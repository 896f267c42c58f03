"""A simulated UAV's autopilot as PX4 SITL presents it to an offboard program, for tests and demos (the world's side).

PX4 SITL instance i sends MAVLink to UDP port 14540 + i, where its offboard program listens; :class:`MavlinkVehicle`
does the same for one simulated UAV, as MAVLink system ``uav + 1``, component ``MAV_COMP_ID_AUTOPILOT1``:

- ``HEARTBEAT`` every second (a quadrotor, PX4, its armed flag and PX4 custom mode);
- ``LOCAL_POSITION_NED`` (and ``ATTITUDE`` when the world gives one) when the world publishes the UAV's navigation;
- a ``COMMAND_ACK`` to every ``COMMAND_LONG``: arm and disarm (``MAV_CMD_COMPONENT_ARM_DISARM``) and PX4's mode
  switch (``MAV_CMD_DO_SET_MODE``); offboard mode is refused (``MAV_RESULT_TEMPORARILY_REJECTED``) unless a setpoint
  came within :data:`~swarmtrack.autopilot.px4.OFFBOARD_LOSS_S`, as PX4 refuses it without an offboard signal;
  ``refuse`` makes it answer another result instead (a vehicle whose pre-flight checks fail);
- ``SET_POSITION_TARGET_LOCAL_NED`` acceleration setpoints: :meth:`MavlinkVehicle.command` is the latest one while
  armed in offboard mode and fresher than ``OFFBOARD_LOSS_S``, otherwise the failsafe: hold the position where it
  began (:func:`hold`).

The world polls it from its own loop (:meth:`MavlinkVehicle.poll`): no thread of its own. Times are the caller's:
simulated seconds in lockstep, wall-clock seconds in real time.
"""

from __future__ import annotations

import time

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot import px4
from swarmtrack.autopilot.frames import enu_to_ned, ned_to_enu, yaw_enu_to_ned

#: The failsafe's position hold, ``a = KP·(p_hold − p) − KD·v`` (1/s², 1/s): critically damped at 1 rad/s.
KP, KD = 1.0, 2.0


def hold(nav: np.ndarray, anchor: np.ndarray) -> np.ndarray:
    """The acceleration (2,) that holds a UAV at ``anchor`` (2,), from its navigation ``[x, y, vx, vy]`` (ENU)."""
    return KP * (anchor - nav[:2]) - KD * nav[2:4]


class MavlinkVehicle:
    """UAV ``uav``'s simulated autopilot, sending to ``host:port`` (module docstring)."""

    def __init__(self, uav: int, port: int, host: str = "127.0.0.1", refuse: dict[str, int] | None = None):
        self.uav, self.refuse = uav, dict(refuse or {})
        self.conn = px4.connect(f"udpout:{host}:{port}", source_system=uav + 1,
                                source_component=mavlink.MAV_COMP_ID_AUTOPILOT1)
        self.armed, self.mode = False, px4.POSCTL
        self.setpoint: np.ndarray | None = None  # the latest acceleration setpoint (2,), ENU
        self.setpoint_at = -np.inf  # when it came (the caller's clock)
        self.setpoint_ms = -1  # its time_boot_ms
        self.anchor: np.ndarray | None = None  # where the failsafe holds
        self._beat = -np.inf

    def heartbeat(self) -> None:
        """``HEARTBEAT``, at most once a second of wall-clock time."""
        if time.monotonic() - self._beat < 1.0:
            return
        self._beat = time.monotonic()
        base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mavlink.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
        self.conn.mav.heartbeat_send(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, base,
                                     px4.custom_mode(self.mode),
                                     mavlink.MAV_STATE_ACTIVE if self.armed else mavlink.MAV_STATE_STANDBY)

    def poll(self, now: float) -> None:
        """Take every message that came (non-blocking): commands are answered, setpoints kept (stamped ``now``)."""
        self.heartbeat()
        while (msg := self.conn.recv_match(blocking=False)) is not None:
            kind = msg.get_type()
            if kind == "COMMAND_LONG":
                self._command(msg, now)
            elif kind == "SET_POSITION_TARGET_LOCAL_NED" and msg.type_mask == px4.ACCELERATION:
                self.setpoint = ned_to_enu([msg.afx, msg.afy, msg.afz])[:2]
                self.setpoint_at, self.setpoint_ms = now, msg.time_boot_ms

    def _command(self, msg, now: float) -> None:
        if msg.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            result = self.refuse.get("arm", mavlink.MAV_RESULT_ACCEPTED)
            if result == mavlink.MAV_RESULT_ACCEPTED:
                self.armed = msg.param1 == 1
        elif msg.command == mavlink.MAV_CMD_DO_SET_MODE:
            main = int(msg.param2)
            result = mavlink.MAV_RESULT_ACCEPTED
            if main == px4.OFFBOARD and now - self.setpoint_at > px4.OFFBOARD_LOSS_S:
                result = mavlink.MAV_RESULT_TEMPORARILY_REJECTED  # no offboard signal
            result = self.refuse.get("offboard" if main == px4.OFFBOARD else "mode", result)
            if result == mavlink.MAV_RESULT_ACCEPTED:
                self.mode = main
        else:
            result = mavlink.MAV_RESULT_UNSUPPORTED
        self.conn.mav.command_ack_send(msg.command, result, target_system=msg.get_srcSystem(),
                                       target_component=msg.get_srcComponent())
        self._beat = -np.inf  # the new state is told at once
        self.heartbeat()

    def publish(self, t: float, nav: np.ndarray, attitude: np.ndarray | None = None) -> None:
        """Send the UAV's navigation ``[x, y, vx, vy]`` (ENU, at altitude 0) at time ``t`` (s) as
        ``LOCAL_POSITION_NED``, and its ``attitude`` ``[roll, pitch, yaw]`` (ENU yaw) as ``ATTITUDE`` when given."""
        ms = int(round(t * 1000))
        p, v = enu_to_ned([nav[0], nav[1], 0.0]), enu_to_ned([nav[2], nav[3], 0.0])
        self.conn.mav.local_position_ned_send(ms, *p.tolist(), *v.tolist())
        if attitude is not None:
            self.conn.mav.attitude_send(ms, float(attitude[0]), float(attitude[1]),
                                        float(yaw_enu_to_ned(attitude[2])), 0.0, 0.0, 0.0)

    def offboard(self) -> bool:
        """Whether it flies the offboard program's setpoints: armed, in offboard mode."""
        return self.armed and self.mode == px4.OFFBOARD

    def command(self, nav: np.ndarray, now: float) -> np.ndarray:
        """The acceleration (2,) it flies now: the latest setpoint while offboard and fresh. Setpoints older than
        ``OFFBOARD_LOSS_S`` in offboard mode are the failsafe: it leaves offboard mode for position control (the
        offboard program must switch it back, as with PX4) and holds the position where it began; a vehicle never
        engaged holds where it is."""
        fresh = self.setpoint is not None and now - self.setpoint_at <= px4.OFFBOARD_LOSS_S
        if self.offboard() and fresh:
            self.anchor = None
            return self.setpoint.copy()
        if self.mode == px4.OFFBOARD:  # the offboard signal is lost
            self.mode = px4.POSCTL
            self._beat = -np.inf
        if self.anchor is None:
            self.anchor = np.asarray(nav[:2], dtype=float).copy()
        return hold(nav, self.anchor)

    def close(self) -> None:
        self.conn.close()
