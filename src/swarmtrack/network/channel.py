"""The message channel: delivers what each UAV broadcasts to the UAVs that hear it.

Onboard code never reads another UAV's memory: it gets an inbox from :class:`Channel`. Delivery of summable
payloads (information contributions) is a matrix product with the link matrix of the step, not a loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.network.topology import adjacency


@dataclass
class Channel:
    """Topology plus independent per-link message loss (probability ``loss_probability`` per message)."""

    topology: str
    n: int
    r_comm: float
    edges: tuple = ()
    loss_probability: float = 0.0
    rng: np.random.Generator | None = None

    def __post_init__(self) -> None:
        self._static = None
        if self.topology != "proximity":
            self._static = adjacency(self.topology, self.n, edges=self.edges)

    def links(self, positions: np.ndarray) -> np.ndarray:
        """Links that carry a message this step: topology (by true positions, for proximity) minus losses."""
        A = self._static if self._static is not None else adjacency(
            "proximity", self.n, positions=positions, r_comm=self.r_comm)
        if self.loss_probability > 0.0:
            A = A & (self.rng.random(A.shape) >= self.loss_probability)
        return A

    def beacon_links(self, positions: np.ndarray) -> np.ndarray:
        """Links that carry a flocking beacon: the proximity graph within r_comm minus losses."""
        A = adjacency("proximity", self.n, positions=positions, r_comm=self.r_comm)
        if self.loss_probability > 0.0:
            A = A & (self.rng.random(A.shape) >= self.loss_probability)
        return A

    @staticmethod
    def sum_received(links: np.ndarray, payload: np.ndarray) -> np.ndarray:
        """Inbox sum ``Σ_{j ∈ N_i} payload_j`` for every i (L24 eq. 7): ``links (N, N) @ payload (N, ...)``."""
        flat = payload.reshape(payload.shape[0], -1)
        return (links.astype(payload.dtype) @ flat).reshape(payload.shape)
