"""Communication topologies as (N, N) boolean adjacency matrices; ``A[i, j]`` means i receives from j.

L24 Fig. 1 is the line 1-2-3; L23 compares ``none`` (no fusion) with ``full`` (full fusion).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

TOPOLOGIES = ("none", "line", "ring", "full", "proximity", "edges")


def adjacency(
    kind: str,
    n: int,
    *,
    positions: np.ndarray | None = None,
    r_comm: float | None = None,
    edges: Sequence[Sequence[int]] = (),
) -> np.ndarray:
    """Symmetric adjacency without self-loops.

    ``proximity`` links UAVs closer than ``r_comm`` (needs ``positions`` (n, 2)); ``edges`` takes 0-based
    undirected pairs.
    """
    A = np.zeros((n, n), dtype=bool)
    if kind == "none":
        return A
    if kind == "full":
        A[:] = True
    elif kind == "line":
        idx = np.arange(n - 1)
        A[idx, idx + 1] = A[idx + 1, idx] = True
    elif kind == "ring":
        idx = np.arange(n)
        A[idx, (idx + 1) % n] = A[(idx + 1) % n, idx] = True
    elif kind == "proximity":
        if positions is None or r_comm is None:
            raise ValueError("proximity topology needs positions and r_comm")
        diff = positions[:, None, :] - positions[None, :, :]
        A = np.einsum("ijk,ijk->ij", diff, diff) < r_comm * r_comm
    elif kind == "edges":
        for e in edges:
            i, j = int(e[0]), int(e[1])
            if not (0 <= i < n and 0 <= j < n) or i == j:
                raise ValueError(f"edge {list(e)} names a missing UAV or a self-loop (UAVs are 0..{n - 1})")
            A[i, j] = A[j, i] = True
    else:
        raise ValueError(f"unknown topology {kind!r}; choose one of {', '.join(TOPOLOGIES)}")
    np.fill_diagonal(A, False)
    return A
