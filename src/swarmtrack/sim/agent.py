"""The onboard stack of the swarm: estimator, controller, and what the controller follows.

Row i of every array in an onboard component belongs to UAV i's own computer. Its inputs are only: UAV i's own
navigation solution, UAV i's own detections, and the messages the channel delivered to UAV i. The same components
built for one UAV (``Context.uavs``) give its row alone, bit for bit: what the live runtime runs in each UAV's
process. This module and the components it holds (``swarmtrack.estimation``, ``swarmtrack.control``,
``swarmtrack.models``, ``swarmtrack.sensors.detections``) never import :mod:`swarmtrack.sim.world`; a test checks it
in a fresh interpreter.
"""

from __future__ import annotations

from dataclasses import dataclass

from swarmtrack.control.base import Controller
from swarmtrack.estimation.base import Estimator


@dataclass
class OnboardStack:
    """``estimator`` is run and recorded; ``guide`` is what the controller follows: the estimator itself, or an
    oracle the builder wired to the truth (``controller.follow: truth``, a study aid, never onboard)."""

    estimator: Estimator
    controller: Controller
    guide: Estimator

    @property
    def probes(self) -> dict[str, tuple[int, ...]]:
        return {p.name: p.shape for p in (*self.estimator.probes, *self.controller.probes)}

    def sample(self) -> dict:
        return {**self.estimator.sample(), **self.controller.sample()}
