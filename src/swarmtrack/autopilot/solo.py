"""One simulated PX4-like vehicle without a world, for tests and for trying a companion program or a ground station
(MAVSDK, QGroundControl, pymavlink) against it: a :class:`~swarmtrack.autopilot.vehicle.MavlinkVehicle` flying a
planar point mass (a double integrator whose acceleration is limited to PX4's tilt, ``g·tan(MPC_TILTMAX_AIR)``) and
the vehicle's own vertical channel, stepped in real time by a thread at :data:`RATE` Hz.

It starts landed and disarmed (PX4 at boot) at a given place, in Position mode, its clock (``time_boot_ms``) the
seconds since it started. On the ground it does not slide: its horizontal velocity is zero there. Its offboard link
sends to ``host:port`` (MAVSDK listening on ``udpin://0.0.0.0:PORT`` receives it there) from ``local_port``; its
ground-station link, when asked for, from ``gcs_local_port``. :meth:`SoloVehicle.close` stops its thread and closes
its sockets.

```python
with SoloVehicle(port=14540, local_port=14580) as solo:
    ...  # mavsdk: await System().connect("udpin://0.0.0.0:14540")
```
"""

from __future__ import annotations

import math
import threading
import time

import numpy as np

from swarmtrack.autopilot.flight import G
from swarmtrack.autopilot.vehicle import MavlinkVehicle

#: Steps per second of the point mass and the vehicle.
RATE = 50.0


class SoloVehicle:
    """A vehicle at ``position`` (ENU, m), UAV ``uav`` (MAVLink system ``uav + 1``); see the module docstring.
    ``gcs_local_port`` None: no ground-station link; ``params``: parameter values by PX4 name."""

    def __init__(self, port: int, local_port: int, *, position=(0.0, 0.0), uav: int = 0, host: str = "127.0.0.1",
                 gcs_local_port: int | None = None, gcs_port: int | None = None,
                 params: dict[str, float] | None = None, rate: float = RATE):
        self.vehicle = MavlinkVehicle(uav, port, host, local_port=local_port, gcs=gcs_local_port is not None,
                                      gcs_local_port=gcs_local_port, gcs_port=gcs_port, params=params)
        self.nav = np.array([float(position[0]), float(position[1]), 0.0, 0.0])  # [x, y, vx, vy] ENU
        self.period = 1.0 / rate
        self.lock = threading.Lock()
        self.t0 = time.monotonic()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"solo-vehicle-{uav + 1}", daemon=True)
        self._thread.start()

    def now(self) -> float:
        """Seconds since it started (its clock)."""
        return time.monotonic() - self.t0

    @property
    def altitude(self) -> float:
        """Metres above its ground."""
        return -self.vehicle.vertical.z

    def _limit(self, a: np.ndarray) -> np.ndarray:
        limit = G * math.tan(math.radians(float(self.vehicle.params.get("MPC_TILTMAX_AIR"))))
        n = float(np.linalg.norm(a))
        return a * (limit / n) if n > limit else a

    def step(self, now: float, dt: float) -> None:
        """One step of ``dt`` s ending at ``now``: take messages, fly, publish."""
        with self.lock:
            v = self.vehicle
            v.poll(now)
            a = v.command(self.nav, now)
            a = self._limit(np.where(np.isfinite(a), a, 0.0))
            if v.vertical.on_ground:
                self.nav[2:] = 0.0
            else:
                self.nav[:2] += dt * self.nav[2:] + 0.5 * dt * dt * a
                self.nav[2:] += dt * a
            v.publish(now, self.nav)

    def _run(self) -> None:
        last = self.now()
        while not self._stop.wait(max(0.0, last + self.period - self.now())):
            now = self.now()
            self.step(now, now - last)
            last = now

    def close(self) -> None:
        self._stop.set()
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout=5.0)
        self.vehicle.close()

    def __enter__(self) -> SoloVehicle:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
