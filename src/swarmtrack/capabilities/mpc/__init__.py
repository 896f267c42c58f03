"""W20 Ch. 5: the distributed MPC formation controller."""

from swarmtrack import registry
from swarmtrack.capabilities.mpc import settings

registry.register("controller", settings.MPCSpec, "swarmtrack.capabilities.mpc.build:mpc")
