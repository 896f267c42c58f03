"""W20 Ch. 4's camera with the error sources of the thesis' hardware (issue 27; W20 Secs. 3.1-3.3, 4.6.1).

The ideal camera (:class:`~swarmtrack.sim.sensors.CameraSensor`) points exactly where its UAV commands and knows
where it is. The thesis' cameras hung on a two-servo pan-tilt unit whose translations to the body were measured by
hand (Sec. 3.3): :class:`ImperfectCamera` adds the servos' dead band and speed (their angles lag and hold, the UAV
stamps the commanded ones), each servo's zero offset and the camera's gimbal-to-body translation error (constants per
UAV, drawn once), and a marker detector whose noise grows with distance and view angle
(:func:`swarmtrack.sensors.camera.marker_sigma`). The frame's age is the sensor's ``latency``; the Optitrack noise
(``swarm.nav_position_std``) and the Wi-Fi delay (``network.delay``) are the world's and the channel's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from swarmtrack.capabilities.multi_model import camera_kernels
from swarmtrack.sensors import camera
from swarmtrack.sensors.detections import Detections
from swarmtrack.sim.sensors import CameraSensor, Scene, hidden_by


@dataclass(frozen=True)
class Budget:
    """The hardware's error sources (SI units: m, rad, rad/s)."""

    reference_range: float = 1.5  #: m, where the marker noise is ``sigma`` seen head on
    distance_power: float = 0.0  #: marker noise ∝ (d / reference_range)^power
    angle_power: float = 0.0  #: marker noise ∝ (1 / cos view angle)^power
    deadband: float = 0.0  #: rad, servo dead band (full width)
    speed: float = np.inf  #: rad/s, servo speed
    zero_std: float = 0.0  #: rad, std of each servo's zero offset (per UAV and axis, drawn once)
    mount_std: float = 0.0  #: m, std of the gimbal-to-body translation error (per UAV and axis, drawn once)

    @property
    def servo(self) -> bool:
        return self.deadband > 0 or np.isfinite(self.speed)

    @property
    def calibrated(self) -> bool:
        """Whether every UAV's calibration is exact (no constants to draw)."""
        return self.zero_std == 0 and self.mount_std == 0


@dataclass(frozen=True)
class ImperfectCamera(CameraSensor):
    """:class:`~swarmtrack.sim.sensors.CameraSensor` with :class:`Budget`'s errors. Its state (the servos' angles,
    the calibration constants) is per UAV row, so a world of a batch senses as it does alone. The calibration
    constants are drawn at the first frame from the camera's own noise streams (``sensor/camera/<group>/<k>``,
    three frames' worth, before that frame's noise): the world hands a sensor no other stream."""

    budget: Budget = Budget()
    state: dict = field(default_factory=dict, compare=False, repr=False)
    #: its frames in one compiled call (:mod:`.camera_kernels`), the same numbers (with the marker noise's powers
    #: numpy takes by a fast path, :func:`~.camera_kernels.exact`; others numpy's)
    compiled: bool = False

    def _constants(self, scene: Scene, rows: int) -> tuple[np.ndarray, np.ndarray]:
        """(rows, 3) gimbal-to-body translation errors and (rows, 2) servo zero offsets (yaw, tilt)."""
        b = self.budget
        if b.calibrated:
            return np.zeros((rows, 3)), np.zeros((rows, 2))
        g = [scene.normal().reshape(rows, -1, 2)[:, 0] for _ in range(3)]  # each UAV's draws toward object 0
        offset = np.column_stack([g[0][:, 0], g[0][:, 1], g[1][:, 0]]) * b.mount_std
        zero = np.column_stack([g[1][:, 1], g[2][:, 0]]) * b.zero_std
        return offset, zero

    def sense(self, scene: Scene) -> tuple[Detections, np.ndarray]:
        frame = _Frame(self, scene)
        rows = frame.rows
        st = self.state
        if "offset" not in st:
            st["offset"], st["zero"] = self._constants(scene, rows) if scene.objects.shape[0] else \
                (np.zeros((rows, 3)), np.zeros((rows, 2)))
        commanded, b = frame.angles, self.budget
        turning = b.servo and "servo" in st  # the servos turn from where they were (the first frame: commanded)
        if self.compiled:
            actual, pointed = camera_kernels.pointed(commanded, st["servo"] if turning else None,
                                                     scene.t - st["t"] if turning else 0.0, b, st["zero"])
        else:
            actual = np.stack(commanded, axis=-1)
            if turning:
                actual = camera.servo_step(st["servo"], actual, scene.t - st["t"], b.deadband, b.speed)
            pointed = actual + st["zero"]
            pointed = (pointed[:, 0], pointed[:, 1])
        if b.servo:
            st["servo"], st["t"] = actual, scene.t
        pointing = camera.Pointing(tuple(frame.per_world(c) for c in commanded),
                                   tuple(frame.per_world(c) for c in pointed), frame.per_world(st["offset"]),
                                   (b.reference_range, b.distance_power, b.angle_power))
        fast = self.compiled and camera_kernels.exact(b.distance_power, b.angle_power)
        return frame.sense(camera_kernels.frames if fast else camera.sense_imperfect, pointing)


@dataclass(frozen=True)
class CompiledCamera(CameraSensor):
    """The ideal camera (:class:`~swarmtrack.sim.sensors.CameraSensor`) with its frames in one compiled call
    (:func:`~swarmtrack.capabilities.multi_model.camera_kernels.frames`): the same numbers."""

    def sense(self, scene: Scene) -> tuple[Detections, np.ndarray]:
        frame = _Frame(self, scene)
        angles = tuple(frame.per_world(a) for a in frame.angles)
        return frame.sense(camera_kernels.frames, camera.Pointing(angles, angles, None))


class _Frame:
    """What a camera's frame reads of the scene, per world (B, n, ...): the UAVs' true and stamped positions, their
    own world's objects and labels, the noise, the occluded pairs (a run alone) and the gimbal angles the UAVs
    command towards their aim points (``home`` before they have an estimate)."""

    def __init__(self, sensor: CameraSensor, scene: Scene):
        self.sensor, self.scene = sensor, scene
        uavs = scene.uavs
        self.rows, self.worlds = len(uavs), scene.worlds
        self.n = self.rows // self.worlds
        self.stamped = scene.stamped()
        aim = np.broadcast_to(sensor.home, (self.rows, 2)) if scene.aim is None else np.asarray(scene.aim, float)
        aim = np.where(np.isfinite(aim).all(axis=-1, keepdims=True), aim, sensor.home)
        self.angles = camera.angles(self.stamped, sensor.height, aim)

    def per_world(self, a: np.ndarray) -> np.ndarray:
        return a.reshape(self.worlds, self.n, *a.shape[1:])

    def sense(self, frames, pointing: camera.Pointing) -> tuple[Detections, np.ndarray]:
        """``frames`` (:func:`~swarmtrack.sensors.camera.sense_imperfect` or its compiled twin) of this frame."""
        scene, sensor = self.scene, self.sensor
        objects = scene.objects
        if self.worlds > 1:
            labels = scene.world_labels()
            objs, hidden = objects[labels], None
        else:
            labels = np.arange(len(objects))[None]
            objs, hidden = objects[None], hidden_by(sensor.occluders, objects, self.rows, scene.t)
        noise = scene.normal()
        return frames(objs, self.per_world(scene.uavs), self.per_world(self.stamped), sensor.height, pointing,
                      sensor.tan_half, sensor.sigma, noise.reshape(self.worlds, self.n, -1, 2), labels, hidden,
                      scene.taken)
