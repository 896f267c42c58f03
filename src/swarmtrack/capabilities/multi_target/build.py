"""Issue 40's onboard builder: from the LMB settings to every UAV's multi-target tracker (the truth-side position
sensor is built in :mod:`.world`)."""

from __future__ import annotations

from scipy.stats import chi2

from swarmtrack.capabilities.multi_target.settings import LMBSpec, TrackAssignmentSpec, positions_sensor
from swarmtrack.capabilities.tracking_swarm.build import flocking_gains
from swarmtrack.control.assignment import SearchPattern, TrackAssignmentController, lawnmower
from swarmtrack.estimation.lmb import cv_model
from swarmtrack.estimation.multitarget import KAPPA_FLOOR, LMBEstimator, LMBSettings
from swarmtrack.onboard.context import Context


def lmb(spec: LMBSpec, ctx: Context) -> LMBEstimator:
    """Each UAV's LMB filter, assuming its sensor's detection probability and clutter (or the settings' own), the
    clutter spread evenly over the sensor's field of view."""
    sensor = positions_sensor(ctx.scenario)
    pd = sensor.detection_probability if spec.detection_probability is None else spec.detection_probability
    rate = sensor.clutter_rate if spec.clutter_rate is None else spec.clutter_rate
    area = sensor.field_of_view()
    kappa = max(rate / area, KAPPA_FLOOR) if area is not None and rate > 0 else KAPPA_FLOOR
    F, Q = cv_model(ctx.dt_estimation, spec.accel_std)
    settings = LMBSettings(F, Q, spec.survival_probability, pd, kappa, float(chi2.ppf(spec.gate_probability, 2)),
                           spec.birth_rate, spec.birth_existence, spec.birth_velocity_std, spec.existence_threshold,
                           spec.prune_threshold, spec.max_tracks, ctx.dt_estimation,
                           spec.region)
    own = ctx.scenario.swarm.nav_position_std if spec.own_position == "include" else 0.0
    if spec.share == "centre":
        ctx.whole_swarm_only("lmb", "share centre is one filter fed every UAV's detections, not a UAV's component")
    return LMBEstimator(settings, ctx.rows, sensor.position_rule(own), sensor.sees, share=spec.share == "measurements",
                        max_shared=spec.max_shared, compiled=ctx.compiled, centre=spec.share == "centre",
                        fuse_tracks=spec.fuse_tracks, max_shared_tracks=spec.max_shared_tracks)


def track_assignment(spec: TrackAssignmentSpec, ctx: Context) -> TrackAssignmentController:
    """Each UAV's assignment to its tracks, its flocking around its own and the searchers' lawnmower."""
    pattern = SearchPattern(lawnmower(spec.region, spec.lane), spec.search_speed, spec.lane / 4)
    return TrackAssignmentController(flocking_gains(spec, ctx.scenario.network.r_comm), spec.variant, len(ctx.uavs),
                                     spec.chase_after_steps * ctx.dt_estimation, spec.searchers, spec.per_track,
                                     pattern)
