"""How kinds fit together, from what they declare (never from their names): what ``swarmtrack validate`` accepts,
``swarmtrack run`` can build and run (tests/scenarios/test_validate_equals_run.py).

* A sensor's settings declare what its measurements *give* an estimator (:attr:`SensorSpec.gives
  <swarmtrack.scenarios.schema.SensorSpec.gives>`, names of :data:`MEASUREMENTS`) and whether it reads heights
  (``three_d``); an estimator's settings declare what they *read* (:attr:`EstimatorSpec.reads
  <swarmtrack.scenarios.schema.EstimatorSpec.reads>`), one of which the sensor must give.
* A controller's settings declare how many numbers it *commands* per UAV (:attr:`ControllerSpec.commands
  <swarmtrack.scenarios.schema.ControllerSpec.commands>`), which the swarm's vehicle kind must take (its
  ``command_width``).
* A controller that follows the truth needs targets that fly velocity profiles (vehicle kinds that are not
  kinematic): the oracle tells the model the followed target flies.

Each check raises one ValueError naming the field; :meth:`Scenario._cross_checks
<swarmtrack.scenarios.schema.Scenario._cross_checks>` calls them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from swarmtrack import registry

if TYPE_CHECKING:
    from swarmtrack.scenarios.schema import Scenario

#: What a sensor's measurements can give an estimator, by name.
MEASUREMENTS = {
    "information_update": "an information-form update at the target's position (the sensor settings' update_rule)",
    "range_bearing": "planar range and bearing with Gaussian noise (sigma_range, sigma_bearing)",
    "camera_position": "the target's metric position in a gimballed camera's frame",
    "bounded_detections": "detections with bounded noise, identified from inside a cone (a footprint)",
    "positions": "each detection as a planar position with its covariance (the sensor settings' position_rule), "
                 "with the sensor's detection probability and clutter rate over its field of view",
}


def _they(names: list[str], verb: str) -> str:
    """``"a, b give"`` or ``"a gives"``."""
    return f"{', '.join(names)} {verb}{'s' if len(names) == 1 else ''}"


def describe(settings: type) -> str:
    """What a kind's settings class declares, in words (the scenario reference heads its section with it)."""
    parts = []
    if hasattr(settings, "gives"):
        parts.append(f"gives {', '.join(sorted(settings.gives)) or 'nothing an estimator reads'}")
    if getattr(settings, "three_d", False):
        parts.append("3-D: reads heights")
    reads, commands = getattr(settings, "reads", None), getattr(settings, "commands", None)
    if reads:
        parts.append("reads " + " or ".join(sorted(reads)))
    if commands is not None:
        parts.append(f"commands {commands} number(s) per UAV")
    return "; ".join(parts)


def sensor_feeds_estimator(scenario: Scenario) -> None:
    """The sensor gives a measurement the estimator reads."""
    reads, sensor = scenario.estimator.reads, scenario.sensor
    if not reads or reads & sensor.gives:
        return
    fit = [n for n, k in registry.kinds("sensor").items() if reads & k.settings.gives]
    gives = ", ".join(sorted(sensor.gives)) or "nothing an estimator reads"
    raise ValueError(f"estimator.kind {scenario.estimator.kind} reads {' or '.join(sorted(reads))}, which sensor.kind "
                     f"{sensor.kind} does not give (it gives {gives})"
                     + (f"; sensor.kind {_they(fit, 'give')} it" if fit else ""))


def sensor_sees_followed_target(scenario: Scenario) -> None:
    """An estimator that follows a target has a sensor that sees the targets (its settings' ``sensed``: the builders
    take the target's label from it, :meth:`~swarmtrack.onboard.context.Context.target_label`)."""
    if scenario.estimator.followed_target() is not None and "targets" not in scenario.sensor.sensed:
        raise ValueError(f"estimator.kind {scenario.estimator.kind} follows estimator.target, which sensor.kind "
                         f"{scenario.sensor.kind} does not see (it sees {', '.join(scenario.sensor.sensed) or 'none'})")
    if scenario.estimator.followed_target() is not None and not getattr(scenario.sensor, "labelled", True):
        raise ValueError(f"sensor.labelled is false, but estimator.kind {scenario.estimator.kind} recognises "
                         "estimator.target by the label its sensor reports: use a multi-target estimator (lmb) or "
                         "a labelled sensor")


def controller_drives_vehicle(scenario: Scenario) -> None:
    """The controller commands as many numbers per UAV as the swarm's vehicle takes."""
    commands = scenario.controller.commands
    vehicles = {n: v for n, v in registry.kinds(registry.VEHICLE).items() if v.uav}
    takes = vehicles[scenario.swarm.vehicle].command_width
    if commands is None or commands == takes:
        return
    fit = [n for n, v in vehicles.items() if v.command_width == commands]
    raise ValueError(f"controller.kind {scenario.controller.kind} commands {commands} number(s) per UAV, but "
                     f"swarm.vehicle {scenario.swarm.vehicle} takes {takes}"
                     + (f" (swarm.vehicle {_they(fit, 'take')} {commands})" if fit else ""))


def truth_has_a_profile(scenario: Scenario) -> None:
    """A controller following the truth follows a target that flies a velocity profile (not a kinematic vehicle,
    which steps its own inputs)."""
    targets = scenario.targets.vehicle
    if scenario.controller.follows_truth() and registry.get(registry.VEHICLE, targets).is_kinematic:
        raise ValueError(f"controller.follow: truth needs targets that fly velocity profiles (the oracle tells the "
                         f"model the followed target flies): targets.vehicle {targets} steps its own kinematics")
