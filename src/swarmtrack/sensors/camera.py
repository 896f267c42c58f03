"""Gimballed camera that reports a ground target's *metric* position in its camera frame (W20 Secs. 3.1-3.2, 4.3.1).

W20's UAVs carry a pan-tilt unit that keeps the target centred, and a marker detector that returns the marker's
metric position in the camera frame (W20 Sec. 3.1.2.4): the measurement is a rigid transform of the target's
world position, not a pixel projection. With the target on flat ground (``z_w = 0``) the first two camera-frame
coordinates are an affine function of the target's planar position (W20 eqs. 4.15-4.16):

``z = S (C_c^w p_w + t_c^w) = A p + b``, ``A = C[:2, :2]``, ``b = t[:2]``, ``t = −C c``

with ``C`` the world-to-camera rotation and ``c`` the camera's world position. The camera frame follows the usual
convention and W20's gimbal: the camera's yaw points it at the aim point (W20 eq. 3.32), its tilt from the nadir
puts the aim point on the optical axis (the pan-tilt unit of eqs. 3.15, 3.21); camera ``x`` is horizontal to the
right of the line of sight, camera ``z`` is the optical axis and ``y = z × x`` (down in the image). The gimbal aims
at the UAV's own latest estimate (its onboard view), so a target that moves faster than the estimate can leave the
field of view. All functions broadcast over leading batch axes.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from swarmtrack.sensors.detections import Detections
from swarmtrack.sensors.range_bearing import wrap_angle

#: W20 Sec. 3.2.2.2: the field of view is 1.2 m x 0.9 m at 1.5 m.
W20_FOOTPRINT = (1.2, 0.9)
W20_FOOTPRINT_RANGE = 1.5


def rotation(camera_xy: np.ndarray, height: float, aim: np.ndarray) -> np.ndarray:
    """World-to-camera rotation ``C`` (..., 3, 3) of a camera at ``(x, y, height)`` aimed at the ground point ``aim``.

    Rows are the camera axes in world coordinates: ``x`` right of the line of sight, ``y = z × x``, ``z`` along
    the optical axis. Yaw ``ψ = atan2(Δy, Δx)`` toward the aim point (W20 eq. 3.32; ``ψ = 0`` when the aim point
    is straight below, so the image's width then spans the world's y axis), tilt from the nadir
    ``θ = atan2(‖Δ‖, height)``. The footprint's height lies along the line of sight, its width across it.
    """
    return rotation_of(*angles(camera_xy, height, aim))


def angles(camera_xy: np.ndarray, height, aim: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The gimbal's yaw ``ψ`` (W20 eq. 3.32) and tilt from the nadir ``θ`` (the pan-tilt unit of eqs. 3.15, 3.21)
    that put the ground point ``aim`` on the optical axis of a camera at ``(x, y, height)``."""
    d = np.asarray(aim, dtype=float) - np.asarray(camera_xy, dtype=float)
    psi = np.arctan2(d[..., 1], d[..., 0])
    theta = np.arctan2(np.hypot(d[..., 0], d[..., 1]), height)
    return psi, theta


def rotation_of(psi: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """World-to-camera rotation ``C`` (..., 3, 3) of a gimbal at yaw ``psi`` and tilt from the nadir ``theta``
    (:func:`rotation`'s axes)."""
    cp, sp, ct, st = np.cos(psi), np.sin(psi), np.cos(theta), np.sin(theta)
    C = np.empty(cp.shape + (3, 3))
    C[..., 0, 0], C[..., 0, 1], C[..., 0, 2] = sp, -cp, 0.0  # right of the line of sight
    C[..., 1, 0], C[..., 1, 1], C[..., 1, 2] = -ct * cp, -ct * sp, -st  # axis × right
    C[..., 2, 0], C[..., 2, 1], C[..., 2, 2] = st * cp, st * sp, -ct  # the optical axis, forward and down
    return C


def ground_affine(C: np.ndarray, camera_xy: np.ndarray, height: float) -> np.ndarray:
    """``[A | b]`` (..., 2, 3) with ``z = A p + b`` for a ground point ``p`` (W20 eq. 4.16, ``z_w = 0``)."""
    c = np.concatenate([np.asarray(camera_xy, dtype=float),
                        np.full(np.shape(camera_xy)[:-1] + (1,), float(height))], axis=-1)
    t = -np.einsum("...ab,...b->...a", C, c)
    return np.concatenate([C[..., :2, :2], t[..., :2, None]], axis=-1)


def camera_frame(points: np.ndarray, C: np.ndarray, camera_xy: np.ndarray, height: float) -> np.ndarray:
    """Camera-frame coordinates (..., 3) of ground points (..., 2) (W20 eq. 4.15 before the projection ``S``)."""
    xy = np.asarray(points, dtype=float) - camera_xy
    rel = np.concatenate([xy, np.full(xy.shape[:-1] + (1,), -float(height))], axis=-1)
    return np.einsum("...ab,...b->...a", C, rel)


def in_view(pc: np.ndarray, tan_half: tuple[float, float]) -> np.ndarray:
    """Whether camera-frame points (..., 3) lie in front of the camera and inside its rectangular field of view,
    ``|x/z| ≤ tan(half width)``, ``|y/z| ≤ tan(half height)``."""
    z = pc[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        return (z > 0) & (np.abs(pc[..., 0]) <= tan_half[0] * z) & (np.abs(pc[..., 1]) <= tan_half[1] * z)


def invert(frame: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``h⁻¹``: the ground point (..., 2) whose measurement is ``z`` under ``[A | b]`` (W20 Table 4.1's
    ``x̂0 = [h⁻¹(z0); 0]``), by solving ``A p = z − b``."""
    return np.linalg.solve(frame[..., :2], (np.asarray(z, dtype=float) - frame[..., 2])[..., None])[..., 0]


def sense(objects: np.ndarray, uavs: np.ndarray, stamped: np.ndarray, height: float, aim: np.ndarray,
          tan_half: tuple[float, float], sigma: float, noise: np.ndarray, hidden: np.ndarray | None = None,
          taken: float | None = None):
    """One sensing step of every UAV's camera toward every labelled object (truth side).

    ``objects`` (M, 2) and ``uavs`` (N, 2) are true positions, ``stamped`` (N, 2) the navigation positions, ``aim``
    (N, 2) the ground points the gimbals aim at, ``noise`` (N, M, 2) standard normal draws for every pair (drawn
    whether seen or not, so the draws do not depend on the geometry), ``hidden`` (N, M) pairs an occluder hides.
    The gimbal angles are set from the UAV's own navigation position, so the true camera pose and the one the UAV
    stamps on its detection (``frame``, from ``stamped``) differ by the navigation error. An object is detected when
    it lies in the field of view and is not hidden; its label is its index (a marker the detector reads).
    Returns the :class:`~swarmtrack.sensors.detections.Detections` and the index of the object each came from.
    """
    C = rotation(stamped, height, aim)  # (N, 3, 3)
    pc = camera_frame(objects[None, :, :], C[:, None], uavs[:, None, :], height)  # (N, M, 3), true pose
    seen = in_view(pc, tan_half)
    if hidden is not None:
        seen &= ~hidden
    owner, source = np.nonzero(seen)
    z = pc[owner, source, :2] + sigma * noise[owner, source]
    frame = ground_affine(C, stamped, height)[owner]
    return Detections(owner, z, stamped[owner], source, len(uavs), frame=frame, taken=taken), source


def sense_worlds(objects: np.ndarray, uavs: np.ndarray, stamped: np.ndarray, height: float, aim: np.ndarray,
                 tan_half: tuple[float, float], sigma: float, noise: np.ndarray, labels: np.ndarray,
                 taken: float | None = None):
    """:func:`sense` for a batch of B worlds of one layout, each UAV's camera towards its own world's objects only:
    ``objects`` (B, M, 2), ``uavs``, ``stamped`` and ``aim`` (B, N, 2), ``noise`` (B, N, M, 2), ``labels`` (B, M)
    each object's label. The detections of world b's UAV i are those of UAV ``b·N + i``, in the order :func:`sense`
    gives them alone (no occluders: they name one world's UAVs). Returns the detections and each one's label."""
    n = uavs.shape[1]
    C = rotation(stamped, height, aim)  # (B, N, 3, 3)
    pc = camera_frame(objects[:, None, :, :], C[:, :, None], uavs[:, :, None, :], height)  # (B, N, M, 3)
    world, uav, obj = np.nonzero(in_view(pc, tan_half))
    source = labels[world, obj]
    z = pc[world, uav, obj, :2] + sigma * noise[world, uav, obj]
    frame = ground_affine(C, stamped, height)[world, uav]
    return Detections(world * n + uav, z, stamped[world, uav], source, uavs.shape[0] * n, frame=frame,
                      taken=taken), source


# --- W20 Ch. 4's error budget (issue 27): the error sources of the thesis' hardware (Secs. 3.1-3.3, 4.6.1) ---


def marker_sigma(pc: np.ndarray, drop: np.ndarray, sigma: float, reference_range: float, distance_power: float,
                 angle_power: float) -> np.ndarray:
    """Per-axis noise (...) of the marker detector's position (W20 Sec. 3.1.2.4, Aruco ROS) for camera-frame
    points ``pc`` (..., 3) seen from ``drop`` (...) m above them: ``sigma (d / reference_range)^distance_power
    (1 / cos α)^angle_power`` with ``d = ‖pc‖`` and ``α`` the angle between the line of sight and the marker's normal
    (the marker lies flat, so ``cos α = drop / d``). A fixed error of the marker's corners in pixels becomes a lateral
    error growing with ``d`` (pinhole camera: power 1), and a marker seen at ``α`` is foreshortened by ``cos α``."""
    d = np.linalg.norm(pc, axis=-1)
    return sigma * (d / reference_range) ** distance_power * (d / drop) ** angle_power


def servo_step(actual: np.ndarray, command: np.ndarray, dt: float, deadband: float, speed: float) -> np.ndarray:
    """A hobby servo's angle (...) after ``dt`` s toward ``command`` (W20 Sec. 3.3: the pan-tilt unit's two servos).
    It holds while the command stays within ``±deadband / 2`` of it (the servo ignores a change of its pulse width
    smaller than its dead band) and otherwise turns toward the command at most ``speed`` rad/s (its rated speed) and
    stops on it. ``speed = inf``: it reaches the command at once."""
    e = wrap_angle(command - actual)
    move = np.clip(e, -speed * dt, speed * dt) if np.isfinite(speed) else e
    return wrap_angle(actual + np.where(np.abs(e) > 0.5 * deadband, move, 0.0))


class Pointing(NamedTuple):
    """How an imperfect gimbal points (each (B, n) per world and UAV): the angles (ψ, θ) its UAV ``commanded``, the
    angles it ``pointed`` at (the servos' angles plus their zero offsets), the camera's gimbal-to-body translation
    error ``offset`` (B, n, 3), and the marker noise's ``growth`` (reference range, distance power, angle power; see
    :func:`marker_sigma`)."""

    commanded: tuple[np.ndarray, np.ndarray]
    pointed: tuple[np.ndarray, np.ndarray]
    offset: np.ndarray
    growth: tuple[float, float, float] = (1.5, 0.0, 0.0)


def sense_imperfect(objects: np.ndarray, uavs: np.ndarray, stamped: np.ndarray, height: float, pointing: Pointing,
                    tan_half: tuple[float, float], sigma: float, noise: np.ndarray, labels: np.ndarray,
                    hidden: np.ndarray | None = None, taken: float | None = None):
    """:func:`sense_worlds` with the hardware's errors (a run alone is the batch of one world, ``hidden`` (n, M) its
    occluded pairs): the true camera sits at ``uavs`` plus its gimbal-to-body offset and points at the gimbal angles
    ``pointing.pointed``, while the UAV stamps on its detection the frame of the angles it commanded from its
    navigation position ``stamped`` at the nominal ``height`` (W20 eqs. 3.15, 3.21, 3.32: the pan-tilt unit is open
    loop and the offsets are unknown to it). The detector's noise grows with distance and view angle
    (:func:`marker_sigma`). Returns the detections and each one's label."""
    commanded, pointed, offset, growth = pointing
    n = uavs.shape[1]
    C = rotation_of(*pointed)  # (B, n, 3, 3), the true pose
    cam_xy = uavs + offset[..., :2]
    drop = height + offset[..., 2]
    rel = np.concatenate([objects[:, None, :, :] - cam_xy[:, :, None, :],
                          np.broadcast_to(-drop[:, :, None, None], cam_xy.shape[:2] + (objects.shape[1], 1))],
                         axis=-1)  # (B, n, M, 3)
    pc = np.einsum("wnij,wnmj->wnmi", C, rel)
    seen = in_view(pc, tan_half)
    if hidden is not None:
        seen &= ~hidden[None]
    world, uav, obj = np.nonzero(seen)
    scale = sigma if growth[1] == 0 and growth[2] == 0 else \
        marker_sigma(pc[world, uav, obj], drop[world, uav], sigma, *growth)[:, None]
    z = pc[world, uav, obj, :2] + scale * noise[world, uav, obj]
    frame = ground_affine(rotation_of(*commanded), stamped, height)[world, uav]
    return Detections(world * n + uav, z, stamped[world, uav], labels[world, obj], uavs.shape[0] * n, frame=frame,
                      taken=taken), labels[world, obj]


def of_relative(rel: np.ndarray, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """W20 eq. 4.16's affine measurement ``z = A p + b`` of targets at planar positions ``rel`` (M, 2) relative to
    the UAVs at ``pos`` (M, 2), with ``A = I``, ``b = −p_uav``: the relative position itself, stamped with its frame
    ``[I | −p_uav]`` (:class:`~swarmtrack.registry.Measurement`)."""
    frame = np.zeros((len(rel), 2, 3))
    frame[:, 0, 0] = frame[:, 1, 1] = 1.0
    frame[:, :, 2] = -pos
    return rel.copy(), frame


def relative_of(det: Detections) -> np.ndarray:
    """``p = A⁻¹ (z − b)`` (solved) of ``det``'s frames, less where the UAVs were: the inverse of
    :func:`of_relative` for any affine frame."""
    assert det.frame is not None, "needs frames"
    p = np.linalg.solve(det.frame[:, :, :2], (det.z - det.frame[:, :, 2])[..., None])[..., 0]
    return p - det.sensor_pos
