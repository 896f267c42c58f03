"""The controller role: what every onboard controller offers the simulator.

Per control step the engine runs broadcast → deliver → command: :meth:`Controller.broadcast` returns each UAV's
beacon (an outbox), the channel delivers the beacons over the links in range (with the channel's message loss),
and :meth:`Controller.command` turns UAV i's own navigation solution, its estimator's view and its inbox into
UAV i's acceleration command. Implementations: :mod:`swarmtrack.control.flocking`; registered for scenarios in
:mod:`swarmtrack.sim.build`.

A controller built for R of the swarm's N UAVs (``Context.uavs``: one UAV's own process) has R rows: its
navigation, view, commands and beacons are theirs, its inbox holds their rows of the links (``Inbox.receivers``)
and every sender's beacon; its rows are bit for bit the whole swarm's.

A controller whose UAVs plan in sequence within one command (IB21's SM-MPC: UAV i uses the plans its lower-indexed
neighbours made in the same call) is a :class:`SequentialPlanner`: the whole swarm's component plans them in index
order itself; a subset's reads the others' plans of the call from its inbox's ``plan`` payload, the messages
:meth:`SequentialPlanner.plans` gives, which the live runtime delivers before the UAV plans.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from swarmtrack.estimation.base import Probe, TargetView
from swarmtrack.network.messages import Inbox, Outbox


class Controller(Protocol):
    @property
    def probes(self) -> tuple[Probe, ...]:
        """What the recorder samples (read only: an implementation's tuple of any length, or a property)."""

    def broadcast(self, t: float, nav: np.ndarray) -> Outbox:
        """Each UAV's beacon this control step."""

    def command(self, t: float, nav: np.ndarray, view: TargetView, inbox: Inbox, dt: float) -> np.ndarray:
        """Acceleration commands (R, 2), R = N for the whole swarm."""

    def sample(self) -> dict[str, np.ndarray]:
        """The current value of every probe, (R, *shape) each."""


@runtime_checkable
class SequentialPlanner(Controller, Protocol):
    def plans(self) -> Outbox:
        """This component's UAVs' plans of the last command, ``{"plan": (R, h)}``: the message its higher-indexed
        neighbours in other processes read in the same call."""
