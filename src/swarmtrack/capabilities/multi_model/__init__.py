"""W20 Ch. 4: the gimballed camera and the multi-model distributed EKF."""

from swarmtrack import registry
from swarmtrack.capabilities.multi_model import settings

_METRICS = "swarmtrack.capabilities.multi_model.metrics:"  # what the analysis reads of its runs
_BUILD = "swarmtrack.capabilities.multi_model.build:"
_WORLD = "swarmtrack.capabilities.multi_model.world:"  # the truth side

registry.register("sensor", settings.CameraSpec, _WORLD + "camera", batched=True,
                  measurement=registry.Measurement("swarmtrack.sensors.camera:of_relative",
                                                   "swarmtrack.sensors.camera:relative_of"))
registry.register("estimator", settings.MultiModelSpec, _BUILD + "multimodel", batched=True,
                  metrics=_METRICS + "METRICS", health=_METRICS + "HEALTH", figures=_METRICS + "FIGURES")
