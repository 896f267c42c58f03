"""The static controller: UAVs hold their initial positions (W20 Ch. 4's estimation trials)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

from swarmtrack import registry
from swarmtrack.scenarios.schema import ControllerSpec

if TYPE_CHECKING:
    from swarmtrack.control.static import StaticController
    from swarmtrack.onboard.context import Context


class StaticSpec(ControllerSpec):
    """UAVs hold their initial positions (W20 Sec. 4.6.1: hung from the ceiling, estimation decoupled from
    flight)."""

    kind: Literal["static"] = "static"


def build(spec: StaticSpec, ctx: Context) -> StaticController:
    """:class:`~swarmtrack.control.static.StaticController` (imported here: registering the kind imports no control
    law)."""
    from swarmtrack.control.static import StaticController

    return StaticController(len(ctx.uavs), ctx.command_width)


registry.register("controller", StaticSpec, build, batched=True)
