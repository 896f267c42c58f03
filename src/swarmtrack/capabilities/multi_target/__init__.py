"""Issue 40: many targets in clutter. The planar position sensor (unlabelled detections, misses, clutter) and the
labelled multi-Bernoulli estimator, one multi-target tracker per UAV over its own and its neighbours' detections
(and the classic GNN and JPDA trackers as baselines beside it), the controller that shares the UAVs between the
tracks, with the multi-target metrics (GOSPA and its split, OSPA, track continuity) and figures."""

from swarmtrack import registry
from swarmtrack.capabilities.multi_target import settings

_METRICS = "swarmtrack.capabilities.multi_target.metrics:"
_BUILD = "swarmtrack.capabilities.multi_target.build:"
_WORLD = "swarmtrack.capabilities.multi_target.world:"

registry.register("sensor", settings.PositionSpec, _WORLD + "position",
                  measurement=registry.Measurement("swarmtrack.sensors.position:of_relative",
                                                   "swarmtrack.sensors.position:relative_of"))
for _spec in (settings.LMBSpec, settings.GNNSpec, settings.JPDASpec):
    registry.register("estimator", _spec, _BUILD + "multi_target", metrics=_METRICS + "METRICS",
                      health=_METRICS + "HEALTH", figures=_METRICS + "FIGURES")
registry.register("controller", settings.TrackAssignmentSpec, _BUILD + "track_assignment")
