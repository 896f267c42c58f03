"""W20 Ch. 4: the gimballed camera and the multi-model distributed EKF."""

from swarmtrack import registry
from swarmtrack.capabilities.multi_model import metrics, settings

_BUILD = "swarmtrack.capabilities.multi_model.build:"

registry.register("sensor", settings.CameraSpec, _BUILD + "camera", batched=True)
registry.register("estimator", settings.MultiModelSpec, _BUILD + "multimodel", batched=True, metrics=metrics.METRICS,
                  health=metrics.HEALTH, figures=metrics.FIGURES)
