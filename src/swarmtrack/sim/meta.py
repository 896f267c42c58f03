"""What a recording says about its run (its ``meta``): the groups' object ranges, the tracked object, the targets'
profile phases, and what the kinds' metrics and figures read. The simulator, the live world and replay write it
alike (replay without building a world)."""

from __future__ import annotations

from swarmtrack import registry
from swarmtrack.onboard.context import sensor_labels
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.streams import stream


def profiles(scenario: Scenario, group: str) -> tuple:
    """The velocity profile of each member of a driven group (random manoeuvres from the stream
    ``manoeuvres/<group>/<member>``); kinematic vehicles (walkers) fly none."""
    if _kinematic(scenario, group):
        return ()
    return tuple(m.velocity_profile(stream(scenario.seed, f"manoeuvres/{group}/{k}"))
                 for k, m in enumerate(getattr(scenario, group).members))


def _kinematic(scenario: Scenario, group: str) -> bool:
    return registry.get(registry.VEHICLE, getattr(scenario, group).vehicle).is_kinematic


def run_meta(scenario: Scenario, slices: dict[str, slice], flown: dict[str, tuple], dt_estimation: float) -> dict:
    """What a recording of one world says about its run: the groups' object ranges, the tracked object, the phases,
    and what capability 1's metrics and figures read."""
    followed = scenario.estimator.followed_target()
    net = scenario.network
    return {
        "scenario": scenario.name, "seed": scenario.seed, "dt": dt_estimation, "topology": net.topology,
        "r_comm": net.r_comm, "liar": None if net.liar is None else net.liar.uav - 1,
        "groups": {name: [sl.start, sl.stop] for name, sl in slices.items()},
        "tracked": None if followed is None else slices["targets"].start + followed - 1,
        # the label the sensor reports for the tracked target (which detections are of it, for readers of the inputs)
        "tracked_label": None if followed is None else sensor_labels(scenario)("targets", followed - 1),
        "phase_names": [] if followed is None or not flown["targets"]
        else list(flown["targets"][followed - 1].phase_names),
        # each object's phases, in the world's order (targets, decoys, UAVs); kinematic vehicles fly no profile
        "object_phases": [names for g in ("targets", "decoys") for names in
                          ([[]] * getattr(scenario, g).size() if _kinematic(scenario, g)
                           else [list(p.phase_names) for p in flown[g]])] + [[]] * scenario.swarm.n_uavs,
        "d": float("nan"),  # the flocking's (capability 1's spacing metrics), from controller.recording_meta()
        # the metrics judge the run from here: when the chase starts, or when the estimator's warm-up ends
        "chase_start": max(scenario.controller.chase_start_steps(), scenario.estimator.warmup_steps()) * dt_estimation,
        "model": None,  # the filter's motion model (capability 1's figures), from estimator.recording_meta()
        "sensor": scenario.sensor.model_dump(mode="json"),
        "estimator": scenario.estimator.model_dump(mode="json"),
        "controller": scenario.controller.model_dump(mode="json"),
        **scenario.estimator.recording_meta(),
        **scenario.controller.recording_meta(),
    }
