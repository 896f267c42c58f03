"""W20 Ch. 5: the distributed MPC formation controller."""

from swarmtrack import registry
from swarmtrack.capabilities.mpc import settings

_METRICS = "swarmtrack.capabilities.mpc.metrics:"  # what the analysis reads of its runs

registry.register("controller", settings.MPCSpec, "swarmtrack.capabilities.mpc.build:mpc", batched=True,
                  metrics=_METRICS + "METRICS", figures=_METRICS + "FIGURES")
