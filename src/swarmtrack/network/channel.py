"""The message channel: delivers what each UAV broadcasts to the UAVs that hear it.

Onboard code never reads another UAV's memory: it gets an inbox from :class:`Channel`. Delivery of summable
payloads (information contributions) is a product with the links of the step (dense or sparse, see
:mod:`swarmtrack.network.links`), not a loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.network.links import Links, drop, proximity_links, static_links


@dataclass
class Channel:
    """Topology plus independent per-link message loss (probability ``loss_probability`` per message).

    Links are dense for small swarms and CSR from :data:`~swarmtrack.network.links.SPARSE_MIN_UAVS` UAVs on
    (``sparse=None``); ``sparse=True``/``False`` forces the form (``full`` is always dense).
    """

    topology: str
    n: int
    r_comm: float
    edges: tuple = ()
    loss_probability: float = 0.0
    rng: np.random.Generator | None = None
    sparse: bool | None = None

    def __post_init__(self) -> None:
        self._static = None
        if self.topology != "proximity":
            self._static = static_links(self.topology, self.n, self.edges, sparse=self.sparse)
        self._near_at: np.ndarray | None = None  # positions of the cached proximity graph
        self._near: Links | None = None

    def links(self, positions: np.ndarray) -> Links:
        """Links that carry an estimation message this step: topology (by true positions, for proximity)
        minus losses."""
        A = self._static if self._static is not None else self._proximity(positions)
        return drop(A, self.loss_probability, self.rng)

    def beacon_links(self, positions: np.ndarray) -> Links:
        """Links that carry a flocking beacon this step: the proximity graph within ``r_comm`` (what the
        flocking weights ``a_ij`` need, L24 Sec. 2, whatever the estimation topology) minus losses.

        The losses are a separate draw from the channel's rng; the proximity graph itself is shared with
        :meth:`links` at the same positions (computed once).
        """
        return drop(self._proximity(positions), self.loss_probability, self.rng)

    def _proximity(self, positions: np.ndarray) -> Links:
        """Proximity graph at ``positions``, recomputed only when they changed."""
        if self._near_at is None or not np.array_equal(positions, self._near_at):
            self._near = proximity_links(positions, self.r_comm, sparse=self.sparse)
            self._near_at = np.array(positions, dtype=float, copy=True)
        return self._near
