"""Capability 1's truth side (L24, L23): the range-bearing sensors the world senses with (never onboard)."""

from __future__ import annotations

from swarmtrack.capabilities.tracking_swarm.settings import RangeBearingElevationSpec, RangeBearingSpec
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.build import occluders
from swarmtrack.sim.sensors import RangeBearingElevationSensor, RangeBearingSensor


def range_bearing(s: RangeBearingSpec, scenario: Scenario) -> RangeBearingSensor:
    return RangeBearingSensor(s.sigma_range, s.sigma_bearing, s.max_range, s.latency, occluders(s),
                              detection_probability=s.detection_probability, clutter_rate=s.clutter_rate,
                              labelled=s.labelled, detection_falloff=s.detection_falloff)


def range_bearing_elevation(s: RangeBearingElevationSpec, scenario: Scenario) -> RangeBearingElevationSensor:
    return RangeBearingElevationSensor(s.sigma_range, s.sigma_bearing, s.sigma_elevation, s.max_range, s.latency,
                                       detection_probability=s.detection_probability, clutter_rate=s.clutter_rate,
                                       labelled=s.labelled)
