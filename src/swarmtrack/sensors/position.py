"""Planar position sensor (issue 40): each UAV measures the position of every object in its footprint relative to
itself, with Gaussian noise, and cannot tell the objects apart.

The measurement from UAV ``i`` at ``q_i`` of an object at ``q_t`` is ``z = q_t − q_i + v``, ``v ~ N(0, σ² I)``: a
downward camera's detection placed on the ground, or a radar's converted report. The footprint is the square of
half-width ``half_width`` centred on the UAV, axes along the world's (a gimbal holding north; None: it sees
everything). Its detections carry no label (:data:`~swarmtrack.sensors.detections.UNLABELLED`): which object each
came from is for the world and the metrics only. The onboard position of a detection is ``sensor_pos + z``, a
linear measurement of the object's position (:func:`positions`).

All functions are vectorised; positions are ``(..., 2)`` arrays.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.sensors.detections import UNLABELLED, Detections


def sense(objects: np.ndarray, uavs: np.ndarray, stamped: np.ndarray, sigma: float, noise: np.ndarray,
          half_width: float | None = None, hidden: np.ndarray | None = None,
          taken: float | None = None) -> tuple[Detections, np.ndarray]:
    """One sensing step of every UAV towards every object (truth side). ``objects`` (M, 2) and ``uavs`` (N, 2) are
    true positions, ``stamped`` (N, 2) the navigation positions the UAVs stamp on their detections, ``noise``
    (N, M, 2) standard normal draws for every (UAV, object) pair, in view or not (so the draws do not depend on the
    geometry); ``hidden`` (N, M) the pairs an occluder hides. Returns the detections (UAV-major, unlabelled, stamped
    ``taken``) and, for the world only, the object each came from."""
    n, m = len(uavs), len(objects)
    rel = objects[None, :, :] - uavs[:, None, :]  # (N, M, 2)
    z = (rel + sigma * noise).reshape(n * m, 2)
    owner, source = np.divmod(np.arange(n * m), m) if m else (np.zeros(0, np.int64), np.zeros(0, np.int64))
    inside = np.ones(n * m, dtype=bool) if hidden is None else ~hidden.reshape(-1)
    if half_width is not None:
        inside &= (np.abs(rel) <= half_width).all(axis=-1).reshape(-1)
    owner, source, z = owner[inside], source[inside], z[inside]
    label = np.full(len(owner), UNLABELLED, dtype=np.int64)
    return Detections(owner, z, stamped[owner], label, n, None, taken=taken), source


def positions(det: Detections, sigma: float, own_sigma: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Each detection as a position in the world frame and its covariance: ``sensor_pos + z`` (M, 2) and
    ``(σ² + own_sigma²) I`` (M, 2, 2), ``own_sigma`` the UAV's own navigation error."""
    p = det.sensor_pos[:, :2] + det.z
    R = np.zeros((len(p), 2, 2))
    R[:, 0, 0] = R[:, 1, 1] = sigma**2 + own_sigma**2
    return p, R


def of_relative(rel: np.ndarray, pos: np.ndarray) -> tuple[np.ndarray, None]:
    """The noiseless ``z`` of objects at planar positions ``rel`` (M, 2) relative to their UAVs: ``rel`` itself, no
    frame (:class:`~swarmtrack.registry.Measurement`)."""
    return np.asarray(rel, dtype=float).copy(), None


def relative_of(det: Detections) -> np.ndarray:
    """The planar positions relative to their UAVs (M, 2) that ``det`` says: its ``z``."""
    return det.z[:, :2].copy()
