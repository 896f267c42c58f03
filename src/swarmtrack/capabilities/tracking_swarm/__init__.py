"""Capability 1 (L24, L23): the range-bearing sensor (and its 3-D extension with the elevation angle, L24 Sec. 6), the
decentralized information filter, its centralized baseline, the IMM bank over models of different sizes and the
flocking controller."""

from swarmtrack import registry
from swarmtrack.capabilities.tracking_swarm import settings

_METRICS = "swarmtrack.capabilities.tracking_swarm.metrics:"  # what the analysis reads of its runs
_BUILD = "swarmtrack.capabilities.tracking_swarm.build:"
_WORLD = "swarmtrack.capabilities.tracking_swarm.world:"  # the truth side

registry.register("sensor", settings.RangeBearingSpec, _WORLD + "range_bearing", batched=True,
                  measurement=registry.Measurement("swarmtrack.sensors.range_bearing:of_relative",
                                                   "swarmtrack.sensors.range_bearing:relative_of"))
registry.register("sensor", settings.RangeBearingElevationSpec, _WORLD + "range_bearing_elevation")
registry.register("estimator", settings.InformationSpec, _BUILD + "information", batched=True,
                  metrics=_METRICS + "METRICS", health=_METRICS + "HEALTH", figures=_METRICS + "FIGURES")
registry.register("estimator", settings.CentralizedSpec, _BUILD + "information", metrics=_METRICS + "METRICS",
                  health=_METRICS + "HEALTH", figures=_METRICS + "FIGURES")
registry.register("estimator", settings.IMMSpec, _BUILD + "imm", batched=True, metrics=_METRICS + "METRICS",
                  health=_METRICS + "HEALTH", figures=_METRICS + "IMM_FIGURES")
registry.register("controller", settings.FlockingSpec, _BUILD + "flocking", batched=True)
