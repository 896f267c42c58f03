"""IB21's builders: the set-membership estimator and MPC (sharing one set backend), the footprint sensor and the
truth-side monitor of the guarantee."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import shapely

from swarmtrack.capabilities.set_membership.settings import FootprintSpec, SetMembershipSpec, SMMPCSpec
from swarmtrack.control.sm_mpc import SetMembershipMPC, SMMPCSettings
from swarmtrack.estimation.set_backends import PolygonSets, RasterSets, SetBackend
from swarmtrack.estimation.setmembership import SetMembershipEstimator
from swarmtrack.models.fixed_wing import FixedWingParams
from swarmtrack.onboard.context import Context
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sensors import footprint
from swarmtrack.sim.sensors import FootprintSensor
from swarmtrack.sim.streams import stream
from swarmtrack.sim.world import World


def set_backend(spec: SetMembershipSpec) -> SetBackend:
    """How the run holds its sets (``estimator.sets``): polygons, or raster fields of side ``estimator.cell``."""
    area = shapely.box(*spec.area)
    return RasterSets.over(area, spec.cell) if spec.sets == "raster" else PolygonSets(area)


def setmembership(spec: SetMembershipSpec, ctx: Context) -> SetMembershipEstimator:
    """IB21's estimator on the run's set backend; with network delays and ``delayed_data: refilter``, the one that
    replays (Sec. 4.5). Builds for any subset ``ctx.uavs``: on raster sets every operation is exact, so a fusion's
    result does not depend on its operands' order; on polygons each UAV fuses its own group in a canonical order (by
    UAV) with sets told apart by value (:func:`swarmtrack.estimation.setmembership.fuse`), so its rows are the whole
    swarm's bit for bit either way."""
    sets = ctx.shared("sets", lambda: set_backend(spec))
    return sets.estimator(len(ctx.uavs), ctx.scenario.targets.size(), window=spec.replayed_periods(ctx.scenario),
                          speed=spec.speed_bound(ctx.scenario), bound=tuple(spec.noise_bound), period=spec.period,
                          uavs=None if ctx.rows.whole else ctx.uavs)


def sm_mpc(spec: SMMPCSpec, ctx: Context) -> SetMembershipMPC:
    sc = ctx.scenario
    f, sensor = sc.swarm.fixed_wing, sc.sensor
    settings = SMMPCSettings(tuple(spec.inputs), spec.horizon, spec.period, ctx.dt_estimation, spec.alpha,
                             spec.distance, sc.estimator.speed_bound(sc), sc.network.r_comm,
                             FixedWingParams(f.speed, f.altitude, f.yaw_rate_max),
                             footprint.tan_half(sensor.opening, sensor.convention), sensor.orientation, spec.baseline)
    sets = ctx.shared("sets", lambda: set_backend(sc.estimator))  # the estimator's: its X^A are what it plans on
    return SetMembershipMPC(sets, settings, n_uavs=ctx.n_uavs, uavs=None if ctx.rows.whole else ctx.uavs)


def footprint_sensor(s: FootprintSpec, scenario: Scenario) -> FootprintSensor:
    """Each sensed object's cone angles from its stream ``cones/<group>/<k>``; decoys confused with target ℓ mod N_t
    (IB21 leaves J open)."""
    params = footprint.FootprintParams(s.opening, s.convention, s.orientation, tuple(s.noise_bound),
                                       confusion=s.confusion)
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
