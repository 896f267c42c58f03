"""The world: the only holder of truth, a set of named vehicle groups integrated at the physics rate.

A group (``uavs``, ``targets``, ``decoys``, any number of members each) has one vehicle kind, a registered
:class:`~swarmtrack.vehicles.base.Vehicle` whose attributes say how it is stepped (the world never tests a kind's
name): an acceleration-driven one (quadrotor, double integrator) has, when nothing onboard commands it, a driver
(:class:`ProfileDriver`: each member's autopilot flies its own velocity profile); a kinematic one is stepped by its
module, driven by its commands (the swarm) or its own draws (a group). The world hands each UAV what that UAV's own
devices would give it (a noisy navigation solution, its sensor's detections) and keeps the origin of every detection
to itself.
Onboard code never imports this module, and this module never imports the scenarios (the builder,
:mod:`swarmtrack.sim.build`, translates a scenario into a world).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from swarmtrack import registry
from swarmtrack.onboard.context import sensed_objects
from swarmtrack.sim.altitude_channel import AltitudeChannel
from swarmtrack.sim.sensors import Scene, Sensor
from swarmtrack.vehicles import double_integrator, fixed_wing, quadrotor
from swarmtrack.vehicles import kernels as _kernels
from swarmtrack.vehicles.altitude import GroupAltitude
from swarmtrack.vehicles.base import Vehicle
from swarmtrack.vehicles.profile import VelocityProfile

_PACK_WIDTH = _kernels.PACK_WIDTH


def vehicle(name: str) -> Vehicle:
    """The registered vehicle kind ``name`` (:mod:`swarmtrack.registry`)."""
    return registry.get(registry.VEHICLE, name)


@dataclass(frozen=True)
class ProfileDriver:
    """Every member's autopilot flies its own velocity profile: ``a = gain·(v_cmd − v) + a_ff`` plus a random
    gust of std ``wind_std`` (L24 Sec. 4 target; gains chosen, see the scenario schema)."""

    profiles: tuple[VelocityProfile, ...]
    gain: float
    wind_std: float


@dataclass(frozen=True)
class Group:
    """``vehicle``: a registered vehicle kind's name; ``start`` (n, 2) initial positions; ``driver`` None: commanded
    onboard (the UAVs); ``altitude``: its heights in a 3-D world (:mod:`swarmtrack.sim.altitude_channel`). A
    kinematic vehicle also takes its ``params`` (e.g. ``WalkerParams``, ``FixedWingParams``) and initial ``heading``
    (n,); a kinematic group other than the UAVs draws its own inputs (stream ``walk/<group>/<member>``)."""

    name: str
    vehicle: str
    start: np.ndarray
    driver: ProfileDriver | None = None
    params: object = None
    heading: np.ndarray | None = None
    #: Its altitude channel in a 3-D world (:class:`~swarmtrack.vehicles.altitude.GroupAltitude`); None: planar.
    altitude: GroupAltitude | None = None

    @property
    def size(self) -> int:
        return len(self.start)


class _Uniforms:
    """A frame's uniforms in [0, 1) for every (UAV, sensed object) pair, (N, M, 2): each object's (N, 2) from its own
    stream, frame after frame. The streams draw ``block`` frames at a time (a generator's uniforms drawn together are
    the ones it draws one call after the other, so the frames are the same numbers), a buffer of at most 64 Ki
    numbers."""

    def __init__(self, rngs: list[np.random.Generator], n: int):
        self.rngs, self.n = rngs, n
        self.block = max(1, min(256, 65536 // max(1, 2 * n * len(rngs))))
        self._buf = np.empty((0, n, len(rngs), 2))
        self._next = 0

    def frame(self) -> np.ndarray:
        """The next frame's (N, M, 2) uniforms (a view of the buffer, never written again)."""
        if self._next == len(self._buf):
            self._buf = np.empty((self.block, self.n, len(self.rngs), 2))  # a new buffer: earlier frames stay valid
            for j, rng in enumerate(self.rngs):
                self._buf[:, :, j] = rng.random((self.block, self.n, 2))
            self._next = 0
        self._next += 1
        return self._buf[self._next - 1]


@dataclass
class _Kinematic:
    """A group of kinematic vehicles (``kind``): their full ``state`` (n, d), the ``command`` a commanded group holds
    (n, 1: a fixed wing's yaw acceleration), a driven group's input draws per tick (ticks, n: a walker's yaw
    accelerations). The objects are ``objects`` (a slice of the world's). ``compiled``: stepped by the module's
    ``step_compiled`` (the same numbers as its ``step``). The cosine and sine of the members' headings, which the
    step, the truth and the footprint sensor all read, are computed once per state (:meth:`trig`)."""

    name: str
    kind: Vehicle
    module: object
    params: object
    objects: slice
    state: np.ndarray
    command: np.ndarray
    draws: np.ndarray | None
    compiled: bool = False
    _trig: tuple[np.ndarray, np.ndarray] | None = None

    @classmethod
    def of(cls, g: Group, objects: slice, world_streams: list, worlds: int, ticks: int,
           compiled: bool = False) -> _Kinematic:
        kind = vehicle(g.vehicle)
        module = kind.module()
        heading = np.zeros(g.size) if g.heading is None else np.asarray(g.heading, dtype=float)
        state = module.initial_state(g.start, heading, g.params)
        draws = None
        if g.name != "uavs":  # a driven group draws its inputs; the swarm's come from onboard
            per = g.size // worlds
            draws = np.stack([module.draw_inputs(world_streams[k // per](f"walk/{g.name}/{k % per}"), ticks, 1,
                                                 g.params)[:, 0] for k in range(g.size)], axis=1) if g.size else \
                np.zeros((ticks, 0))
        return cls(g.name, kind, module, g.params, objects, state, np.zeros((g.size, kind.command_width)), draws,
                   compiled)

    def trig(self) -> tuple[np.ndarray, np.ndarray]:
        """``(cos, sin)`` (n,) of the members' headings in the current state (computed at the first call)."""
        if self._trig is None:
            heading = self.state[:, self.module.HEADING]
            self._trig = np.cos(heading), np.sin(heading)
        return self._trig

    def step(self, tick: int, dt: float) -> None:
        u = self.command if self.draws is None else self.draws[min(tick, len(self.draws) - 1)]
        step = self.module.step_compiled if self.compiled else self.module.step
        self.state = step(self.state, u, self.params, dt, trig=self.trig())
        self._trig = None

    def truth4(self) -> np.ndarray:
        return self.module.truth4(self.state, self.params, trig=self.trig())


class _KinematicPack:
    """A compiled world's kinematic groups stepped together (:func:`~swarmtrack.vehicles.kernels.kinematic_step`):
    their states are rows of one ``(K, 7)`` array (a walker's five columns, a fixed wing's seven), each group's
    ``state`` a view of its rows and its ``trig`` views of one cosine and one sine call (numpy's) over every row's
    heading and γ per tick. The same numbers as stepping each group by its module's ``step_compiled`` (the
    reference); a walker group that would cross a wall is stepped by its module's ``step``, as there."""

    def __init__(self, kins: list[_Kinematic], dt: float):
        self.kins, self.dt = kins, dt
        sizes = [len(k.state) for k in kins]
        self.bounds = np.cumsum([0, *sizes])
        k_total = int(self.bounds[-1])
        self.walker = np.array([k.kind.pack == "walker" for k in kins for _ in range(len(k.state))], dtype=bool)
        self.group = np.repeat(np.arange(len(kins)), sizes).astype(np.int64)
        self.speed = np.array([k.params.speed for k in kins for _ in range(len(k.state))], dtype=float)
        self.v_dt = np.array([dt * k.params.speed for k in kins for _ in range(len(k.state))], dtype=float)
        self.rate_max = np.array([0.0 if k.kind.pack == "walker" else k.params.yaw_rate_max
                                  for k in kins for _ in range(len(k.state))], dtype=float)
        self.area = np.array([k.params.area if k.kind.pack == "walker" else (0.0,) * 4
                              for k in kins for _ in range(len(k.state))], dtype=float).reshape(k_total, 4)
        self.objects = np.concatenate([np.arange(k.objects.start, k.objects.stop) for k in kins]).astype(np.int64)
        ticks = max((len(k.draws) for k in kins if k.draws is not None), default=1)
        self.draws = np.zeros((ticks, k_total))
        self.command = np.zeros(k_total)
        for k, a, b in zip(kins, self.bounds[:-1], self.bounds[1:], strict=True):
            if k.draws is not None:
                self.draws[:, a:b] = k.draws
            k.command = self.command[a:b].reshape(-1, 1)  # the world writes a group's command into the pack
        # each row's heading column, and then its γ column (a walker's is read but not used)
        self._angle_rows = np.tile(np.arange(k_total), 2)
        self._angle_cols = np.concatenate([[k.module.HEADING] * len(k.state) for k in kins]
                                          + [[fixed_wing.GAMMA] * k_total]).astype(np.int64)
        self._rows = list(zip(kins, self.bounds[:-1], self.bounds[1:], strict=True))  # each group's rows
        self._ok = np.ones(len(kins), dtype=bool)  # the groups the compiled pass stepped
        self.state = np.zeros((k_total, _PACK_WIDTH))
        for k, a, b in zip(kins, self.bounds[:-1], self.bounds[1:], strict=True):
            self.state[a:b, :k.state.shape[1]] = k.state
        self._share()

    def _share(self, angles: np.ndarray | None = None) -> None:
        """Numpy's cosine and sine of every row's heading and γ (``angles``, gathered here if not given), and each
        group's views of its rows."""
        k_total = len(self.state)
        if angles is None:
            angles = self.state[self._angle_rows, self._angle_cols]
        self._cos, self._sin = np.cos(angles), np.sin(angles)
        self.cos_h, self.sin_h = self._cos[:k_total], self._sin[:k_total]
        self.cos_g, self.sin_g = self._cos[k_total:], self._sin[k_total:]
        for k, a, b in self._rows:
            k.state = self.state[a:b, :k.module.STATE_DIM]
            k._trig = self.cos_h[a:b], self.sin_h[a:b]

    def step(self, tick: int) -> None:
        """One tick of every group (from tick ``tick``): a new state array, and new trig."""
        out = np.empty_like(self.state)
        angles = np.empty(2 * len(out))
        if _kernels.kinematic_step(self.state, (self.walker, self.v_dt, self.rate_max, self.area, self.group),
                                   (self.cos_h, self.sin_h, self.cos_g, self.sin_g), self.draws,
                                   min(tick, len(self.draws) - 1), self.command, self.dt, out, angles, self._ok):
            # a walker group with a member crossing a wall: its module's reference step
            for g in np.flatnonzero(~self._ok):
                k, a, b = self._rows[g]
                out[a:b, :k.module.STATE_DIM] = k.module.step(k.state, k.draws[min(tick, len(k.draws) - 1)],
                                                              k.params, self.dt, k.trig())
                out[a:b, k.module.STATE_DIM:] = 0.0
            angles = None
        self.state = out
        self._share(angles)

    def truth(self, truth: np.ndarray) -> None:
        """Every member's ``[x, y, vx, vy]`` (its module's ``truth4``) into its object's row of ``truth``."""
        _kernels.kinematic_truth(self.state, self.walker, self.speed, self.cos_h, self.sin_h, self.cos_g,
                                 self.objects, truth)


@dataclass
class _Layout:
    """Where each object lives: rows of the quadrotor and point-mass arrays, and its driver column."""

    quad_obj: list = field(default_factory=list)
    point_obj: list = field(default_factory=list)
    quad_driver: list = field(default_factory=list)
    point_driver: list = field(default_factory=list)


class World:
    """Truth of every group; :meth:`advance` integrates them together (one batched step per vehicle kind).

    ``streams(purpose)`` gives the random stream of each purpose. A sequence of B such functions makes the world a
    batch of B independent worlds of one layout (one seed each): every group holds B equal blocks of members, world
    b's block b; each world draws from its own streams exactly what it would draw alone, and its UAVs sense only its
    objects, so every world evolves as it would on its own (:mod:`swarmtrack.sim.batch`).
    """

    def __init__(self, groups: list[Group], sensor: Sensor, *, dt: float, ticks: int,
                 nav_std: tuple[float, float],
                 streams: Callable[[str], np.random.Generator] | Sequence[Callable[[str], np.random.Generator]],
                 compiled: bool = False):
        names = [g.name for g in groups]
        if "uavs" not in names or len(set(names)) != len(names):
            raise ValueError(f"groups must be uniquely named and include 'uavs'; got {names}")
        self.groups = {g.name: g for g in groups}
        self.dt, self.sensor, self.compiled = dt, sensor, compiled
        world_streams = list(streams) if isinstance(streams, Sequence) else [streams]
        self.worlds = len(world_streams)
        if any(g.size % self.worlds for g in groups):
            raise ValueError(f"a batch of {self.worlds} worlds needs every group's size divisible by it")
        # random streams by purpose (swarmtrack.sim.streams): each driven member's gusts have their own, so adding
        # a member or a group shifts no other draw
        self._nav_rngs = [s("navigation") for s in world_streams]
        self._nav_std = np.array([nav_std[0]] * 2 + [nav_std[1]] * 2)
        self._nav_noisy = bool(self._nav_std.any())
        # object index ranges of each group, in group order
        self.slices, start = {}, 0
        for g in groups:
            self.slices[g.name] = slice(start, start + g.size)
            start += g.size
        self.n_objects = start
        # each object's world and its member number within its world's block of its group
        self.world_of = np.concatenate([np.arange(g.size) // (g.size // self.worlds) for g in groups]
                                       or [np.zeros(0, np.int64)]).astype(np.int64)
        local = [(g.name, k % (g.size // self.worlds)) for g in groups for k in range(g.size)]
        # the objects the sensor sees, in label order (a cooperative sensor labels each by this index), each
        # with its own noise stream
        self._sensed = sensed_objects(self.slices, sensor.sensed)
        self._sensor_rngs = [world_streams[self.world_of[o]]("sensor/{}/{}/{}".format(sensor.name, *local[o]))
                             for o in self._sensed]
        # further noise of a sensor, each purpose its own stream per sensed object (extra_normal)
        self._extra_rngs = {}
        self._extra_stream = lambda purpose, o: world_streams[self.world_of[o]](
            "sensor/{}/{}/{}/{}".format(sensor.name, purpose, *local[o]))
        self._uav_stream = lambda purpose, i: world_streams[0](f"sensor/{sensor.name}/{purpose}/uavs/{i}")
        self._uniforms: _Uniforms | None = None  # their uniforms, for a sensor that takes them (frame_uniforms)
        # a batch: each world's UAV rows (contiguous) and its sensed objects' labels (B, M)
        n = self.groups["uavs"].size // self.worlds
        self._world_uavs = [slice(b * n, (b + 1) * n) for b in range(self.worlds)]
        sensed_world = self.world_of[self._sensed]
        self._world_labels = np.stack([np.flatnonzero(sensed_world == b) for b in range(self.worlds)])
        # physics layout and the drivers' profiles, gusts and gains sampled once for each of the run's ``ticks``
        ticks = ticks + 2
        grid = np.arange(ticks) * dt
        lay, v_cmd, a_ff, gains, winds = _Layout(), [], [], [], []
        self._kinematic: list[_Kinematic] = []
        kinds = {g.name: vehicle(g.vehicle) for g in groups}
        for g in groups:
            quad = kinds[g.name].physics == "quadrotor"  # else a double integrator (point mass) or kinematic
            if kinds[g.name].is_kinematic:
                self._kinematic.append(_Kinematic.of(g, self.slices[g.name], world_streams, self.worlds, ticks,
                                                     compiled))
                continue
            for k in range(g.size):
                obj = self.slices[g.name].start + k
                d = -1
                if g.driver is not None:
                    d = len(gains)
                    prof = g.driver.profiles[k]
                    v_cmd.append(prof.velocity(grid))
                    a_ff.append(prof.acceleration(grid))
                    gains.append(g.driver.gain)
                    b, kl = divmod(k, g.size // self.worlds)
                    winds.append(world_streams[b](f"wind/{g.name}/{kl}").standard_normal((ticks, 2))
                                 * g.driver.wind_std)
                (lay.quad_obj if quad else lay.point_obj).append(obj)
                (lay.quad_driver if quad else lay.point_driver).append(d)
        n_driven = len(gains)
        # profile phase of every driven object at every tick (the UAVs have none)
        self._driven = np.asarray([self.slices[g.name].start + k for g in groups if g.driver is not None
                                   for k in range(g.size)], dtype=np.int64)
        self._undriven = np.full(self.n_objects, -1, dtype=np.int16)  # phase_index's start: no phase
        self._phase = np.stack([p.phase_index(grid) for g in groups if g.driver is not None
                                for p in g.driver.profiles], axis=1).astype(np.int16) if n_driven else \
            np.zeros((ticks, 0), dtype=np.int16)
        self._v_cmd = np.stack(v_cmd, axis=1) if n_driven else np.zeros((ticks, 0, 2))
        self._a_ff = np.stack(a_ff, axis=1) if n_driven else np.zeros((ticks, 0, 2))
        self._wind = np.stack(winds, axis=1) if n_driven else np.zeros((ticks, 0, 2))
        self._gains = np.asarray(gains, dtype=float)
        self._quad_obj = np.asarray(lay.quad_obj, dtype=np.int64)
        # each quadrotor row's parameters: its group's (the swarm's `quadrotor` section), the defaults without
        self.params = quadrotor.per_row([g.params for g in groups if kinds[g.name].physics == "quadrotor"
                                         for _ in range(g.size)])
        self._point_obj = np.asarray(lay.point_obj, dtype=np.int64)
        self._quad_driver = np.asarray(lay.quad_driver, dtype=np.int64)
        self._point_driver = np.asarray(lay.point_driver, dtype=np.int64)
        starts = np.concatenate([np.asarray(g.start, dtype=float).reshape(-1, 2) for g in groups])
        self._quads = np.asarray(quadrotor.hover_state(starts[self._quad_obj]), order="F")
        self._points = np.zeros((len(self._point_obj), 4))
        self._points[:, :2] = starts[self._point_obj]
        self._quad_cmd = np.zeros((len(self._quad_obj), 2))
        self._point_cmd = np.zeros((len(self._point_obj), 2))
        # each object's row in the stacked [quadrotors; points] truth, and the commanded (UAV) rows
        self._row = np.empty(self.n_objects, dtype=np.int64)
        self._row[self._quad_obj] = np.arange(len(self._quad_obj))
        self._row[self._point_obj] = len(self._quad_obj) + np.arange(len(self._point_obj))
        first = len(self._quad_obj) + len(self._point_obj)
        for kin in self._kinematic:
            self._row[kin.objects] = first + np.arange(kin.objects.stop - kin.objects.start)
            first += kin.objects.stop - kin.objects.start
        self._kinematic_of = {kin.name: kin for kin in self._kinematic}
        # a compiled world steps its built-in kinematic groups together (their kind's ``pack``), any other kinematic
        # group by its own module
        packed = [kin for kin in self._kinematic if compiled and kin.kind.pack is not None]
        self._loose = [kin for kin in self._kinematic if not (compiled and kin.kind.pack is not None)]
        self._pack = _KinematicPack(packed, dt) if packed else None
        self._physics = bool(len(self._quad_obj) or len(self._point_obj))  # any vehicle the kernel steps
        # ring buffer of past positions, for measurements that arrive `latency` late
        lag = int(round(sensor.latency / dt))
        self._history = np.repeat(starts[None], lag + 1, axis=0)
        # a 3-D world: every object's altitude, stepped beside the physics, and the UAVs' navigation heights' noise
        self._altitude = AltitudeChannel(groups, self.slices, self.n_objects, grid, lag) \
            if sensor.three_d or any(g.altitude is not None for g in groups) else None
        self._nav_z_rngs = [s("navigation/altitude") for s in world_streams] if self._altitude is not None else []
        # where each group's commands go: a group is one vehicle kind, laid out contiguously in that kind's rows
        self._cmd_rows = {}
        for g in groups:
            if kinds[g.name].is_kinematic:
                continue
            quad = kinds[g.name].physics == "quadrotor"
            rows = self._row[self.slices[g.name]]
            if not quad:
                rows = rows - len(self._quad_obj)
            target = self._quad_cmd if quad else self._point_cmd
            self._cmd_rows[g.name] = (target, slice(rows[0], rows[-1] + 1) if len(rows) else slice(0, 0))
        self._truth_at = -1  # tick of the cached truth
        self._tick = 0
        if compiled:
            from swarmtrack.vehicles import kernels

            self._kernel = kernels.advance
            self._kernel_consts = kernels.params_tuple(self.params)

    @property
    def t(self) -> float:
        """Simulated time, s."""
        return self._tick * self.dt

    @property
    def three_d(self) -> bool:
        """Whether the world has an altitude channel (:meth:`altitude`)."""
        return self._altitude is not None

    @property
    def aims(self) -> bool:
        """Whether the sensor is gimballed (:meth:`sense` reads its ``aim``)."""
        return self.sensor.aims

    # --- truth, for the engine's recorder and the metrics only -------------------------------------------
    def _all_truth(self) -> np.ndarray:
        if self._truth_at != self._tick:  # gathered once per tick (the arrays only change in advance())
            truth = np.empty((self.n_objects, 4))
            if self._physics:
                truth[self._quad_obj] = self._quads[:, :4]
                truth[self._point_obj] = self._points
            if self._pack is not None:
                self._pack.truth(truth)
            for kin in self._loose:
                truth[kin.objects] = kin.truth4()
            self._truth = truth
            self._truth_at = self._tick
        return self._truth

    def truth(self, group: str | None = None) -> np.ndarray:
        """(n, 4) ``[x, y, vx, vy]`` of a group's members (a copy), or of every object with ``group=None``."""
        truth = self._all_truth()
        return truth.copy() if group is None else truth[self.slices[group]].copy()

    def recorded_truth(self, truth: np.ndarray | None = None) -> np.ndarray:
        """What the recorder keeps of every object: its ``[x, y, vx, vy]`` (``truth``, this tick's :meth:`truth` if
        not given), and in a 3-D world ``[z, vz]`` after them (M, 6)."""
        truth = self._all_truth() if truth is None else truth
        return truth if self._altitude is None else np.concatenate([truth, self._altitude.truth()], axis=1)

    def altitude(self, group: str | None = None) -> np.ndarray:
        """(n, 2) ``[z, vz]`` of a group's members, or of every object with ``group=None`` (a 3-D world only)."""
        alt = self._altitude.truth()
        return alt if group is None else alt[self.slices[group]]

    def phase_index(self) -> np.ndarray:
        """(n_objects,) index of the profile phase each driven object flies now (−1: not driven)."""
        out = self._undriven.copy()
        if len(self._driven):
            out[self._driven] = self._phase[min(self._tick, len(self._phase) - 1)]
        return out

    def label_of(self, obj: int) -> int | None:
        """The label the sensor reports for world object ``obj`` (None: the sensor does not see it)."""
        at = np.flatnonzero(self._sensed == obj)
        return int(at[0]) if len(at) else None

    # --- what each UAV's own devices report ----------------------------------------------------------
    def navigation(self) -> np.ndarray:
        """Each UAV's own navigation solution (N, 4): truth plus white noise (the ``navigation`` stream)."""
        nav = self.truth("uavs")
        if self._nav_noisy:
            nav += self._draw(self._nav_rngs, nav.shape[1]) * self._nav_std
        kin = self.kinematic("uavs")
        return nav if kin is None else np.concatenate([nav, kin.state], axis=1)

    def kinematic(self, group: str) -> _Kinematic | None:
        """The kinematic vehicles of ``group`` (their full states), or None for a group of other vehicles. A UAV's
        navigation solution carries its full state after ``[x, y, vx, vy]`` (its autopilot knows it)."""
        return self._kinematic_of.get(group)

    def frame_uniforms(self) -> np.ndarray:
        """(N, M, 2) uniforms in [0, 1) of this sensing frame for every (UAV, sensed object) pair, each object's
        (N, 2) from its own stream (``sensor/<kind>/<group>/<member>``; a footprint sensor's box noise)."""
        if self._uniforms is None:
            self._uniforms = _Uniforms(self._sensor_rngs, self.groups["uavs"].size)
        return self._uniforms.frame()

    def _draw(self, rngs, width: int) -> np.ndarray:
        """(N, width) standard normal draws, each world's UAV rows from its own stream (one draw when alone)."""
        n = self._world_uavs[0].stop
        if self.worlds == 1:
            return rngs[0].standard_normal((n, width))
        return np.concatenate([rng.standard_normal((n, width)) for rng in rngs])

    def sense(self, aim: np.ndarray | None = None):
        """Every UAV's detections, ``sensor.latency`` old, and (for the recorder and metrics only) the object
        each came from: what the sensor (:class:`~swarmtrack.sim.sensors.Sensor`) reports of this frame's
        :class:`~swarmtrack.sim.sensors.Scene`. ``aim`` (N, 2): where each UAV points a gimballed sensor (its latest
        estimate; NaN rows: none yet); others ignore it."""
        det, source = self.sensor.sense(Scene(self, aim))
        came = np.full(len(source), -1, dtype=np.int64)  # −1: a false detection (clutter), from no object
        real = source >= 0
        came[real] = self._sensed[source[real]]
        return det, came

    def lagged_positions(self) -> tuple[np.ndarray, float]:
        """Every object's position ``sensor.latency`` ago (M, 2) and the time it was taken (a ring buffer)."""
        if len(self._history) == 1:
            return self._all_truth()[:, :2], self.t
        taken = (self._tick - (len(self._history) - 1)) * self.dt
        return self._history[(self._tick + 1) % len(self._history)], taken

    def lagged_heights(self) -> np.ndarray:
        """Every object's height ``sensor.latency`` ago (M,), with :meth:`lagged_positions` (a 3-D world)."""
        return self._altitude.lagged(self._tick)

    def stamped_heights(self, heights: np.ndarray) -> np.ndarray:
        """The navigation heights a 3-D sensor stamps on its detections: ``heights`` (N,) plus their navigation error
        (σ of the navigation position, from the ``navigation/altitude`` stream: the planar draws are left as
        they are)."""
        stamped = heights.copy()
        if self._nav_std[0] > 0:
            stamped += self._draw(self._nav_z_rngs, 1)[:, 0] * self._nav_std[0]
        return stamped

    def stamped(self, uavs: np.ndarray) -> np.ndarray:
        """The navigation positions a sensor stamps on its detections: ``uavs`` (N, 2) plus their own navigation
        error (the ``navigation`` stream)."""
        stamped = uavs.copy()
        if self._nav_std[0] > 0:
            stamped += self._draw(self._nav_rngs, 2) * self._nav_std[0]
        return stamped

    def normal_noise(self) -> np.ndarray:
        """(N, M, 2) standard normal draws of this frame, each sensed object's (N, 2) from its own stream (a batch:
        (B, n, M_b, 2), each world's UAVs towards its own objects)."""
        if self.worlds > 1:
            labels, n = self._world_labels, self._world_uavs[0].stop
            noise = np.empty((self.worlds, n, labels.shape[1], 2))
            for b, row in enumerate(labels):
                for j, label in enumerate(row):
                    noise[b, :, j] = self._sensor_rngs[label].standard_normal((n, 2))
            return noise
        n = self.groups["uavs"].size
        noise = np.empty((n, len(self._sensed), 2))
        for j, rng in enumerate(self._sensor_rngs):
            noise[:, j] = rng.standard_normal((n, 2))
        return noise

    def extra_uniform(self, purpose: str) -> np.ndarray:
        """(N, M) uniform draws in [0, 1) of this frame for a sensor's ``purpose`` (its misses), each sensed object's
        (N,) from its own stream ``sensor/<name>/<purpose>/<group>/<member>``. One world at a time."""
        return self._extra(purpose, lambda rng, n: rng.random(n))

    def uav_streams(self, purpose: str) -> list:
        """Each UAV's stream for a sensor's ``purpose`` (its clutter): ``sensor/<name>/<purpose>/uavs/<i>``. One world
        at a time."""
        key = ("uavs", purpose)
        if key not in self._extra_rngs:
            self._extra_rngs[key] = [self._uav_stream(purpose, i) for i in range(self.groups["uavs"].size)]
        return self._extra_rngs[key]

    def extra_normal(self, purpose: str) -> np.ndarray:
        """(N, M) standard normal draws of this frame for a sensor's further noise ``purpose`` (the 3-D sensor's
        elevation), each sensed object's (N,) from its own stream ``sensor/<name>/<purpose>/<group>/<member>``: the
        draws of :meth:`normal_noise` are left as they are. One world at a time."""
        return self._extra(purpose, lambda rng, n: rng.standard_normal(n))

    def _extra(self, purpose: str, draw) -> np.ndarray:
        """(N, M): ``draw(rng, N)`` from each sensed object's stream for ``purpose``, made when first asked for."""
        if purpose not in self._extra_rngs:
            self._extra_rngs[purpose] = [self._extra_stream(purpose, o) for o in self._sensed]
        n = self.groups["uavs"].size
        out = np.empty((n, len(self._sensed)))
        for j, rng in enumerate(self._extra_rngs[purpose]):
            out[:, j] = draw(rng, n)
        return out

    # --- physics -----------------------------------------------------------------------------------------
    def advance(self, commands: dict[str, np.ndarray], ticks: int) -> None:
        """Advance the truth by ``ticks`` physics steps, each commanded group's accelerations (n, 2) held.

        The same as ``ticks`` calls of :meth:`step` (the reference); with ``compiled`` one call of the numba
        kernel :func:`swarmtrack.vehicles.kernels.advance`, which gives the same numbers to a few ulps.
        """
        for name, u in commands.items():
            kin = self.kinematic(name)
            if kin is not None:
                kin.command[:] = np.asarray(u, dtype=float).reshape(kin.command.shape)
                continue
            target, rows = self._cmd_rows[name]
            target[rows] = u
        if not self.compiled:
            for _ in range(ticks):
                self.step()
            return
        start = self._tick
        if self._physics:
            self._kernel((self._quads, self._quad_cmd, self._quad_driver, self._quad_obj),
                         (self._points, self._point_cmd, self._point_driver, self._point_obj),
                         (self._v_cmd, self._a_ff, self._wind, self._gains), self._tick, ticks, self.dt,
                         self._kernel_consts, self._history)
        for tick in range(start, start + ticks):
            self._step_beside(tick)
        self._tick += ticks

    def _step_beside(self, tick: int) -> None:
        """One tick (from tick ``tick``) of what the physics kernel does not step: every kinematic group (their
        positions into the latency buffer) and a 3-D world's altitude channel."""
        if self._altitude is not None:
            self._altitude.step(tick, self.dt)
        if self._pack is not None:
            self._pack.step(tick)
        for kin in self._loose:
            kin.step(tick, self.dt)
        if len(self._history) > 1:
            for kin in self._kinematic:
                self._history[(tick + 1) % len(self._history)][kin.objects] = kin.state[:, :2]

    def _accel(self, cmd: np.ndarray, driver: np.ndarray, velocity: np.ndarray) -> np.ndarray:
        """Commanded rows keep their command; driven rows fly their profile (feed-forward + P) plus the gust."""
        k, driven = self._tick, driver >= 0
        if not driven.any():
            return cmd
        a = cmd.copy()
        d = driver[driven]
        a[driven] = quadrotor.velocity_tracking_accel(self._v_cmd[k, d], velocity[driven], self._a_ff[k, d],
                                                      self._gains[d, None]) + self._wind[k, d]
        return a

    def step(self) -> None:
        """Advance the truth by one physics step (the numpy reference of the compiled kernel)."""
        self._step_beside(self._tick)
        if len(self._quad_obj):
            a = self._accel(self._quad_cmd, self._quad_driver, self._quads[:, 2:4])
            self._quads = quadrotor.step(self._quads, a, self.params, self.dt)
        if len(self._point_obj):
            a = self._accel(self._point_cmd, self._point_driver, self._points[:, 2:4])
            self._points = double_integrator.step(self._points, a, self.dt)
        self._tick += 1
        if len(self._history) > 1:
            slot = self._history[self._tick % len(self._history)]
            slot[self._quad_obj] = self._quads[:, :2]
            slot[self._point_obj] = self._points[:, :2]
