"""Issue 40's onboard builders: from the multi-target settings to every UAV's tracker (the LMB filter, or a classic
baseline), and the controller that shares the UAVs between the tracks (the truth-side position sensor is built in
:mod:`.world`)."""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from swarmtrack import registry
from swarmtrack.capabilities.multi_target.settings import (
    ClassicSpec,
    LMBSpec,
    MultiTargetSpec,
    TrackAssignmentSpec,
    positions_sensor,
)
from swarmtrack.capabilities.tracking_swarm.build import flocking_gains
from swarmtrack.control.assignment import SearchPattern, TrackAssignmentController, lawnmower
from swarmtrack.estimation.lmb import cv_model
from swarmtrack.estimation.multitarget import KAPPA_FLOOR, MultiTargetEstimator, TrackerSettings
from swarmtrack.onboard.context import Context


def multi_target(spec: MultiTargetSpec, ctx: Context) -> MultiTargetEstimator:
    """Each UAV's tracker, assuming its sensor's detection law and clutter (or the settings' own), the clutter
    spread evenly over the sensor's field of view; the LMB filter, or a classic one (its ``tracker``)."""
    sensor = positions_sensor(ctx.scenario)
    rate = sensor.clutter_rate if spec.clutter_rate is None else spec.clutter_rate
    area = sensor.field_of_view()
    kappa = max(rate / area, KAPPA_FLOOR) if area is not None and rate > 0 else KAPPA_FLOOR
    pd_at = sensor.detection_probability_at
    if spec.detection_probability is not None:  # the settings' constant, inside the sensor's view
        law, pd = sensor.detection_probability_at, spec.detection_probability

        def pd_at(rel):
            return np.where(law(rel) > 0.0, pd, 0.0)
    F, Q = cv_model(ctx.dt_estimation, spec.accel_std)
    gate = float(chi2.ppf(spec.gate_probability, 2))
    if isinstance(spec, LMBSpec):
        settings = TrackerSettings(F, Q, spec.survival_probability, kappa, gate, spec.birth_rate, spec.birth_existence,
                               spec.birth_velocity_std, spec.existence_threshold, spec.prune_threshold,
                               spec.max_tracks, ctx.dt_estimation, spec.region)
        make = None
    else:
        assert isinstance(spec, ClassicSpec)
        settings = TrackerSettings(F, Q, 1.0, kappa, gate, 0.0, 0.0, spec.birth_velocity_std, 0.5, 1e-3,
                               spec.max_tracks, ctx.dt_estimation, spec.region)
        tracker, confirm, delete, compiled = registry.resolve(spec.tracker), spec.confirm, spec.delete, ctx.compiled

        def make():
            return tracker(confirm, delete, compiled)
    own = ctx.scenario.swarm.nav_position_std if spec.own_position == "include" else 0.0
    if spec.share == "centre":
        ctx.whole_swarm_only(spec.kind, "share centre is one filter fed every UAV's detections, not a UAV's "
                             "component")
    return MultiTargetEstimator(settings, ctx.rows, sensor.position_rule(own), pd_at,
                                share=spec.share == "measurements", max_shared=spec.max_shared,
                                compiled=ctx.compiled, centre=spec.share == "centre", fuse_tracks=spec.fuse_tracks,
                                max_shared_tracks=spec.max_shared_tracks, make_filter=make)


def track_assignment(spec: TrackAssignmentSpec, ctx: Context) -> TrackAssignmentController:
    """Each UAV's assignment to its tracks, its flocking around its own and the searchers' lawnmower."""
    pattern = SearchPattern(lawnmower(spec.region, spec.lane), spec.search_speed, spec.lane / 4)
    return TrackAssignmentController(flocking_gains(spec, ctx.scenario.network.r_comm), spec.variant, len(ctx.uavs),
                                     spec.chase_after_steps * ctx.dt_estimation, spec.searchers, spec.per_track,
                                     pattern)
