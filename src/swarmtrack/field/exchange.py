"""The field's :class:`~swarmtrack.onboard.exchange.Exchange`: a UAV's messages straight to its peers over Zenoh,
with no world to play the radio.

The live agent's exchange (:class:`~swarmtrack.live.exchange.LiveExchange`) in real time, told by nobody whose
messages may come: at each step a UAV waits, until its deadlines (:data:`~swarmtrack.live.exchange.FUSE_BY` ...
of the period after the step's time on its own clock), for its **neighbours in the scenario's topology** (the
algorithm's design: L24's line, W20's full graph) that it has heard within
:data:`~swarmtrack.live.node.LOST_AFTER` s (a heartbeat, or any message: the others are absent, and nobody waits
for them); with ``topology: proximity`` every peer is a neighbour, and the real radio's range decides. Beacons
(the flocking's) come from every UAV heard, as the simulator's travel the proximity graph. What comes
after the deadline is fused at its time stamp within the scenario's delay bound, or dropped and counted, as in a
live run at wall-clock rate.
"""

from __future__ import annotations

import hashlib
import math
import time

import numpy as np

from swarmtrack.live import wire
from swarmtrack.live.exchange import LiveExchange
from swarmtrack.live.node import LOST_AFTER, Node
from swarmtrack.network.links import static_links


def neighbours(scenario, i: int) -> list[int]:
    """The UAVs whose messages UAV ``i`` (0-based) fuses: its neighbours in the scenario's topology, every other
    UAV with a topology that depends on where they are (``proximity``: the real radio's range decides)."""
    net, n = scenario.network, scenario.swarm.n_uavs
    if net.topology == "proximity":
        return [j for j in range(n) if j != i]
    links = np.asarray(static_links(net.topology, n, [(a - 1, b - 1) for a, b in net.edges], sparse=False))
    return [int(j) for j in np.flatnonzero(links[i]) if j != i]


def field_run(scenario_hash: str, epoch: float) -> bytes:
    """The identity of a field run (what every message carries, :attr:`~swarmtrack.live.wire.Seal.run`): the same
    resolved scenario started at the same epoch; there is no world to draw it."""
    return hashlib.sha256(f"{scenario_hash}@{epoch!r}".encode()).digest()[:16]


class FieldExchange(LiveExchange):
    """UAV ``i``'s rounds with its ``peers`` (0-based) of a swarm of ``n``, on the clock that starts at ``epoch``
    (wall-clock s); ``late_steps``: the estimation steps a late share can take (the scenario's delay bound)."""

    def __init__(self, node: Node, i: int, n: int, late_steps: int, peers: list[int], epoch: float):
        super().__init__(node, i, n, late_steps)
        self.peers, self.epoch = peers, epoch

    def heard(self) -> list[int]:
        """The UAVs heard within :data:`~swarmtrack.live.node.LOST_AFTER` s (the others are absent: not waited
        for, not counted late)."""
        now = time.monotonic()
        alive = [s for s in range(self.n) if s != self.i and now - self.node.seen.get(s, -math.inf) <= LOST_AFTER]
        self.node.absent = set(range(self.n)) - set(alive) - {self.i}
        return alive

    def step(self, k: int, c: int, t: float, period: float, controller) -> FieldExchange:
        """The rounds of step ``(k, c)`` at run time ``t`` (due at ``epoch + t``): the estimation messages of its
        neighbours heard now, the beacons of every UAV heard now (the flocking weighs them by distance, L24 Sec. 2,
        whatever the estimation topology: the simulator's beacons travel the proximity graph)."""
        alive = self.heard()
        fused = [s for s in alive if s in self.peers]
        self.at(k, c, wire.Radio(parts=[(k, fused)], links=fused, beacons=alive), self.epoch + t, period, controller)
        return self
