"""IB21's truth side: the footprint sensor the world senses with, and the monitor of the guarantee (never onboard)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from swarmtrack.capabilities.set_membership.build import footprint_params
from swarmtrack.capabilities.set_membership.settings import FootprintSpec
from swarmtrack.estimation.setmembership import SetMembershipEstimator
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sensors import footprint
from swarmtrack.sim.sensors import FootprintSensor
from swarmtrack.sim.streams import stream
from swarmtrack.sim.world import World


def footprint_sensor(s: FootprintSpec, scenario: Scenario) -> FootprintSensor:
    """Each sensed object's cone angles from its stream ``cones/<group>/<k>``; decoys confused with target ℓ mod N_t
    (IB21 leaves J open)."""
    params = footprint_params(s)
    angles = [footprint.draw_cones(stream(scenario.seed, f"cones/{g}/{k}"), 1)
              for g in ("targets", "decoys") for k in range(getattr(scenario, g).size())]
    beta = np.array([a[0][0] for a in angles])
    gamma = np.array([a[1][0] for a in angles])
    n_t, n_f = scenario.targets.size(), scenario.decoys.size()
    is_decoy = np.r_[np.zeros(n_t, bool), np.ones(n_f, bool)]
    return FootprintSensor(params, beta, gamma, is_decoy, footprint.confusion_map(n_f, n_t))


def guarantee_monitor(world: World, estimator: SetMembershipEstimator) -> dict[str, Callable[[], np.ndarray]]:
    """Truth-side check recorded beside the probes, (N,): the number of true targets outside the sets that must hold
    them (IB21's guarantee)."""
    if not world.slices["targets"].stop - world.slices["targets"].start:
        return {}
    ids = np.arange(world.slices["targets"].stop - world.slices["targets"].start)

    def violations() -> np.ndarray:
        """Checked for the UAVs whose sets describe this instant (updated now); 0 for the others, whose sets are
        older than the truth they would be compared with."""
        now = estimator.current(world.t)
        out = np.zeros(len(now))
        if now.any():
            out[now] = (~estimator.containing(world.truth("targets")[:, :2], ids)[now]).sum(axis=1)
        return out

    return {"guarantee_violations": violations}
