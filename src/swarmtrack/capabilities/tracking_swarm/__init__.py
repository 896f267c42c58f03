"""Capability 1 (L24, L23): the range-bearing sensor, the decentralized information filter, its centralized
baseline, the IMM bank over models of different sizes and the flocking controller."""

from swarmtrack import registry
from swarmtrack.capabilities.tracking_swarm import settings

_BUILD = "swarmtrack.capabilities.tracking_swarm.build:"

registry.register("sensor", settings.RangeBearingSpec, _BUILD + "range_bearing", batched=True)
registry.register("estimator", settings.InformationSpec, _BUILD + "information", batched=True)
registry.register("estimator", settings.CentralizedSpec, _BUILD + "information")
registry.register("estimator", settings.IMMSpec, _BUILD + "imm")
registry.register("controller", settings.FlockingSpec, _BUILD + "flocking", batched=True)
