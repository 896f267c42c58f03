"""The message channel: delivers what each UAV broadcasts to the UAVs that hear it.

Onboard code never reads another UAV's memory: it gets an inbox from :class:`Channel`. Delivery of summable
payloads (information contributions) is a product with the links of the step (dense or sparse, see
:mod:`swarmtrack.network.links`), not a loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.network.delays import delay_steps
from swarmtrack.network.faults import Liar
from swarmtrack.network.links import (
    Links,
    cut,
    drop,
    edge_list,
    proximity_blocks,
    proximity_links,
    static_links,
    subset,
    to_dense,
)
from swarmtrack.network.messages import Inbox, Outbox


@dataclass
class Channel:
    """Topology plus independent per-link message loss (probability ``loss_probability`` per message), and
    outages: ``(uavs, (t0, t1))`` pairs (0-based UAVs) that neither send nor receive during ``[t0, t1)``.

    Links are dense for small swarms and CSR from :data:`~swarmtrack.network.links.SPARSE_MIN_UAVS` UAVs on
    (``sparse=None``); ``sparse=True``/``False`` forces the form (``full`` is always dense).

    Delays (:meth:`deliver`): every estimation message on every link takes ``delay`` s, or a time drawn uniformly
    in ``[delay, delay_max]`` from ``delay_rng`` (its own stream, so the losses are the same draws with or without
    delays); it arrives at the first estimation step (period ``dt``) at or after it was sent plus its delay, so
    random delays reorder messages. Flocking beacons are not delayed.
    """

    topology: str
    n: int
    r_comm: float
    edges: tuple = ()
    loss_probability: float = 0.0
    rng: np.random.Generator | None = None
    sparse: bool | None = None
    outages: tuple = ()
    delay: float = 0.0
    delay_max: float = 0.0
    dt: float = 1.0
    delay_rng: np.random.Generator | None = None
    liar: Liar | None = None

    def __post_init__(self) -> None:
        self._in_flight: dict[int, list[Inbox]] = {}  # arrival step -> parts of earlier messages
        self._static = None
        if self.topology != "proximity":
            self._static = static_links(self.topology, self.n, self.edges, sparse=self.sparse)
        self._near_at: tuple | None = None  # shape and bytes of the positions of the cached proximity graph
        self._near: Links | None = None

    def links(self, positions: np.ndarray, t: float = 0.0) -> Links:
        """Links that carry an estimation message at time ``t``: topology (by true positions, for proximity)
        minus the UAVs cut off, minus losses."""
        A = self._static if self._static is not None else self._proximity(positions)
        return drop(self._cut(A, t), self.loss_probability, self.rng)

    def deliver(self, links: Links, outbox: Outbox, t: float) -> Inbox:
        """This step's inbox: what ``links`` carry of ``outbox`` without delay, plus the earlier messages whose
        delays end now (:attr:`Inbox.late`, oldest first). Without delays, ``Inbox(links, outbox)``. A
        :class:`~swarmtrack.network.faults.Liar`'s broadcast is corrupted as it is sent."""
        if self.liar is not None:
            outbox = self.liar.corrupt(outbox, t)
        if self.delay_max <= 0.0:
            return Inbox(links, outbox)
        k = round(t / self.dt)
        wait = np.full(edge_list(links)[0].size, self.delay)
        if self.delay_max > self.delay:
            assert self.delay_rng is not None, "random delays draw from delay_rng"
            wait += (self.delay_max - self.delay) * self.delay_rng.random(wait.size)
        steps = delay_steps(wait, self.dt)
        for m in np.unique(steps[steps > 0]):
            self._in_flight.setdefault(k + int(m), []).append(Inbox(subset(links, steps == m), outbox))
        return Inbox(subset(links, steps == 0), outbox, tuple(self._in_flight.pop(k, ())))

    def _cut(self, links: Links, t: float) -> Links:
        if not self.outages:
            return links
        off = np.zeros(self.n, dtype=bool)
        for uavs, (t0, t1) in self.outages:
            if t0 <= t < t1:
                off[list(uavs)] = True
        return cut(links, off)

    def beacon_links(self, positions: np.ndarray, t: float = 0.0) -> Links:
        """Links that carry a flocking beacon this step: the proximity graph within ``r_comm`` (what the
        flocking weights ``a_ij`` need, L24 Sec. 2, whatever the estimation topology) minus losses.

        The losses are a separate draw from the channel's rng; the proximity graph itself is shared with
        :meth:`links` at the same positions (computed once).
        """
        return drop(self._cut(self._proximity(positions), t), self.loss_probability, self.rng)

    def _proximity(self, positions: np.ndarray) -> Links:
        """Proximity graph at ``positions``, recomputed only when they changed: the cache is keyed by the positions'
        bytes (equal bytes, equal floats, the same graph; a quarter of the cost of comparing the arrays)."""
        q = np.ascontiguousarray(positions, dtype=float)
        key = (q.shape, q.tobytes())
        if key != self._near_at:
            self._near = proximity_links(q, self.r_comm, sparse=self.sparse)
            self._near_at = key
        return self._near


@dataclass
class WorldsChannel:
    """The channels of a batch of B worlds of ``n`` UAVs each (:mod:`swarmtrack.sim.batch`): world b's UAVs are rows
    ``b·n .. (b+1)·n − 1`` and hear only each other, through world b's own :class:`Channel` (its topology, losses
    and random stream), so each world's links are the ones it would have alone. Links are dense, block-diagonal."""

    channels: tuple[Channel, ...]
    n: int

    def __post_init__(self) -> None:
        worlds = np.repeat(np.arange(len(self.channels)), self.n)
        self._same = worlds[:, None] == worlds[None, :]
        first = self.channels[0]
        self._quiet = all(c.loss_probability <= 0 and not c.outages for c in self.channels)
        self._static = None
        if self._quiet and first._static is not None:
            self._static = self._blocks([to_dense(c._static) for c in self.channels])

    def _blocks(self, blocks: list[np.ndarray]) -> np.ndarray:
        out = np.zeros(self._same.shape, dtype=bool)
        for b, block in enumerate(blocks):
            out[b * self.n:(b + 1) * self.n, b * self.n:(b + 1) * self.n] = block
        return out

    def links(self, positions: np.ndarray, t: float = 0.0) -> np.ndarray:
        """Each world's :meth:`Channel.links` (one static block-diagonal array when nothing is lost or cut)."""
        if self._static is not None:
            return self._static
        return self._blocks([to_dense(c.links(positions[b * self.n:(b + 1) * self.n], t))
                             for b, c in enumerate(self.channels)])

    def deliver(self, links: np.ndarray, outbox: Outbox, t: float) -> Inbox:
        """A batch has no delays (:func:`swarmtrack.sim.batch.unbatchable`): what the links carry, now."""
        return Inbox(links, outbox)

    def beacon_links(self, positions: np.ndarray, t: float = 0.0) -> np.ndarray:
        """Each world's :meth:`Channel.beacon_links`: the proximity graph within each world (all worlds at once when
        nothing is lost or cut: the pairs of each world, tested as :func:`proximity_links` tests them)."""
        if self._quiet:
            near = proximity_blocks(positions.reshape(len(self.channels), self.n, -1), self.channels[0].r_comm)
            out = np.zeros(self._same.shape, dtype=bool)
            out[self._same] = near.reshape(-1)
            return out
        return self._blocks([to_dense(c.beacon_links(positions[b * self.n:(b + 1) * self.n], t))
                             for b, c in enumerate(self.channels)])
