"""What the simulated vehicle's MAVLink services (its parameters, missions and telemetry streams) read of it: one
snapshot, in MAVLink's conventions (local NED frame, SI units, PX4's main and sub modes)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pymavlink.dialects.v20 import common as mavlink


@dataclass
class VehicleState:
    """A simulated vehicle's state as its autopilot reports it."""

    system: int
    """Its MAVLink system id (UAV i is system i + 1)."""
    boot_ms: int = 0
    """Milliseconds since its boot (``time_boot_ms``) of this snapshot."""
    armed: bool = False
    main_mode: int = 3
    """PX4's main mode (``PX4_CUSTOM_MAIN_MODE_*``: 3 Position, 4 Auto, 6 Offboard)."""
    sub_mode: int = 0
    """PX4's sub mode within Auto (``PX4_CUSTOM_SUB_MODE_AUTO_*``: 2 Takeoff, 3 Loiter (Hold), 5 RTL, 6 Land)."""
    landed: int = mavlink.MAV_LANDED_STATE_ON_GROUND
    """``MAV_LANDED_STATE``."""
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """(3,) local NED position (m)."""
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """(3,) local NED velocity (m/s)."""
    attitude: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """(3,) roll, pitch, yaw (rad; yaw from north, clockwise)."""
    home: np.ndarray | None = None
    """(3,) local NED position of home (set when it first arms, as PX4 does), None before."""
