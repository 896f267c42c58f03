"""Where a swarm can start: the hexagonal lattice that places the most UAVs a minimum separation apart in a spawn
box, so that ``swarmtrack validate`` refuses exactly the swarms ``swarmtrack run`` cannot place.

The simulator draws the UAVs at random in the box and redraws those too close to an earlier one
(:func:`swarmtrack.sim.build.spawn_positions`); random sequential placement jams near a covered fraction of 0.55
(Feder 1980's jamming limit for discs), so a dense swarm may not be drawn. Then the UAVs are put on this lattice
(the nodes nearest the box's centre, in a seeded random order of the chosen nodes). Validation refuses a swarm the
lattice cannot hold (:func:`capacity`), which is the one the run could not place: validate and run agree.
"""

from __future__ import annotations

import math

import numpy as np


def lattice(half_width: float, separation: float) -> np.ndarray:
    """(M, 2) the nodes of a hexagonal lattice of spacing ``separation`` (> 0) inside the square
    ``[-half_width, half_width]²``: rows ``separation·√3/2`` apart, every other row shifted by half a spacing; its
    nodes are pairwise at least ``separation`` apart (up to round-off, with a relative margin of 1e-9)."""
    s = separation * (1.0 + 1e-9)
    dy = s * math.sqrt(3.0) / 2.0
    rows = int(math.floor(2.0 * half_width / dy + 1e-12)) + 1
    points = []
    for r in range(rows):
        shift = 0.5 * s * (r % 2)
        if shift > 2.0 * half_width:
            continue
        per_row = int(math.floor((2.0 * half_width - shift) / s + 1e-12)) + 1
        x = -half_width + shift + s * np.arange(per_row)
        points.append(np.column_stack([x, np.full(per_row, -half_width + r * dy)]))
    return np.concatenate(points) if points else np.zeros((0, 2))


def capacity(half_width: float, separation: float) -> int | None:
    """How many UAVs :func:`lattice` holds (None: any number, a separation of 0); computed from the rows, without
    making the lattice (a large box holds millions)."""
    if separation <= 0:
        return None
    s = separation * (1.0 + 1e-9)
    dy = s * math.sqrt(3.0) / 2.0
    rows = int(math.floor(2.0 * half_width / dy + 1e-12)) + 1
    even = int(math.floor(2.0 * half_width / s + 1e-12)) + 1
    odd = int(math.floor((2.0 * half_width - 0.5 * s) / s + 1e-12)) + 1 if 0.5 * s <= 2.0 * half_width else 0
    return (rows + 1) // 2 * even + rows // 2 * odd


def on_lattice(n: int, center, half_width: float, separation: float, rng: np.random.Generator) -> np.ndarray:
    """``n`` (≤ :func:`capacity`) UAVs on the lattice's nodes nearest the box's centre, shifted to ``center``, in a
    random order (``rng``) so that UAV numbers do not follow the rows."""
    nodes = lattice(half_width, separation)
    nearest = np.argsort(np.hypot(nodes[:, 0], nodes[:, 1]), kind="stable")[:n]
    return np.asarray(center, dtype=float) + nodes[rng.permutation(nearest)]
