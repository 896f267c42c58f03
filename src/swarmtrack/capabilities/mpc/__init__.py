"""W20 Ch. 5: the distributed MPC formation controller."""

from swarmtrack import registry
from swarmtrack.capabilities.mpc import metrics, settings

registry.register("controller", settings.MPCSpec, "swarmtrack.capabilities.mpc.build:mpc", batched=True,
                  metrics=metrics.METRICS, figures=metrics.FIGURES)
