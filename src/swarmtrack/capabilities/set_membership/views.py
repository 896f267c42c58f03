"""What a live view draws of IB21's estimator (``swarmtrack run --foxglove``, ``--ros2``): each UAV's sets as
outlines, its unidentified set Xᵁ_i and its identified sets X_{i,j} (eq. 34), for
:attr:`~swarmtrack.streams.frame.StepFrame.polygons`."""

from __future__ import annotations

import numpy as np
import shapely


def shapes(estimator) -> list[tuple[int, np.ndarray]]:
    """``[(uav, vertices (K, 2))]``: the exterior of every polygon of each UAV's Xᵁ_i and X_{i,j} (``uav`` its 1-based
    number: the estimator's ``uavs`` when built for some, else its rows in order); raster sets (``estimator.sets:
    raster``) as the outline of their member squares."""
    b = estimator.beliefs
    numbers = (np.arange(len(b.unidentified)) if estimator.uavs is None else estimator.uavs) + 1
    grid = getattr(b, "grid", None)
    if grid is not None:
        from swarmtrack.estimation.raster_field import to_polygon
    out = []
    for row, number in enumerate(numbers.tolist()):
        for geometry in (b.unidentified[row], *b.identified[row]):
            if grid is not None:
                geometry = to_polygon(grid, geometry)
            for part in shapely.get_parts(geometry):
                if isinstance(part, shapely.Polygon) and not part.is_empty:
                    out.append((number, np.asarray(part.exterior.coords)[:, :2]))
    return out
