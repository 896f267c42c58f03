"""The world's simulated autopilots (``swarmtrack world --mavlink``): one :class:`~swarmtrack.autopilot.vehicle.
MavlinkVehicle` per UAV, UAV i's sending to ``host:base_port + i`` as PX4 SITL instance i sends to 14540 + i.

The world publishes each UAV's navigation through its vehicle and flies what the vehicle flies: the UAV's latest
setpoint, or the failsafe's hold (:meth:`Fleet.commands`). A thread keeps the vehicles answering (heartbeats,
command acknowledgements) while the world's loop waits elsewhere; times are the world's clock (``now``: simulated
seconds in lockstep, wall-clock seconds in real time).
"""

from __future__ import annotations

import select
import threading
import time
from collections.abc import Callable

import numpy as np

from swarmtrack.autopilot.vehicle import MavlinkVehicle

#: The first UDP port the vehicles send to (PX4 SITL's offboard port of instance 0).
BASE_PORT = 14540


class Fleet:
    """``n`` simulated autopilots sending to ``host:base_port + i``; ``now()`` the world's clock."""

    def __init__(self, n: int, now: Callable[[], float], base_port: int = BASE_PORT, host: str = "127.0.0.1"):
        self.vehicles = [MavlinkVehicle(i, base_port + i, host) for i in range(n)]
        self.now, self._lock, self._closed = now, threading.Lock(), False
        threading.Thread(target=self._answer, name="mavlink-vehicles", daemon=True).start()

    def _answer(self) -> None:
        while not self._closed:
            self.poll()
            time.sleep(0.02)

    def poll(self) -> None:
        """Every vehicle takes what came (answers commands, keeps setpoints stamped with the world's time)."""
        with self._lock:
            if self._closed:
                return
            now = self.now()
            for v in self.vehicles:
                v.poll(now)

    def publish(self, t: float, nav: np.ndarray, uavs) -> None:
        """The navigation ``nav`` (N, 4) of the UAVs ``uavs`` at time ``t``, each through its vehicle."""
        with self._lock:
            for i in uavs:
                self.vehicles[i].publish(t, nav[i])

    def setpoints(self, t: float, uavs, until: float | None, stop: Callable[[], bool] = lambda: False) -> set[int]:
        """Wait for the setpoints stamped ``t`` of the UAVs ``uavs`` until the monotonic time ``until`` (None: until
        they come, or ``stop()``); returns the UAVs whose setpoint came."""
        ms, sockets = int(round(t * 1000)), [v.conn.port for v in self.vehicles]
        while True:
            self.poll()
            got = {i for i in uavs if self.vehicles[i].setpoint_ms == ms}
            if len(got) == len(uavs) or stop() or (until is not None and time.monotonic() >= until):
                return got
            select.select(sockets, [], [], 0.01)  # until one of them has something

    def commands(self, nav: np.ndarray, now: float) -> np.ndarray:
        """What every vehicle flies now (N, 2): its setpoint, or its failsafe's hold."""
        with self._lock:
            return np.array([v.command(nav[i], now) for i, v in enumerate(self.vehicles)])

    def close(self) -> None:
        with self._lock:
            self._closed = True
            for v in self.vehicles:
                v.close()
