"""Communication topologies as dense (N, N) boolean adjacency matrices; ``A[i, j]`` means i receives from j.

L24 Fig. 1 is the line 1-2-3; L23 compares ``none`` (no fusion) with ``full`` (full fusion). The links
themselves are built by :mod:`swarmtrack.network.links` (dense or sparse); :func:`adjacency` is its dense
form, for small swarms and tests.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from swarmtrack.network.links import TOPOLOGIES, proximity_links, static_links

__all__ = ["TOPOLOGIES", "adjacency"]


def adjacency(
    kind: str,
    n: int,
    *,
    positions: np.ndarray | None = None,
    r_comm: float | None = None,
    edges: Sequence[Sequence[int]] = (),
) -> np.ndarray:
    """Symmetric dense adjacency without self-loops.

    ``proximity`` links UAVs closer than ``r_comm`` (needs ``positions`` (n, 2)); ``edges`` takes 0-based
    undirected pairs. See :func:`~swarmtrack.network.links.proximity_links` and
    :func:`~swarmtrack.network.links.static_links`, which this calls with ``sparse=False``.
    """
    if kind == "proximity":
        if positions is None or r_comm is None:
            raise ValueError("proximity topology needs positions and r_comm")
        return proximity_links(positions, r_comm, sparse=False)
    return static_links(kind, n, edges, sparse=False)
