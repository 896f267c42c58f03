"""IB21: the footprint sensor, the set-membership estimator (with the truth-side monitor of its guarantee) and the
set-membership MPC."""

from swarmtrack import registry
from swarmtrack.capabilities.set_membership import settings

_METRICS = "swarmtrack.capabilities.set_membership.metrics:"  # what the analysis reads of its runs
_BUILD = "swarmtrack.capabilities.set_membership.build:"
_WORLD = "swarmtrack.capabilities.set_membership.world:"  # the truth side

registry.register("sensor", settings.FootprintSpec, _WORLD + "footprint_sensor", quiet=_BUILD + "quiet_frame")
registry.register("estimator", settings.SetMembershipSpec, _BUILD + "setmembership",
                  monitors=_WORLD + "guarantee_monitor", metrics=_METRICS + "METRICS", figures=_METRICS + "FIGURES",
                  telemetry="swarmtrack.capabilities.set_membership.telemetry:TELEMETRY",
                  shapes="swarmtrack.capabilities.set_membership.views:shapes")
registry.register("controller", settings.SMMPCSpec, _BUILD + "sm_mpc")
