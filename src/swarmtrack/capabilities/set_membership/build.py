"""IB21's onboard builders: the set-membership estimator and MPC, sharing one set backend (the footprint sensor and
the truth-side monitor of the guarantee are built in :mod:`.world`)."""

from __future__ import annotations

import numpy as np
import shapely

from swarmtrack.capabilities.set_membership.settings import FootprintSpec, SetMembershipSpec, SMMPCSpec
from swarmtrack.control.sm_mpc import SetMembershipMPC, SMMPCSettings
from swarmtrack.estimation.set_backends import PolygonSets, RasterSets, SetBackend
from swarmtrack.estimation.setmembership import SetMembershipEstimator
from swarmtrack.models import fixed_wing as fw
from swarmtrack.models.fixed_wing import FixedWingParams
from swarmtrack.onboard.context import Context
from swarmtrack.sensors import footprint
from swarmtrack.sensors.detections import Detections


def footprint_params(s: FootprintSpec) -> footprint.FootprintParams:
    """The footprint sensor's parameters (IB21 Sec. 3.2, Sec. 6)."""
    return footprint.FootprintParams(s.opening, s.convention, s.orientation, tuple(s.noise_bound),
                                     confusion=s.confusion)


def quiet_frame(s: FootprintSpec, nav: np.ndarray) -> Detections:
    """A frame without detections (:attr:`~swarmtrack.registry.Kind.quiet`): the footprints of the fixed wings whose
    navigation is ``nav`` (``[x, y, vx, vy]`` and their state), as the sensor stamps them (IB21 Sec. 3.2)."""
    p, state = footprint_params(s), nav[:, 4:]
    corners = footprint.footprint_corners(state[:, fw.X:fw.Y + 1], state[:, fw.PSI], state[:, fw.Z], p.tan_half,
                                          p.orientation)
    return Detections(np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, np.int64), len(nav),
                      footprint=corners)


def set_backend(spec: SetMembershipSpec) -> SetBackend:
    """How the run holds its sets (``estimator.sets``): polygons, or raster fields of side ``estimator.cell``."""
    area = shapely.box(*spec.area)
    return RasterSets.over(area, spec.cell) if spec.sets == "raster" else PolygonSets(area)


def setmembership(spec: SetMembershipSpec, ctx: Context) -> SetMembershipEstimator:
    """IB21's estimator on the run's set backend; with network delays and ``delayed_data: refilter``, the one that
    replays (Sec. 4.5). Builds for any subset ``ctx.uavs``: on raster sets every operation is exact, so a fusion's
    result does not depend on its operands' order; on polygons each UAV fuses its own group in a canonical order (by
    UAV) with sets told apart by value (:func:`swarmtrack.estimation.setmembership.fuse`), so its rows are the whole
    swarm's bit for bit either way."""
    sets = ctx.shared("sets", lambda: set_backend(spec))
    return sets.estimator(len(ctx.uavs), ctx.scenario.targets.size(), window=spec.replayed_periods(ctx.scenario),
                          speed=spec.speed_bound(ctx.scenario), bound=tuple(spec.noise_bound), period=spec.period,
                          uavs=None if ctx.rows.whole else ctx.uavs)


def sm_mpc(spec: SMMPCSpec, ctx: Context) -> SetMembershipMPC:
    sc = ctx.scenario
    f, sensor = sc.swarm.fixed_wing, sc.sensor
    settings = SMMPCSettings(tuple(spec.inputs), spec.horizon, spec.period, ctx.dt_estimation, spec.alpha,
                             spec.distance, sc.estimator.speed_bound(sc), sc.network.r_comm,
                             FixedWingParams(f.speed, f.altitude, f.yaw_rate_max),
                             footprint.tan_half(sensor.opening, sensor.convention), sensor.orientation, spec.baseline)
    sets = ctx.shared("sets", lambda: set_backend(sc.estimator))  # the estimator's: its X^A are what it plans on
    return SetMembershipMPC(sets, settings, n_uavs=ctx.n_uavs, uavs=None if ctx.rows.whole else ctx.uavs)
