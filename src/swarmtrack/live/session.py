"""One live run's truth side, in lockstep or at wall-clock rate."""

from __future__ import annotations

from collections.abc import Callable

import pandas as pd

from swarmtrack.live.agent import PATIENCE
from swarmtrack.live.node import Node
from swarmtrack.live.realtime import RealtimeWorld
from swarmtrack.live.report import LiveReport
from swarmtrack.live.world import LockstepWorld
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.recorder import Recording


def run_live(scenario: Scenario, node: Node, record_to=None, progress: Callable[[float], None] | None = None,
             patience: float = PATIENCE, realtime: bool = False,
             mavlink: tuple | None = None, running: Callable[[int], bool] | None = None,
             taps=(), all_to_all: bool = False) -> tuple[Recording, LiveReport, dict[str, pd.DataFrame]]:
    """Run ``scenario`` with its UAVs' stacks in their own processes (already started, reachable through ``node``),
    in lockstep (:class:`~swarmtrack.live.world.LockstepWorld`) or ``realtime``
    (:class:`~swarmtrack.live.realtime.RealtimeWorld`), each UAV flying through a simulated autopilot with
    ``mavlink`` (its vehicles' base port, host and ground-station port or None,
    :class:`~swarmtrack.autopilot.fleet.Fleet`); ``running``: whether the process of a pid is one the caller
    started and it still runs (lockstep waits for such a UAV however long it is silent); returns the
    recording (streamed to ``record_to`` when given), the live report and the tables the run folder keeps beside the
    recording; ``taps``: live outputs sent each recorded step (:mod:`swarmtrack.streams`). ``all_to_all``: each UAV
    puts its messages on its own key, which every UAV hears (the delivery before issue 41, for comparison), instead
    of addressing them to the UAVs that hear it."""
    world = (RealtimeWorld if realtime else LockstepWorld)(scenario, node, record_to, patience, progress, mavlink,
                                                                running, taps, all_to_all)
    try:
        recording, report = world.run()
    finally:
        if world.fleet is not None:
            world.fleet.close()
    return recording, report, world.tables()
