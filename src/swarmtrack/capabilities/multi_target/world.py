"""Issue 40's truth side: the position sensor the world senses with (never onboard)."""

from __future__ import annotations

from swarmtrack.capabilities.multi_target.settings import PositionSpec
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.build import occluders
from swarmtrack.sim.sensors import PositionSensor


def position(s: PositionSpec, scenario: Scenario) -> PositionSensor:
    return PositionSensor(s.sigma, s.half_width, s.latency, occluders(s),
                          detection_probability=s.detection_probability, clutter_rate=s.clutter_rate,
                          detection_falloff=s.detection_falloff)
