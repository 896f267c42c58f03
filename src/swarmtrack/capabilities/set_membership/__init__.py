"""IB21: the footprint sensor, the set-membership estimator (with the truth-side monitor of its guarantee) and the
set-membership MPC."""

from swarmtrack import registry
from swarmtrack.capabilities.set_membership import metrics, settings

_BUILD = "swarmtrack.capabilities.set_membership.build:"

registry.register("sensor", settings.FootprintSpec, _BUILD + "footprint_sensor")
registry.register("estimator", settings.SetMembershipSpec, _BUILD + "setmembership",
                  monitors=_BUILD + "guarantee_monitor", metrics=metrics.METRICS, figures=metrics.FIGURES,
                  animated=True, telemetry="swarmtrack.capabilities.set_membership.telemetry:TELEMETRY")
registry.register("controller", settings.SMMPCSpec, _BUILD + "sm_mpc")
