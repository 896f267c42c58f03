"""PX4's MAVLink conventions, shared by the UAV's link and the simulated vehicle.

PX4 packs its flight mode into ``HEARTBEAT.custom_mode`` as ``main << 16 | sub << 24`` (``px4_custom_mode.h``) and
switches it on ``MAV_CMD_DO_SET_MODE`` with ``param1 = MAV_MODE_FLAG_CUSTOM_MODE_ENABLED`` and ``param2`` the main
mode. Offboard mode is main mode 6; it is entered only while setpoints stream, and left (failsafe) when they stop
for ``COM_OF_LOSS_T`` s.
"""

from __future__ import annotations

import os

from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink

#: PX4 main modes (``PX4_CUSTOM_MAIN_MODE_*``).
POSCTL, OFFBOARD = 3, 6
#: Seconds without a setpoint after which an offboard vehicle holds its position (PX4's ``COM_OF_LOSS_T``).
OFFBOARD_LOSS_S = 0.5

#: ``SET_POSITION_TARGET_LOCAL_NED`` type mask of an acceleration setpoint: position, velocity, yaw and yaw rate
#: ignored (``afx, afy, afz`` used, as accelerations).
ACCELERATION = (mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE
                | mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE
                | mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE
                | mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE)


def connect(device: str, **kwargs):
    """A pymavlink connection to ``device`` speaking MAVLink 2 with the common dialect, as PX4 does (pymavlink's
    default is MAVLink 1 with every dialect)."""
    os.environ["MAVLINK20"] = "1"
    return mavutil.mavlink_connection(device, dialect="common", **kwargs)


def custom_mode(main: int, sub: int = 0) -> int:
    """``HEARTBEAT.custom_mode`` of PX4's main mode ``main`` (and sub mode)."""
    return (main << 16) | (sub << 24)


def main_mode(custom: int) -> int:
    """PX4's main mode in a ``custom_mode``."""
    return (int(custom) >> 16) & 0xFF


def result_name(result: int) -> str:
    """``MAV_RESULT``'s name of a command acknowledgement's result."""
    entry = mavlink.enums["MAV_RESULT"].get(int(result))
    return entry.name if entry is not None else f"MAV_RESULT {result}"
