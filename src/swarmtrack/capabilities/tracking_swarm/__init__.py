"""Capability 1 (L24, L23): the range-bearing sensor (and its 3-D extension with the elevation angle, L24 Sec. 6), the
decentralized information filter, its centralized baseline, the IMM bank over models of different sizes and the
flocking controller."""

from swarmtrack import registry
from swarmtrack.capabilities.tracking_swarm import metrics, settings

_BUILD = "swarmtrack.capabilities.tracking_swarm.build:"

registry.register("sensor", settings.RangeBearingSpec, _BUILD + "range_bearing", batched=True)
registry.register("sensor", settings.RangeBearingElevationSpec, _BUILD + "range_bearing_elevation")
registry.register("estimator", settings.InformationSpec, _BUILD + "information", batched=True,
                  metrics=metrics.METRICS, health=metrics.HEALTH, figures=metrics.FIGURES)
registry.register("estimator", settings.CentralizedSpec, _BUILD + "information", metrics=metrics.METRICS,
                  health=metrics.HEALTH, figures=metrics.FIGURES)
registry.register("estimator", settings.IMMSpec, _BUILD + "imm", batched=True, metrics=metrics.METRICS,
                  health=metrics.HEALTH, figures=(*metrics.FIGURES, metrics.PROBABILITIES))
registry.register("controller", settings.FlockingSpec, _BUILD + "flocking", batched=True)
