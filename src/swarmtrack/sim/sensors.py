"""The truth side of the sensors: what the world needs of a sensor, and the three the papers fly.

A :class:`Sensor` says which groups it sees (in label order: a cooperative sensor labels each object by its place
in that list), how old its reports are, whether it is gimballed (reads an aim), and senses a frame's
:class:`Scene`: the truth it may read (positions ``latency`` old, the kinematic vehicles' full states), the
navigation positions the UAVs stamp on their detections, and its noise, drawn from each sensed object's own stream
(``sensor/<name>/<group>/<member>``) as normal or uniform numbers. It returns every UAV's
:class:`~swarmtrack.sensors.detections.Detections` and, for the truth side only, which sensed object each came
from. The world builds the scene; onboard code never sees either.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from swarmtrack.sensors import camera, clutter, elevation_bearing_range, footprint, position, range_bearing
from swarmtrack.sensors.detections import Detections
from swarmtrack.vehicles import fixed_wing, ground_walker

if TYPE_CHECKING:
    from swarmtrack.sim.world import World


class Scene:
    """One sensing frame as a sensor may read it. ``objects`` (M, 2) and ``uavs`` (N, 2): the sensed objects' and
    the UAVs' true positions at ``taken`` (``latency`` before ``t``); ``aim`` (N, 2) or None: where each UAV points a
    gimballed sensor. The draws are made when asked for, each from its own streams, so a sensor draws only what it
    uses."""

    __slots__ = ("_world", "aim", "t", "worlds", "_lagged", "_heights", "_stamped")

    def __init__(self, world: World, aim: np.ndarray | None):
        self._world, self.aim, self.t, self.worlds = world, aim, world.t, world.worlds
        self._lagged = None
        self._heights = None
        self._stamped: np.ndarray | None = None

    def _positions(self) -> tuple[np.ndarray, float]:
        if self._lagged is None:  # read when a sensor asks (the footprint sensor reads full states instead)
            self._lagged = self._world.lagged_positions()
        return self._lagged

    @property
    def taken(self) -> float:
        return self._positions()[1]

    @property
    def uavs(self) -> np.ndarray:
        return self._positions()[0][self._world.slices["uavs"]]

    @property
    def objects(self) -> np.ndarray:
        return self._positions()[0][self._world._sensed]

    def stamped(self) -> np.ndarray:
        """(N, 2) the navigation positions stamped on the detections: ``uavs`` with their own navigation error, drawn
        once per frame (a frame's true and false detections carry the same stamp)."""
        if self._stamped is None:
            self._stamped = self._world.stamped(self.uavs)
        return self._stamped

    def _lagged_heights(self) -> np.ndarray:
        if self._heights is None:
            self._heights = self._world.lagged_heights()
        return self._heights

    @property
    def uav_heights(self) -> np.ndarray:
        """(N,) the UAVs' true heights at ``taken`` (a 3-D world)."""
        return self._lagged_heights()[self._world.slices["uavs"]]

    @property
    def object_heights(self) -> np.ndarray:
        """(M,) the sensed objects' true heights at ``taken`` (a 3-D world)."""
        return self._lagged_heights()[self._world._sensed]

    def stamped_heights(self) -> np.ndarray:
        """(N,) the navigation heights stamped on a 3-D sensor's detections."""
        return self._world.stamped_heights(self.uav_heights)

    def normal(self) -> np.ndarray:
        """(N, M, 2) standard normal noise of every (UAV, sensed object) pair (a batch: (B, n, M_b, 2))."""
        return self._world.normal_noise()

    def extra_normal(self, purpose: str) -> np.ndarray:
        """(N, M) standard normal noise of every pair for a further ``purpose``, from its own streams."""
        return self._world.extra_normal(purpose)

    def extra_uniform(self, purpose: str) -> np.ndarray:
        """(N, M) uniform draws in [0, 1) of every pair for a further ``purpose`` (misses), from its own streams."""
        return self._world.extra_uniform(purpose)

    def uav_streams(self, purpose: str) -> list:
        """Each UAV's own stream for ``purpose`` (its clutter)."""
        return self._world.uav_streams(purpose)

    def uniforms(self) -> np.ndarray:
        """(N, M, 2) uniform noise in [0, 1) of every (UAV, sensed object) pair."""
        return self._world.frame_uniforms()

    def kinematic(self, group: str):
        """The kinematic vehicles of ``group`` (full states, e.g. a fixed wing's heading), or None."""
        return self._world.kinematic(group)

    def world_labels(self) -> np.ndarray:
        """(B, M_b) a batch's sensed objects per world, as labels."""
        return self._world._world_labels


class Sensor:
    """The truth side of a sensor (a base class with the defaults; :meth:`sense` is what a sensor implements)."""

    #: Its noise streams' name: ``sensor/<name>/<group>/<member>``.
    name: ClassVar[str] = "sensor"
    #: Whether :meth:`sense` reads the scene's ``aim`` (a gimballed sensor; the estimates are then computed for it).
    aims: ClassVar[bool] = False
    #: Whether it reads the heights (the world then has an altitude channel, every object at z = 0 by default).
    three_d: ClassVar[bool] = False
    #: The groups it senses, in label order.
    sensed: tuple[str, ...] = ("targets", "decoys")
    #: Age of its reports, s (the world keeps that much history of the truth).
    latency: float = 0.0
    #: What hides objects from some UAVs (:class:`Occluder`).
    occluders: tuple = ()

    def sense(self, scene: Scene) -> tuple[Detections, np.ndarray]:
        """Every UAV's detections of this frame and, per detection, the index in the sensed list of the object it
        came from (truth side only)."""
        raise NotImplementedError


def missed_and_fooled(scene: Scene, det: Detections, source: np.ndarray, pd, false,
                      stamped: np.ndarray) -> tuple[Detections, np.ndarray]:
    """Issue 40's misses and clutter on a frame's detections (:mod:`swarmtrack.sensors.clutter`), each drawn from
    the scene's streams of its own only when asked, so that a sensor without them draws nothing more: each detection
    kept with probability ``pd(rel)`` at its object's true planar position relative to its UAV (None: every one
    kept); the false detections ``false(rngs) → (counts, z)`` from each UAV's own stream (None: none), stamped
    ``stamped``."""
    if pd is not None:
        rel = scene.objects[source] - scene.uavs[det.owner]
        det, source = clutter.thin(det, source, scene.extra_uniform("detection"), pd(rel))
    if false is not None:
        counts, z = false(scene.uav_streams("clutter"))
        det, source = clutter.add_clutter(det, source, counts, z, stamped)
    return det, source


@dataclass(frozen=True)
class RangeBearingSensor(Sensor):
    """Truth side of the range-bearing sensor (L24 Sec. 3.2): every UAV measures every object of the ``sensed``
    groups (within ``max_range``), ``latency`` s late; the noise of the detections of each object comes from
    that object's stream (``sensor/range_bearing/<group>/<member>``)."""

    sigma_range: float
    sigma_bearing: float
    max_range: float | None = None
    latency: float = 0.0
    occluders: tuple[Occluder, ...] = ()
    sensed: tuple[str, ...] = ("targets", "decoys")
    #: Issue 40's misses and clutter (:mod:`swarmtrack.sensors.clutter`): each object in view detected with this
    #: probability (draws: ``sensor/range_bearing/detection/<group>/<member>``), and a Poisson number of false
    #: detections a scan over the disk of ``max_range`` (draws: ``sensor/range_bearing/clutter/uavs/<i>``).
    detection_probability: float = 1.0
    clutter_rate: float = 0.0
    #: False: its detections carry no label (a sensor that cannot tell the objects apart; issue 40).
    labelled: bool = True
    #: The detection probability falls linearly with the range, to ``detection_probability · (1 − falloff)`` at
    #: ``max_range`` (:func:`~swarmtrack.sensors.clutter.disk_detection_probability`).
    detection_falloff: float = 0.0
    name: ClassVar[str] = "range_bearing"

    def sense(self, scene: Scene) -> tuple[Detections, np.ndarray]:
        det, source = self._sense(scene)
        if not self.labelled:
            det = clutter.unlabelled(det)
        pd = None if self.detection_probability == 1.0 and self.detection_falloff == 0.0 else \
            functools.partial(clutter.disk_detection_probability, probability=self.detection_probability,
                              falloff=self.detection_falloff, max_range=self.max_range)
        false = None if self.clutter_rate == 0.0 else \
            functools.partial(clutter.polar_clutter, rate=self.clutter_rate, max_range=self.max_range)
        return missed_and_fooled(scene, det, source, pd, false, scene.stamped())

    def _sense(self, scene: Scene) -> tuple[Detections, np.ndarray]:
        objects, uavs = scene.objects, scene.uavs
        stamped, noise = scene.stamped(), scene.normal()
        if scene.worlds > 1:  # each world's UAVs towards its own objects (no occluders: they name one world's UAVs)
            labels = scene.world_labels()
            n = len(uavs) // scene.worlds
            return range_bearing.sense_worlds(objects[labels], uavs.reshape(scene.worlds, n, 2),
                                              stamped.reshape(scene.worlds, n, 2), self.sigma_range,
                                              self.sigma_bearing, noise, labels, self.max_range, scene.taken)
        hidden = hidden_by(self.occluders, objects, len(uavs), scene.t)
        return range_bearing.sense(objects, uavs, stamped, self.sigma_range, self.sigma_bearing, noise,
                                   self.max_range, hidden, scene.taken)


@dataclass(frozen=True)
class PositionSensor(Sensor):
    """Truth side of the planar position sensor (:mod:`swarmtrack.sensors.position`, issue 40): every UAV measures
    the relative position of every object of the ``sensed`` groups in its square footprint (half-width
    ``half_width``; None: everywhere), unlabelled, ``latency`` s late, each detected with ``detection_probability``
    (draws ``sensor/position/detection/<group>/<member>``), plus a Poisson number ``clutter_rate`` of false
    detections a scan uniform over the footprint (draws ``sensor/position/clutter/uavs/<i>``); the noise of each
    object's detections comes from its stream ``sensor/position/<group>/<member>``. ``detection_falloff``: the
    detection probability falls with the distance to the footprint's edge."""

    sigma: float
    half_width: float | None = None
    latency: float = 0.0
    occluders: tuple[Occluder, ...] = ()
    sensed: tuple[str, ...] = ("targets", "decoys")
    detection_probability: float = 1.0
    clutter_rate: float = 0.0
    #: The detection probability falls linearly with the Chebyshev distance, to ``detection_probability · (1 −
    #: falloff)`` at the footprint's edge (:func:`~swarmtrack.sensors.clutter.square_detection_probability`).
    detection_falloff: float = 0.0
    name: ClassVar[str] = "position"

    def sense(self, scene: Scene) -> tuple[Detections, np.ndarray]:
        objects, uavs = scene.objects, scene.uavs
        hidden = hidden_by(self.occluders, objects, len(uavs), scene.t)
        det, source = position.sense(objects, uavs, scene.stamped(), self.sigma, scene.normal(), self.half_width,
                                     hidden, scene.taken)
        pd = None if self.detection_probability == 1.0 and self.detection_falloff == 0.0 else \
            functools.partial(clutter.square_detection_probability, probability=self.detection_probability,
                              falloff=self.detection_falloff, half_width=self.half_width)
        false = None if self.clutter_rate == 0.0 else \
            functools.partial(clutter.square_clutter, rate=self.clutter_rate, half_width=self.half_width)
        return missed_and_fooled(scene, det, source, pd, false, scene.stamped())


@dataclass(frozen=True)
class RangeBearingElevationSensor(Sensor):
    """Truth side of the range-bearing-elevation sensor (:mod:`swarmtrack.sensors.elevation_bearing_range`, issue
    28): the range-bearing sensor of L24 Sec. 3.2 in a 3-D world, with the elevation angle; every UAV measures
    every object of the ``sensed`` groups within ``max_range`` (3-D distance), ``latency`` s late. The range and
    bearing noise comes from the planar sensor's streams (``sensor/range_bearing/<group>/<member>``), the
    elevation's from ``sensor/range_bearing/elevation/<group>/<member>``: a target level with its UAVs gives the
    planar sensor's measurements, and a 3-D run of a planar scene the planar run's numbers. Misses and clutter as
    the planar sensor's (issue 40): each object in view detected with ``detection_probability`` (draws
    ``sensor/range_bearing/detection/<group>/<member>``), a Poisson number ``clutter_rate`` of false detections a
    scan uniform over the ball of ``max_range`` (draws ``sensor/range_bearing/clutter/uavs/<i>``), unlabelled;
    ``labelled`` false: no detection carries a label. One world at a time."""

    sigma_range: float
    sigma_bearing: float
    sigma_elevation: float
    max_range: float | None = None
    latency: float = 0.0
    sensed: tuple[str, ...] = ("targets", "decoys")
    detection_probability: float = 1.0
    clutter_rate: float = 0.0
    labelled: bool = True
    name: ClassVar[str] = "range_bearing"  # its streams: the planar sensor's, and the elevation's
    three_d: ClassVar[bool] = True

    def sense(self, scene: Scene) -> tuple[Detections, np.ndarray]:
        objects = np.column_stack([scene.objects, scene.object_heights])
        uavs = np.column_stack([scene.uavs, scene.uav_heights])
        stamped = np.column_stack([scene.stamped(), scene.stamped_heights()])
        noise = np.concatenate([scene.normal(), scene.extra_normal("elevation")[..., None]], axis=-1)
        det, source = elevation_bearing_range.sense(objects, uavs, stamped, self.sigma_range, self.sigma_bearing,
                                                    self.sigma_elevation, noise, self.max_range, scene.taken)
        if not self.labelled:
            det = clutter.unlabelled(det)
        probability = self.detection_probability
        pd = None if probability == 1.0 else lambda rel: np.full(len(rel), probability)
        false = None if self.clutter_rate == 0.0 else \
            functools.partial(clutter.ball_clutter, rate=self.clutter_rate, max_range=self.max_range)
        return missed_and_fooled(scene, det, source, pd, false, stamped)


@dataclass(frozen=True)
class Occluder:
    """Hides the sensed objects from the UAVs ``uavs`` (0-based; empty: every UAV) while an object is inside
    ``region`` ``(x0, y0, x1, y1)`` (None: anywhere) during ``window`` ``(t0, t1)`` s (None: always)."""

    region: tuple[float, float, float, float] | None = None
    window: tuple[float, float] | None = None
    uavs: tuple[int, ...] = ()

    def hides(self, objects: np.ndarray, n_uavs: int, t: float) -> np.ndarray:
        """(N, M) the (UAV, object) pairs this occluder hides at time ``t``."""
        hidden = np.ones((n_uavs, len(objects)), dtype=bool)
        if self.window is not None and not self.window[0] <= t < self.window[1]:
            return ~hidden
        if self.region is not None:
            x0, y0, x1, y1 = self.region
            inside = (objects[:, 0] >= x0) & (objects[:, 0] <= x1) & (objects[:, 1] >= y0) & (objects[:, 1] <= y1)
            hidden &= inside[None, :]
        if self.uavs:
            mask = np.zeros(n_uavs, dtype=bool)
            mask[list(self.uavs)] = True
            hidden &= mask[:, None]
        return hidden


def hidden_by(occluders, objects: np.ndarray, n_uavs: int, t: float) -> np.ndarray | None:
    """(N, M) the (UAV, object) pairs any of ``occluders`` hides at time ``t``; None without occluders."""
    hidden = None
    for occ in occluders:
        h = occ.hides(objects, n_uavs, t)
        hidden = h if hidden is None else hidden | h
    return hidden


@dataclass(frozen=True)
class CameraSensor(Sensor):
    """Truth side of the gimballed camera-frame position sensor (W20 Sec. 3.2, eqs. 4.14-4.16,
    :mod:`swarmtrack.sensors.camera`): cameras ``height`` m above the ground, a rectangular field of view with
    half-angle tangents ``tan_half``, noise ``sigma`` m per camera-frame axis, gimbals aimed at each UAV's latest
    estimate (``home`` before it has one), ``occluders`` hiding objects; streams ``sensor/camera/<group>/<k>``."""

    sigma: float
    height: float
    tan_half: tuple[float, float]
    home: tuple[float, float] = (0.0, 0.0)
    occluders: tuple[Occluder, ...] = ()
    latency: float = 0.0
    sensed: tuple[str, ...] = ("targets", "decoys")
    name: ClassVar[str] = "camera"
    aims: ClassVar[bool] = True

    def sense(self, scene: Scene) -> tuple[Detections, np.ndarray]:
        objects, uavs = scene.objects, scene.uavs
        n = len(uavs)
        stamped, noise = scene.stamped(), scene.normal()
        aim = np.broadcast_to(self.home, (n, 2)) if scene.aim is None else np.asarray(scene.aim, dtype=float)
        aim = np.where(np.isfinite(aim).all(axis=-1, keepdims=True), aim, self.home)  # no estimate yet: home
        if scene.worlds > 1:  # each world's cameras towards its own objects (no occluders in a batch)
            labels, b = scene.world_labels(), scene.worlds
            return camera.sense_worlds(objects[labels], uavs.reshape(b, n // b, 2), stamped.reshape(b, n // b, 2),
                                       self.height, aim.reshape(b, n // b, 2), self.tan_half, self.sigma, noise,
                                       labels, scene.taken)
        hidden = hidden_by(self.occluders, objects, n, scene.t)
        return camera.sense(objects, uavs, stamped, self.height, aim, self.tan_half, self.sigma, noise, hidden,
                            scene.taken)


@dataclass(frozen=True)
class FootprintSensor(Sensor):
    """Truth side of IB21's downward camera (Sec. 3.2, Sec. 6, eqs. 50-54; :mod:`swarmtrack.sensors.footprint`):
    every target and decoy (walkers) inside a fixed-wing UAV's footprint is detected with box noise (uniform draws
    from the object's stream ``sensor/footprint/<group>/<k>``) and labelled by the identification cones. ``beta`` and
    ``gamma`` are each sensed object's cone angles, ``is_decoy`` which are decoys, ``J`` the decoys' confusion map
    (drawn and built by :mod:`swarmtrack.sim.build`). What of these the sensor reads every frame is derived once
    (``constants``, :class:`~swarmtrack.sensors.footprint.ObjectConstants`)."""

    params: object
    beta: np.ndarray
    gamma: np.ndarray
    is_decoy: np.ndarray
    J: np.ndarray
    latency: float = 0.0
    occluders: tuple = ()
    sensed: tuple[str, ...] = ("targets", "decoys")
    constants: object = field(init=False, repr=False, compare=False)
    name: ClassVar[str] = "footprint"

    def __post_init__(self) -> None:
        object.__setattr__(self, "constants", footprint.ObjectConstants.of(self.params, self.is_decoy, self.beta,
                                                                         self.gamma, self.J))

    def sense(self, scene: Scene) -> tuple[Detections, np.ndarray]:
        """From the full states: the fixed wings' positions, altitudes and headings, the walkers' headings."""
        uavs = scene.kinematic("uavs")
        objects = np.concatenate([scene.kinematic(g).state for g in self.sensed if scene.kinematic(g) is not None])
        if not len(objects):  # nothing to detect: sense's reference pass (the compiled one needs objects)
            return footprint.sense(uavs.state[:, fixed_wing.X:fixed_wing.Z + 1], uavs.state[:, fixed_wing.PSI],
                                   objects[:, :2], objects[:, ground_walker.HEADING], self.is_decoy, self.beta,
                                   self.gamma, scene.uniforms(), self.params, self.J)
        return footprint.sense_frame(uavs.state[:, fixed_wing.X:fixed_wing.Z + 1], uavs.state[:, fixed_wing.PSI],
                                     objects[:, :2], objects[:, ground_walker.HEADING], scene.uniforms(),
                                     self.params, self.constants, uav_trig=uavs.trig())


