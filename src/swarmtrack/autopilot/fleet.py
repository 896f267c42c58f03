"""The world's simulated autopilots (``swarmtrack world --mavlink``): one :class:`~swarmtrack.autopilot.vehicle.
MavlinkVehicle` per UAV, UAV i's as PX4 SITL instance i: its offboard link from local port ``base_port + 40 + i`` to
``host:base_port + i`` (14580 + i → 14540 + i), its ground-station link from local port ``base_port + 4030 + i``
(18570 + i: :func:`gcs_port_of`) to ``host:gcs_port`` when given, else to the ground station that claims it by
sending first.

The vehicles start armed, in the air, in Position mode, holding where they are (a pilot who took off and is about to
hand over to the swarm), at the world's altitude or :data:`~swarmtrack.autopilot.vehicle.AIRBORNE_ALTITUDE`. The
world publishes each UAV's navigation through its vehicle and flies what the vehicle flies (:meth:`Fleet.commands`):
the UAV's latest setpoint in Offboard mode, else its mode's own control (Hold, Return, Land...) or failsafe. A thread
keeps the vehicles answering (heartbeats, commands, streams) while the world's loop waits elsewhere; ``now`` is the
world's clock (simulated seconds in lockstep, the run's seconds in real time). A port another process holds is
:class:`~swarmtrack.autopilot.endpoint.VehicleError`, with nothing left open.
"""

from __future__ import annotations

import select
import threading
import time
from collections.abc import Callable

import numpy as np

from swarmtrack.autopilot.endpoint import VehicleError, check_free, gcs_local_port, offboard_ports
from swarmtrack.autopilot.vehicle import MavlinkVehicle

__all__ = ["BASE_PORT", "Fleet", "VehicleError", "check_ports", "gcs_port_of"]

#: The first UDP port the vehicles send to (PX4 SITL's offboard port of instance 0).
BASE_PORT = 14540


def gcs_port_of(base_port: int, i: int) -> int:
    """The local port of UAV ``i``'s ground-station link (18570 + i for base 14540): a ground station sends there to
    claim it."""
    return gcs_local_port(base_port, i)


def check_ports(n: int, base_port: int = BASE_PORT, host: str = "127.0.0.1") -> None:
    """Refuse, before anything is started, the ports ``n`` vehicles would bind (each UAV's offboard and ground-station
    local ports) when one is taken: :class:`VehicleError` naming the first (the ports are bound without
    ``SO_REUSEADDR`` and released at once; :class:`Fleet` still refuses one taken in between)."""
    for i in range(n):
        check_free(host, offboard_ports(base_port, i)[0], f"UAV {i + 1}'s autopilot's offboard link")
        check_free(host, gcs_port_of(base_port, i), f"UAV {i + 1}'s autopilot's ground-station link")


class Fleet:
    """``n`` simulated autopilots (module docstring); ``now()`` the world's clock. ``airborne=False`` starts them
    landed and disarmed."""

    def __init__(self, n: int, now: Callable[[], float], base_port: int = BASE_PORT, host: str = "127.0.0.1",
                 gcs_port: int | None = None, airborne: bool = True):
        self.vehicles: list[MavlinkVehicle] = []
        try:
            for i in range(n):
                local, remote = offboard_ports(base_port, i)
                self.vehicles.append(MavlinkVehicle(i, remote, host, local_port=local,
                                                    gcs_local_port=gcs_port_of(base_port, i), gcs_port=gcs_port,
                                                    airborne=airborne))
        except VehicleError:
            for v in self.vehicles:
                v.close()
            raise
        self.gcs_ports = [gcs_port_of(base_port, i) for i in range(n)]
        self.now, self._lock, self._closed = now, threading.RLock(), False
        self._thread = threading.Thread(target=self._answer, name="mavlink-vehicles", daemon=True)
        self._thread.start()

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

    def publish(self, t: float, nav: np.ndarray, uavs, altitude: np.ndarray | None = None) -> None:
        """The navigation ``nav`` (N, 4) of the UAVs ``uavs`` at time ``t``, each through its vehicle; ``altitude``
        (N,) metres up in a 3-D world (None: planar, each vehicle's own altitude)."""
        with self._lock:
            for i in uavs:
                self.vehicles[i].publish(t, nav[i], altitude=None if altitude is None else float(altitude[i]))

    def flying_offboard(self, uavs) -> list[int]:
        """The UAVs of ``uavs`` whose vehicle flies its setpoints (armed, Offboard mode)."""
        with self._lock:
            return [i for i in uavs if self.vehicles[i].offboard()]

    def setpoints(self, t: float, uavs, until: float | None, stop: Callable[[], bool] = lambda: False) -> set[int]:
        """Wait for the setpoints stamped ``t`` of the UAVs ``uavs`` whose vehicle is armed in Offboard mode (a UAV
        handed to its operator sends none: nobody waits for it) until the monotonic time ``until`` (None: until they
        come, or ``stop()``); returns the UAVs whose setpoint came."""
        ms = int(round(t * 1000))
        sockets = [link for v in self.vehicles for link in v.sockets()]
        while True:
            self.poll()
            with self._lock:
                if self._closed:
                    return set()
                waiting = [i for i in uavs if self.vehicles[i].offboard()]
                got = {i for i in uavs if self.vehicles[i].setpoint_ms == ms}
            if all(i in got for i in waiting) or stop() or (until is not None and time.monotonic() >= until):
                return got
            try:
                select.select(sockets, [], [], 0.01)  # until one of them has something
            except (OSError, ValueError):  # closed meanwhile
                return got

    def commands(self, nav: np.ndarray, now: float) -> np.ndarray:
        """What every vehicle flies now (N, 2): its setpoint, or its mode's own control."""
        with self._lock:
            return np.array([v.command(nav[i], now) for i, v in enumerate(self.vehicles)])

    def close(self) -> None:
        with self._lock:
            self._closed = True
            for v in self.vehicles:
                v.close()
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout=1.0)
