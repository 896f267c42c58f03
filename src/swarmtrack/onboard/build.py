"""A scenario's onboard components, by their kinds' registered builders (:mod:`swarmtrack.registry`), and the stack
they make: for the whole swarm (the simulator), one UAV (its own process in the live swarm) or without a controller
(replay, whose commands would fly nothing)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from swarmtrack import registry
from swarmtrack.onboard.stack import OnboardStack

if TYPE_CHECKING:
    from swarmtrack.onboard.context import Context
    from swarmtrack.scenarios.schema import Scenario


def component(role: str, scenario: Scenario, ctx):
    """The ``role`` component of ``scenario``, by its registered kind's builder (estimator and controller: with the
    builder :class:`~swarmtrack.onboard.context.Context`; a sensor, built by the world: with the scenario)."""
    spec = getattr(scenario, role)
    return registry.get(role, spec.kind).builder()(spec, ctx)


def onboard_stack(ctx: Context, controller: bool = True) -> OnboardStack:
    """The stack of ``ctx``'s UAVs: its scenario's estimator and, unless ``controller`` is False, its controller,
    which follows the estimator (a simulation that follows the truth swaps in its oracle as the guide)."""
    estimator = component("estimator", ctx.scenario, ctx)
    return OnboardStack(estimator, component("controller", ctx.scenario, ctx) if controller else None, estimator)


def probes_of(scenario: Scenario) -> dict[str, tuple[int, ...]]:
    """What each UAV's sample of ``scenario`` carries (its stack's probes, by name and shape per UAV): read off one
    UAV's stack, as the processes that record the samples of others (the live world, the field's monitor) need."""
    from swarmtrack.onboard.context import context, sensor_labels

    return onboard_stack(context(scenario, sensor_labels(scenario), uavs=[0])).probes
