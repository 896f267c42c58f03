"""UAVs that hold their position: W20's Pelicans hung from the ceiling so that estimation is decoupled from flight
(W20 Sec. 4.6.1). No beacons, zero acceleration commands; the gimbal still follows each UAV's estimate."""

from __future__ import annotations

import numpy as np

from swarmtrack.estimation.base import TargetView
from swarmtrack.network.messages import Inbox


class StaticController:
    probes = ()

    def __init__(self, n_uavs: int, width: int = 2):
        self._zero = np.zeros((n_uavs, width))
        self._zero.flags.writeable = False

    def broadcast(self, t: float, nav: np.ndarray) -> dict:
        return {}

    def command(self, t: float, nav: np.ndarray, view: TargetView, inbox: Inbox, dt: float) -> np.ndarray:
        return self._zero

    def sample(self) -> dict:
        return {}
