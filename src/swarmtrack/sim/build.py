"""From a scenario to a runnable simulation: world, onboard stack, channel, recorder metadata.

The registries :data:`ESTIMATORS` and :data:`CONTROLLERS` map a scenario section's ``kind`` to the function that
builds it; :func:`register` adds a kind (its settings class goes into the schema's registry, its builder here),
so a new capability adds modules and a registry entry, never a branch in the engine.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from swarmtrack.control.flocking import FlockingController, FlockingGains
from swarmtrack.control.mpc import MPCController, MPCSettings
from swarmtrack.control.position import PositionGains
from swarmtrack.control.sm_mpc import SetMembershipMPC
from swarmtrack.control.static import StaticController
from swarmtrack.estimation.imm import IMMInformationEstimator
from swarmtrack.estimation.information import InformationEstimator, RangeBearingUpdate
from swarmtrack.estimation.measurements import CameraFrameMeasurement, RangeBearingMeasurement
from swarmtrack.estimation.multimodel import MultiModelEstimator
from swarmtrack.estimation.refilter import RefilteringEstimator
from swarmtrack.estimation.setmembership import ReplayingSetMembershipEstimator, SetMembershipEstimator
from swarmtrack.models import make_model
from swarmtrack.network.channel import Channel
from swarmtrack.network.faults import Liar
from swarmtrack.network.links import edge_list, proximity_links
from swarmtrack.scenarios.loader import ScenarioError
from swarmtrack.scenarios.schema import (
    CONTROLLER_KINDS,
    ESTIMATOR_KINDS,
    CameraSpec,
    ControllerSpec,
    EstimatorSpec,
    FilterSpec,
    FlockingSpec,
    FootprintSpec,
    GroupSpec,
    IMMSpec,
    MPCSpec,
    MultiModelSpec,
    RangeBearingSpec,
    Scenario,
    SensorSpec,
    SetMembershipSpec,
    SMMPCSpec,
    refiltered_steps,
)
from swarmtrack.sim.agent import OnboardStack
from swarmtrack.sim.clock import Clock
from swarmtrack.sim.oracle import TruthOracle
from swarmtrack.sim.streams import stream
from swarmtrack.sim.world import (
    CameraSensor,
    FootprintSensor,
    Group,
    Occluder,
    ProfileDriver,
    RangeBearingSensor,
    World,
    hidden_by,
)
from swarmtrack.vehicles.fixed_wing import FixedWingParams
from swarmtrack.vehicles.ground_walker import WalkerParams


@dataclass(frozen=True)
class Context:
    """What a builder may use besides its own settings: the scenario, the rates and the labels the sensor reports
    for the world's objects. Not the world itself: what a builder hands an onboard component must not be truth."""

    scenario: Scenario
    n_uavs: int
    dt_estimation: float
    dt_control: float
    compiled: bool
    label_of: Callable[[str, int], int]
    """``label_of(group, member)``: the label the sensor reports for ``group`` member ``member`` (0-based)."""
    command_width: int = 2
    """What a UAV's controller commands per UAV: 2 (a planar acceleration) or 1 (a fixed wing's yaw acceleration)."""


def _information(spec: FilterSpec, ctx: Context) -> InformationEstimator:
    """L24's filter; with late data (latency, delays) and ``delayed_data: refilter``, the time-stamp-aware one."""
    s = ctx.scenario.sensor
    window = refiltered_steps(ctx.scenario) if spec.delayed_data == "refilter" else 0
    kind, extra = (RefilteringEstimator, {"window": window}) if window else (InformationEstimator, {})
    own = ctx.scenario.swarm.nav_position_std if spec.own_position == "include" else 0.0
    return kind(
        make_model(spec.model, ctx.dt_estimation, spec.q),
        RangeBearingUpdate(s.sigma_range, s.sigma_bearing, s.update, own_sigma=own),
        ctx.n_uavs, label=ctx.label_of("targets", spec.target - 1), share=spec.share,
        centralized=spec.kind == "centralized", initial_info=spec.initial_information,
        fake_vz_sigma=spec.fake_vz_sigma, compiled=ctx.compiled, gating=spec.gating,
        gate_probability=spec.gate_probability, **extra)


def _imm(spec: IMMSpec, ctx: Context) -> IMMInformationEstimator:
    s = ctx.scenario.sensor
    qs = spec.q or [None] * len(spec.models)
    return IMMInformationEstimator(
        [make_model(m, ctx.dt_estimation, q) for m, q in zip(spec.models, qs, strict=True)],
        RangeBearingUpdate(s.sigma_range, s.sigma_bearing, s.update), ctx.n_uavs,
        label=ctx.label_of("targets", spec.target - 1), share=spec.share, markov=spec.markov,
        initial_info=spec.initial_information, fake_vz_sigma=spec.fake_vz_sigma)


#: W20 Table 4.1: x̂0 = [h⁻¹(z0); 0], with CT's turn rate ω0 = 1e-5 rad/s.
W20_HIDDEN_START = {"cv": (0.0, 0.0), "ca": (0.0,) * 4, "ct": (0.0, 0.0, 1e-5)}


def _multimodel(spec: MultiModelSpec, ctx: Context) -> MultiModelEstimator:
    """W20 Ch. 4: one model per UAV with Q = q I (ω: q_turn_rate), P0 = p0 I (ω: p0_turn_rate)."""
    def diag(name: str, value: float, turn: float) -> list[float]:
        dim = make_model(name, ctx.dt_estimation).dim
        return [value] * 4 + ([turn] if name == "ct" else [value] * (dim - 4))

    models = [make_model(m, ctx.dt_estimation, diag(m, spec.q, spec.q_turn_rate)) for m in spec.models]
    s = ctx.scenario.sensor
    measurement = CameraFrameMeasurement(spec.r) if isinstance(s, CameraSpec) else \
        RangeBearingMeasurement(s.sigma_range, s.sigma_bearing)
    return MultiModelEstimator(
        models, measurement, label=ctx.label_of("targets", spec.target - 1), fusion_rule=spec.fusion,
        occlusion=spec.occlusion, window=spec.window, solo_steps=spec.solo_steps, markov=spec.markov,
        P0={m: np.diag(diag(m, spec.p0, spec.p0_turn_rate)) for m in set(spec.models)},
        x0_hidden={m: np.asarray(W20_HIDDEN_START[m]) for m in set(spec.models)}, compiled=ctx.compiled)


def flocking_gains(spec: FlockingSpec, r_comm: float) -> FlockingGains:
    """The scenario's flocking gains (names checked by the schema) with its d and r_comm."""
    return dataclasses.replace(FlockingGains(), **spec.gains, d=spec.d, r_comm=r_comm)


def _flocking(spec: FlockingSpec, ctx: Context) -> FlockingController:
    return FlockingController(flocking_gains(spec, ctx.scenario.network.r_comm), spec.variant, ctx.n_uavs,
                              spec.chase_after_steps * ctx.dt_estimation, compiled=ctx.compiled)


def _mpc(spec: MPCSpec, ctx: Context) -> MPCController:
    _, A, B = spec.uav_model()
    settings = MPCSettings(spec.horizon, spec.period, spec.Q, spec.R, spec.Q_s, spec.r_s, spec.bound)
    offsets = np.asarray(spec.offsets or [(0.0, 0.0)] * ctx.n_uavs, dtype=float)
    return MPCController(A, B, offsets, settings, target_model=None if spec.target_model == "estimate" else
                         spec.target_model, start=spec.start, gains=PositionGains(**spec.gains.model_dump()))


def _setmembership(spec: SetMembershipSpec, ctx: Context) -> SetMembershipEstimator:
    """IB21's estimator; with network delays and ``delayed_data: refilter``, the one that replays (Sec. 4.5)."""
    import shapely

    window = spec.replayed_periods(ctx.scenario)
    kind, extra = (ReplayingSetMembershipEstimator, {"window": window}) if window else (SetMembershipEstimator, {})
    if spec.sets == "raster":
        from swarmtrack.estimation import setmembership_raster as raster

        kind = raster.RasterReplayingSetMembershipEstimator if window else raster.RasterSetMembershipEstimator
        extra = {**extra, "cell": spec.cell}
    return kind(ctx.n_uavs, ctx.scenario.targets.size(), shapely.box(*spec.area),
                speed=spec.speed_bound(ctx.scenario), bound=tuple(spec.noise_bound), period=spec.period, **extra)


def _sm_mpc(spec: SMMPCSpec, ctx: Context) -> SetMembershipMPC:
    import shapely

    from swarmtrack.control.sm_mpc import SMMPCSettings
    from swarmtrack.models.fixed_wing import FixedWingParams as Model
    from swarmtrack.sensors.footprint import tan_half

    sc = ctx.scenario
    f, sensor = sc.swarm.fixed_wing, sc.sensor
    settings = SMMPCSettings(tuple(spec.inputs), spec.horizon, spec.period, ctx.dt_estimation, spec.alpha,
                             spec.distance, sc.estimator.speed_bound(sc), sc.network.r_comm,
                             Model(f.speed, f.altitude, f.yaw_rate_max), tan_half(sensor.opening, sensor.convention),
                             sensor.orientation, spec.baseline)
    area = shapely.box(*sc.estimator.area)
    grid = None
    if sc.estimator.sets == "raster":  # the estimator's X^A are fields on this grid
        from swarmtrack.estimation.raster import Grid

        grid = Grid.over(area, sc.estimator.cell)
    return SetMembershipMPC(area, settings, n_uavs=ctx.n_uavs, grid=grid)


#: ``kind`` → builder ``(settings, Context) -> Estimator``.
ESTIMATORS: dict[str, Callable] = {"information": _information, "centralized": _information,
                                   "multimodel": _multimodel, "imm": _imm, "setmembership": _setmembership}
#: ``kind`` → builder ``(settings, Context) -> Controller``.
CONTROLLERS: dict[str, Callable] = {"flocking": _flocking,
                                    "static": lambda spec, ctx: StaticController(ctx.n_uavs, ctx.command_width),
                                    "mpc": _mpc, "sm_mpc": _sm_mpc}


def _occluders(s: SensorSpec) -> tuple[Occluder, ...]:
    return tuple(Occluder(o.region, o.window, tuple(u - 1 for u in o.uavs)) for o in s.occluders)


def _range_bearing(s: RangeBearingSpec, scenario: Scenario) -> RangeBearingSensor:
    return RangeBearingSensor(s.sigma_range, s.sigma_bearing, s.max_range, s.latency, _occluders(s))


def _camera(s: CameraSpec, scenario: Scenario) -> CameraSensor:
    tan_half = (0.5 * s.footprint[0] / s.footprint_range, 0.5 * s.footprint[1] / s.footprint_range)
    return CameraSensor(s.sigma, s.height, tan_half, tuple(s.home), _occluders(s), s.latency)


def _footprint(s: FootprintSpec, scenario: Scenario) -> FootprintSensor:
    """Each sensed object's cone angles from its stream ``cones/<group>/<k>``; decoys confused with target ℓ mod N_t
    (IB21 leaves J open)."""
    from swarmtrack.sensors import footprint

    params = footprint.FootprintParams(s.opening, s.convention, s.orientation, tuple(s.noise_bound),
                                       confusion=s.confusion)
    angles = [footprint.draw_cones(stream(scenario.seed, f"cones/{g}/{k}"), 1)
              for g in ("targets", "decoys") for k in range(getattr(scenario, g).size())]
    beta = np.array([a[0][0] for a in angles])
    gamma = np.array([a[1][0] for a in angles])
    n_t, n_f = scenario.targets.size(), scenario.decoys.size()
    is_decoy = np.r_[np.zeros(n_t, bool), np.ones(n_f, bool)]
    return FootprintSensor(params, beta, gamma, is_decoy, footprint.confusion_map(n_f, n_t))


#: sensor ``kind`` → builder ``(settings, scenario)`` of the world's (truth-side) sensor.
SENSORS: dict[str, Callable] = {"range_bearing": _range_bearing, "camera": _camera, "footprint": _footprint}


def register(role: str, spec: type, builder: Callable) -> None:
    """Add an estimator (``role="estimator"``) or controller kind: its settings class (a subclass of
    :class:`~swarmtrack.scenarios.schema.EstimatorSpec` / ``ControllerSpec`` whose ``kind`` is a literal with a
    default) and its builder. Scenarios can then pick it by ``kind``. A kind is registered once."""
    kinds, builders, base = {"estimator": (ESTIMATOR_KINDS, ESTIMATORS, EstimatorSpec),
                             "controller": (CONTROLLER_KINDS, CONTROLLERS, ControllerSpec)}[role]
    if not issubclass(spec, base):
        raise TypeError(f"{spec.__name__} must subclass {base.__name__}")
    kind = spec.model_fields["kind"].default
    if not isinstance(kind, str):
        raise TypeError(f"{spec.__name__}.kind needs a string default (its kind)")
    if kind in kinds or kind in builders:
        raise ValueError(f"{role} kind {kind!r} is already registered")
    kinds[kind] = spec
    builders[kind] = builder


def _builder(role: str, kind: str, builders: dict) -> Callable:
    if kind not in builders:
        raise ScenarioError(f"{role}.kind {kind!r} has settings but no builder: add both with "
                            "swarmtrack.sim.build.register")
    return builders[kind]


def spawn_positions(scenario: Scenario, rng: np.random.Generator) -> np.ndarray:
    """Initial UAV positions: the scenario's, or seeded uniform draws in the spawn box, kept apart."""
    sw = scenario.swarm
    if sw.initial_positions is not None:
        return np.asarray(sw.initial_positions, dtype=float)
    center = np.asarray(sw.spawn_center)
    pos = center + rng.uniform(-sw.spawn_half_width, sw.spawn_half_width, size=(sw.n_uavs, 2))
    for _ in range(10_000):  # redraw the UAVs that are too close to an earlier one (near jamming: thousands)
        close = _too_close(pos, sw.min_separation)
        if not close.any():
            break
        pos[close] = center + rng.uniform(-sw.spawn_half_width, sw.spawn_half_width, size=(close.sum(), 2))
    else:
        raise ScenarioError(f"swarm: cannot place {sw.n_uavs} UAVs {sw.min_separation} m apart in a spawn box of "
                            f"half-width {sw.spawn_half_width} m; enlarge swarm.spawn_half_width or lower "
                            "swarm.min_separation")
    return pos


def _too_close(pos: np.ndarray, min_sep: float) -> np.ndarray:
    """UAVs closer than ``min_sep`` to an earlier UAV (the links of a proximity graph of range ``min_sep``: dense
    for small swarms, a KD-tree for large ones)."""
    close = np.zeros(len(pos), dtype=bool)
    if min_sep > 0 and len(pos) > 1:
        receivers, senders = edge_list(proximity_links(pos, min_sep))
        close[np.maximum(receivers, senders)] = True
    return close


def profiles(scenario: Scenario, group: str) -> tuple:
    """The velocity profile of each member of a driven group (random manoeuvres from the stream
    ``manoeuvres/<group>/<member>``); walkers fly none."""
    spec = getattr(scenario, group)
    if spec.vehicle == "walker":
        return ()
    return tuple(m.velocity_profile(stream(scenario.seed, f"manoeuvres/{group}/{k}"))
                 for k, m in enumerate(spec.members))


def _group(name: str, spec: GroupSpec, flown: tuple, seed: int = 0) -> Group:
    starts = np.asarray([m.start for m in spec.members], dtype=float).reshape(-1, 2)
    if spec.vehicle == "walker":  # the listed members, then `count` at uniform places and headings (IB21 Sec. 6)
        rng = stream(seed, f"spawn/{name}")
        x0, y0, x1, y1 = spec.area
        starts = np.concatenate([starts, rng.uniform((x0, y0), (x1, y1), size=(spec.count, 2))])
        heading = np.concatenate([[m.heading for m in spec.members], rng.uniform(-np.pi, np.pi, spec.count)])
        return Group(name, "walker", starts, params=WalkerParams(spec.speed, spec.yaw_accel_bound, tuple(spec.area)),
                     heading=heading)
    return Group(name, spec.vehicle, starts, ProfileDriver(flown, spec.velocity_gain, spec.wind_std))


def _uavs(scenario: Scenario) -> Group:
    """The swarm at its spawn positions; fixed wings also with seeded uniform headings (stream ``spawn/headings``)."""
    sw = scenario.swarm
    starts = spawn_positions(scenario, stream(scenario.seed, "spawn"))
    if sw.vehicle != "fixed_wing":
        return Group("uavs", sw.vehicle, starts)
    f = sw.fixed_wing
    heading = stream(scenario.seed, "spawn/headings").uniform(-np.pi, np.pi, sw.n_uavs)
    return Group("uavs", "fixed_wing", starts, params=FixedWingParams(f.speed, f.altitude, f.yaw_rate_max),
                 heading=heading)


def _oracle(world: World, tracked: int, profile, n: int) -> TruthOracle:
    """The truth oracle for the followed target: its state, the model its profile flies now, and which UAVs the
    sensor's occluders blind."""
    def kinematics():
        return profile.velocity(world.t), profile.acceleration(world.t)

    def blind():
        hidden = hidden_by(world.sensor.occluders, world.truth()[tracked, None, :2], n, world.t)
        return np.zeros(n, dtype=bool) if hidden is None else hidden[:, 0]

    return TruthOracle(lambda: world.truth()[tracked], n, kinematics=kinematics, blind=blind, now=lambda: world.t)


@dataclass
class Simulation:
    """Everything one run needs: the truth, the onboard stack, the channel, the clock and the recording's
    metadata."""

    world: World
    stack: OnboardStack
    channel: Channel
    clock: Clock
    meta: dict
    monitors: dict = dataclasses.field(default_factory=dict)
    """Truth-side checks recorded beside the probes: name → a function giving (N,) values (never onboard)."""


def build(scenario: Scenario) -> Simulation:
    """Wire a validated scenario into a :class:`Simulation` (random streams derived by purpose from its seed)."""
    r = scenario.rates
    clock = Clock.from_rates(r.physics, r.estimation, r.control, scenario.run_duration())
    dt_phys, dt_est = clock.dt, clock.dt_estimation
    compiled = scenario.kernels != "numpy"  # one decision for every compiled fast path
    n = scenario.swarm.n_uavs
    seed = scenario.seed
    flown = {g: profiles(scenario, g) for g in ("targets", "decoys")}
    groups = [_group("targets", scenario.targets, flown["targets"], seed),
              _group("decoys", scenario.decoys, flown["decoys"], seed), _uavs(scenario)]
    world = World(groups, SENSORS[scenario.sensor.kind](scenario.sensor, scenario),
                  dt=dt_phys, ticks=clock.steps * clock.ticks_estimation,
                  nav_std=(scenario.swarm.nav_position_std, scenario.swarm.nav_velocity_std),
                  streams=lambda purpose: stream(seed, purpose), compiled=compiled)
    ctx = Context(scenario, n, dt_est, clock.dt_control, compiled,
                  lambda group, member: world.label_of(world.slices[group].start + member),
                  1 if scenario.swarm.vehicle == "fixed_wing" else 2)
    estimator = _builder("estimator", scenario.estimator.kind, ESTIMATORS)(scenario.estimator, ctx)
    controller = _builder("controller", scenario.controller.kind, CONTROLLERS)(scenario.controller, ctx)
    followed = scenario.estimator.followed_target()  # 1-based member of targets, checked by the schema
    tracked = None if followed is None else world.slices["targets"].start + followed - 1
    guide = estimator
    if getattr(scenario.controller, "follow", "estimate") == "truth":  # the schema checked there is a target
        guide = _oracle(world, tracked, flown["targets"][followed - 1], n)
    net = scenario.network
    channel = Channel(net.topology, n, net.r_comm, tuple((a - 1, b - 1) for a, b in net.edges),
                      net.loss_probability, stream(seed, "channel"),
                      outages=tuple((tuple(u - 1 for u in o.uavs), o.window) for o in net.outages),
                      delay=net.delay, delay_max=net.delay_bound(), dt=dt_est, delay_rng=stream(seed, "channel/delay"),
                      liar=None if net.liar is None else Liar(net.liar.uav - 1, net.liar.mode, net.liar.offset,
                                                              net.liar.sigma, net.liar.start, stream(seed, "liar")))
    meta = run_meta(scenario, world.slices, flown, dt_est)
    return Simulation(world, OnboardStack(estimator, controller, guide), channel, clock, meta,
                      _monitors(world, estimator))


def _monitors(world: World, estimator) -> dict[str, Callable[[], np.ndarray]]:
    """Truth-side checks recorded beside the probes (N,) each: for a guaranteed estimator, the number of true
    targets outside the sets that must hold them (IB21's guarantee)."""
    if not hasattr(estimator, "containing") or not world.slices["targets"].stop - world.slices["targets"].start:
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
        "phase_names": [] if followed is None else list(flown["targets"][followed - 1].phase_names),
        "object_phases": [list(p.phase_names) for p in flown["targets"] + flown["decoys"]]
        + [[]] * (scenario.swarm.n_uavs + sum(getattr(scenario, g).size() for g in ("targets", "decoys")
                                              if getattr(scenario, g).vehicle == "walker")),
        # what capability 1's metrics and figures read: the flocking's d, when the chase starts, the filter model
        "d": getattr(scenario.controller, "d", float("nan")),
        # the metrics judge the run from here: when the chase starts, or when the estimator's warm-up ends
        "chase_start": max(getattr(scenario.controller, "chase_after_steps", 0),
                           scenario.estimator.warmup_steps()) * dt_estimation,
        "model": getattr(scenario.estimator, "model", None),
        "estimator": scenario.estimator.model_dump(mode="json"),
        "controller": scenario.controller.model_dump(mode="json"),
    }
