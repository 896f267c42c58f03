"""Every implementation of the package's :class:`~typing.Protocol` s, assigned to its protocol: read by the type check
(``[tool.mypy]`` in pyproject.toml, run by ``tests/test_types.py``), never run.

The stack (:mod:`swarmtrack.onboard.stack`) and the registry's builders rely on these protocols by duck typing at
run time; here mypy checks that each class (or module) has every member with a compatible signature, so a change to
a protocol or to one of its implementations that breaks the other fails the check. A new implementation is added to
its function below. The imports run only under the type checker: importing this module imports nothing else.

Covered: :class:`~swarmtrack.onboard.exchange.Exchange` (the simulator's channel, the live agent's messages, the
warm-up's echo); :class:`~swarmtrack.estimation.base.Estimator` (every estimator the registered builders return, and
the oracles a controller may follow instead) and :class:`~swarmtrack.estimation.base.PublishingEstimator`;
:class:`~swarmtrack.control.base.Controller` (every registered controller) and
:class:`~swarmtrack.control.base.SequentialPlanner`; :class:`~swarmtrack.vehicles.base.KinematicModel` (the built-in
kinematic vehicles' modules) and :class:`~swarmtrack.vehicles.base.DrivenKinematicModel`;
:class:`~swarmtrack.live.transport.Transport` (Zenoh).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from swarmtrack.control.base import Controller, SequentialPlanner
    from swarmtrack.control.flocking import FlockingController
    from swarmtrack.control.mpc import MPCController
    from swarmtrack.control.sm_mpc import SetMembershipMPC
    from swarmtrack.control.static import StaticController
    from swarmtrack.estimation.base import Estimator, PublishingEstimator
    from swarmtrack.estimation.imm import IMMInformationEstimator
    from swarmtrack.estimation.information import InformationEstimator
    from swarmtrack.estimation.multimodel import MultiModelEstimator
    from swarmtrack.estimation.refilter import RefilteringEstimator
    from swarmtrack.estimation.setmembership import ReplayingSetMembershipEstimator, SetMembershipEstimator
    from swarmtrack.estimation.setmembership_raster import (
        RasterReplayingSetMembershipEstimator,
        RasterSetMembershipEstimator,
    )
    from swarmtrack.live.exchange import LiveExchange
    from swarmtrack.live.transport import Transport, ZenohTransport
    from swarmtrack.network.exchange import ChannelExchange
    from swarmtrack.onboard.exchange import Exchange
    from swarmtrack.onboard.warm import Echo
    from swarmtrack.sim.batch import WorldsOracle
    from swarmtrack.sim.oracle import TruthOracle
    from swarmtrack.vehicles.base import DrivenKinematicModel, KinematicModel


def exchanges(a: ChannelExchange, b: LiveExchange, c: Echo) -> list[Exchange]:
    return [a, b, c]


def estimators(a: InformationEstimator, b: RefilteringEstimator, c: IMMInformationEstimator, d: MultiModelEstimator,
               e: SetMembershipEstimator, f: ReplayingSetMembershipEstimator, g: RasterSetMembershipEstimator,
               h: RasterReplayingSetMembershipEstimator) -> list[Estimator]:
    """What the registered estimator builders return (``swarmtrack.capabilities.*.build``)."""
    return [a, b, c, d, e, f, g, h]


def guides(a: TruthOracle, b: WorldsOracle) -> list[Estimator]:
    """What a controller may follow instead of the estimator (``controller.follow: truth``; a batch of worlds')."""
    return [a, b]


def publishing(a: MultiModelEstimator) -> list[PublishingEstimator]:
    return [a]


def controllers(a: FlockingController, b: MPCController, c: SetMembershipMPC, d: StaticController) -> list[Controller]:
    return [a, b, c, d]


def planners(a: SetMembershipMPC) -> list[SequentialPlanner]:
    return [a]


def kinematic_models() -> list[KinematicModel]:
    """The built-in kinematic vehicles: modules (mypy checks a module's names against a protocol's members)."""
    from swarmtrack.vehicles import fixed_wing, ground_walker

    return [fixed_wing, ground_walker]


def driven_kinematic_models() -> list[DrivenKinematicModel]:
    """The built-in kinematic vehicles a driven group may use (``group=True``; the fixed wing is the swarm's only)."""
    from swarmtrack.vehicles import ground_walker

    return [ground_walker]


def transports(a: ZenohTransport) -> list[Transport]:
    return [a]
