"""How IB21's sets are held: one backend per run, built once by the builder and handed to both the set-membership
estimator and the set-membership MPC, so the two agree on what a set is.

- :class:`PolygonSets`: shapely polygons (exact up to outward margins of micrometres; :mod:`swarmtrack.estimation.
  polygons`), planned by :func:`swarmtrack.control.sm_mpc.plan_one`.
- :class:`RasterSets`: fields of distance lower bounds on one grid over X0 (outer by up to a cell's half-diagonal;
  :mod:`swarmtrack.estimation.raster`), planned by :func:`swarmtrack.control.sm_mpc_raster.plan_one_raster`.

Either way the estimator's view carries each UAV's aggregated set X^A (IB21 eq. 43) as
:class:`~swarmtrack.estimation.base.Regions`: an (N,) array of the backend's sets (shapely geometries, or
:class:`~swarmtrack.estimation.raster.Field` s with their grid).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import shapely

from swarmtrack.estimation import setmembership_raster as raster_sets
from swarmtrack.estimation.raster import Grid
from swarmtrack.estimation.setmembership import ReplayingSetMembershipEstimator, SetMembershipEstimator


@dataclass(frozen=True)
class PolygonSets:
    """Sets as shapely polygons over the search area X0 (``area``)."""

    area: shapely.Geometry
    name: ClassVar[str] = "polygons"
    grid: ClassVar[None] = None  # no grid: the sets are exact polygons

    def estimator(self, n_uavs: int, n_ids: int, *, window: int = 0, **kwargs) -> SetMembershipEstimator:
        """IB21's estimator on these sets; with a replay ``window`` (periods), the one that fuses late sets at their
        time (Sec. 4.5). ``kwargs``: its speed bound, noise bound and period."""
        if window:
            return ReplayingSetMembershipEstimator(n_uavs, n_ids, self.area, window=window, **kwargs)
        return SetMembershipEstimator(n_uavs, n_ids, self.area, **kwargs)


@dataclass(frozen=True)
class RasterSets:
    """Sets as raster fields on ``grid`` (cells of ``grid.cell`` m over X0, ``area``)."""

    area: shapely.Geometry
    grid: Grid
    name: ClassVar[str] = "raster"

    @classmethod
    def over(cls, area: shapely.Geometry, cell: float) -> RasterSets:
        return cls(area, Grid.over(area, cell))

    def estimator(self, n_uavs: int, n_ids: int, *, window: int = 0, **kwargs) -> SetMembershipEstimator:
        """:meth:`PolygonSets.estimator` on raster sets of this grid."""
        if window:
            return raster_sets.RasterReplayingSetMembershipEstimator(n_uavs, n_ids, self.area, grid=self.grid,
                                                                    window=window, **kwargs)
        return raster_sets.RasterSetMembershipEstimator(n_uavs, n_ids, self.area, grid=self.grid, **kwargs)


SetBackend = PolygonSets | RasterSets

