"""PX4's MAVLink conventions, shared by the UAV's link and the simulated vehicle (reference: PX4-Autopilot v1.14/v1.15,
``src/modules/commander/px4_custom_mode.h``, ``src/modules/mavlink/mavlink_receiver.cpp``).

PX4 packs its flight mode into ``HEARTBEAT.custom_mode`` as ``main << 16 | sub << 24`` (``px4_custom_mode.h``) and
switches it on ``MAV_CMD_DO_SET_MODE`` with ``param1 = MAV_MODE_FLAG_CUSTOM_MODE_ENABLED``, ``param2`` the main mode
and ``param3`` the sub mode (within Auto). Offboard mode is main mode 6; it is entered only while setpoints stream, and
left (failsafe) when they stop for ``COM_OF_LOSS_T`` s.
"""

from __future__ import annotations

import os

from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink

#: PX4 main modes (``PX4_CUSTOM_MAIN_MODE_*``).
MANUAL, ALTCTL, POSCTL, AUTO, ACRO, OFFBOARD, STABILIZED = 1, 2, 3, 4, 5, 6, 7
#: PX4 sub modes within Auto (``PX4_CUSTOM_SUB_MODE_AUTO_*``).
AUTO_READY, AUTO_TAKEOFF, AUTO_LOITER, AUTO_MISSION, AUTO_RTL, AUTO_LAND = 1, 2, 3, 4, 5, 6
#: Seconds without a setpoint after which an offboard vehicle leaves offboard mode (PX4's ``COM_OF_LOSS_T``, default
#: 1 s in ``commander_params.c``; the simulated vehicle reads its parameter table).
OFFBOARD_LOSS_S = 1.0
#: ``MAV_CMD_COMPONENT_ARM_DISARM``'s ``param2`` that forces a disarm in flight (PX4's Commander.cpp: 21196).
FORCE_MAGIC = 21196

_T = mavlink
_POSITION_IGNORE = _T.POSITION_TARGET_TYPEMASK_X_IGNORE | _T.POSITION_TARGET_TYPEMASK_Y_IGNORE \
    | _T.POSITION_TARGET_TYPEMASK_Z_IGNORE
_VELOCITY_IGNORE = _T.POSITION_TARGET_TYPEMASK_VX_IGNORE | _T.POSITION_TARGET_TYPEMASK_VY_IGNORE \
    | _T.POSITION_TARGET_TYPEMASK_VZ_IGNORE
_ACCELERATION_IGNORE = _T.POSITION_TARGET_TYPEMASK_AX_IGNORE | _T.POSITION_TARGET_TYPEMASK_AY_IGNORE \
    | _T.POSITION_TARGET_TYPEMASK_AZ_IGNORE
_YAW_IGNORE = _T.POSITION_TARGET_TYPEMASK_YAW_IGNORE | _T.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE

#: ``SET_POSITION_TARGET_LOCAL_NED`` type mask of an acceleration setpoint: position, velocity, yaw and yaw rate
#: ignored (``afx, afy, afz`` used, as accelerations): 3135.
ACCELERATION = _POSITION_IGNORE | _VELOCITY_IGNORE | _YAW_IGNORE
#: Type mask of a velocity setpoint (``vx, vy, vz``; position, acceleration, yaw and yaw rate ignored): 3527.
VELOCITY = _POSITION_IGNORE | _ACCELERATION_IGNORE | _YAW_IGNORE
#: Type mask of a position setpoint (``x, y, z``; velocity, acceleration, yaw and yaw rate ignored): 3576.
POSITION = _VELOCITY_IGNORE | _ACCELERATION_IGNORE | _YAW_IGNORE

#: QGroundControl's names of PX4's modes, by (main, sub); a main mode alone by (main, 0).
MODE_NAMES = {
    (MANUAL, 0): "Manual", (ALTCTL, 0): "Altitude", (POSCTL, 0): "Position", (ACRO, 0): "Acro",
    (OFFBOARD, 0): "Offboard", (STABILIZED, 0): "Stabilized", (AUTO, AUTO_READY): "Ready",
    (AUTO, AUTO_TAKEOFF): "Takeoff", (AUTO, AUTO_LOITER): "Hold", (AUTO, AUTO_MISSION): "Mission",
    (AUTO, AUTO_RTL): "Return", (AUTO, AUTO_LAND): "Land", (AUTO, 7): "Return to Groundstation",
    (AUTO, 8): "Follow Me", (AUTO, 9): "Precision Land",
}


def connect(device: str, **kwargs):
    """A pymavlink connection to ``device`` speaking MAVLink 2 with the common dialect, as PX4 does (pymavlink's
    default is MAVLink 1 with every dialect)."""
    os.environ["MAVLINK20"] = "1"
    return mavutil.mavlink_connection(device, dialect="common", **kwargs)


def custom_mode(main: int, sub: int = 0) -> int:
    """``HEARTBEAT.custom_mode`` of PX4's main mode ``main`` (and sub mode)."""
    return (int(main) << 16) | (int(sub) << 24)


def main_mode(custom: int) -> int:
    """PX4's main mode in a ``custom_mode``."""
    return (int(custom) >> 16) & 0xFF


def sub_mode(custom: int) -> int:
    """PX4's sub mode in a ``custom_mode`` (0 outside Auto)."""
    return (int(custom) >> 24) & 0xFF


def mode_name(main: int, sub: int = 0) -> str:
    """The name QGroundControl shows for PX4's mode (``"Hold"`` for Auto/Loiter); ``"main.sub"`` for one it does
    not know."""
    name = MODE_NAMES.get((int(main), int(sub) if int(main) == AUTO else 0))
    return name if name is not None else f"mode {int(main)}.{int(sub)}"


def result_name(result: int) -> str:
    """``MAV_RESULT``'s name of a command acknowledgement's result."""
    entry = mavlink.enums["MAV_RESULT"].get(int(result))
    return entry.name if entry is not None else f"MAV_RESULT {result}"
