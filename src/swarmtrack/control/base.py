"""The controller role: what every onboard controller offers the simulator.

Per control step the engine runs broadcast → deliver → command: :meth:`Controller.broadcast` returns each UAV's
beacon (an outbox), the channel delivers the beacons over the links in range (with the channel's message loss),
and :meth:`Controller.command` turns UAV i's own navigation solution, its estimator's view and its inbox into
UAV i's acceleration command. Implementations: :mod:`swarmtrack.control.flocking`; registered for scenarios in
:mod:`swarmtrack.sim.build`.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from swarmtrack.estimation.base import Probe, TargetView
from swarmtrack.network.messages import Inbox, Outbox


class Controller(Protocol):
    probes: tuple[Probe, ...]

    def broadcast(self, t: float, nav: np.ndarray) -> Outbox:
        """Each UAV's beacon this control step."""

    def command(self, t: float, nav: np.ndarray, view: TargetView, inbox: Inbox, dt: float) -> np.ndarray:
        """Acceleration commands (N, 2)."""

    def sample(self) -> dict[str, np.ndarray]:
        """The current value of every probe, (N, *shape) each."""
