"""A sensor that misses and is fooled: each sensed object in view is detected with probability ``Pd``, and each UAV
sees a Poisson number of false detections a scan, uniform over its field of view (issue 40). The false ones carry
no label (:data:`~swarmtrack.sensors.detections.UNLABELLED`) and come from no object (source −1); a detection kept
keeps its label (a sensor that labels its detections still does).

``Pd`` may fall with the distance: ``Pd(d) = Pd · (1 − falloff · d)`` with ``d`` the object's distance from the UAV
normalised by the field of view's (the range over ``max_range`` for a disk, the Chebyshev distance over
``half_width`` for a square footprint), so ``Pd · (1 − falloff)`` at the edge, and 0 outside the view
(:func:`disk_detection_probability`, :func:`square_detection_probability`). The settings read the same functions
(their ``detection_probability_at``) as the truth side, so an estimator's ``Pd`` is the world's.

The draws are the caller's, each from a stream of its own (the world's), so that a sensor without misses or clutter
draws nothing more and its runs stay bit for bit.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.sensors.detections import UNLABELLED, Detections

#: The source of a false detection (it came from no object).
CLUTTER = -1


def thin(det: Detections, source: np.ndarray, uniform: np.ndarray,
         probability: np.ndarray) -> tuple[Detections, np.ndarray]:
    """Keep each detection when its pair's ``uniform`` (N, M) draw (UAV ``owner``, object ``source``) is below its
    detection ``probability`` (one per detection, (len(det),))."""
    keep = uniform[det.owner, source] < probability
    return _rows(det, keep), source[keep]


def falloff_probability(probability: float, falloff: float, distance: np.ndarray,
                        inside: np.ndarray) -> np.ndarray:
    """``probability · (1 − falloff · distance)`` where ``inside`` the field of view, 0 elsewhere (...,);
    ``distance`` normalised by the field of view's (1 at its edge)."""
    return np.where(inside, probability * (1.0 - falloff * distance), 0.0)


def disk_detection_probability(rel, probability: float, falloff: float, max_range: float | None) -> np.ndarray:
    """The detection probability (...,) of objects at planar positions ``rel`` (..., 2) relative to a UAV whose field
    of view is the disk of radius ``max_range`` (None: everywhere, no falloff): :func:`falloff_probability` of the
    range over ``max_range``, inside where the range is at most ``max_range``."""
    rel = np.asarray(rel, dtype=float)
    if max_range is None:
        return np.full(rel.shape[:-1], float(probability))
    rho = np.hypot(rel[..., 0], rel[..., 1])
    return falloff_probability(probability, falloff, rho / max_range, rho <= max_range)


def square_detection_probability(rel, probability: float, falloff: float,
                                 half_width: float | None) -> np.ndarray:
    """The detection probability (...,) of objects at planar positions ``rel`` (..., 2) relative to a UAV whose
    footprint is the square ``[−half_width, half_width]²`` (None: everywhere, no falloff): :func:`falloff_probability`
    of the Chebyshev distance ``max(|x|, |y|)`` over ``half_width``, inside where it is at most ``half_width``."""
    rel = np.asarray(rel, dtype=float)
    if half_width is None:
        return np.full(rel.shape[:-1], float(probability))
    chebyshev = np.abs(rel).max(axis=-1)
    return falloff_probability(probability, falloff, chebyshev / half_width, chebyshev <= half_width)


def add_clutter(det: Detections, source: np.ndarray, counts: np.ndarray, z: np.ndarray,
                stamped: np.ndarray) -> tuple[Detections, np.ndarray]:
    """Append ``counts[i]`` false detections to each UAV i (``z`` their measurements, UAV-major, already drawn over
    its field of view), stamped where its navigation put it (``stamped`` (N, d))."""
    if not len(z):
        return det, source
    owner = np.repeat(np.arange(len(counts)), counts)
    out = Detections(np.concatenate([det.owner, owner]), np.concatenate([det.z, z]),
                     np.concatenate([det.sensor_pos, stamped[owner]]),
                     np.concatenate([det.label, np.full(len(owner), UNLABELLED, dtype=det.label.dtype)]),
                     det.n_uavs, None, None, det.footprint, det.taken)
    return out, np.concatenate([source, np.full(len(owner), CLUTTER, dtype=source.dtype)])


def polar_clutter(rngs: list, rate: float, max_range: float) -> tuple[np.ndarray, np.ndarray]:
    """Each UAV's false detections of one scan from its own stream (``rngs``, one per UAV): a Poisson(``rate``)
    count, each uniform over the disk of radius ``max_range`` around it, as ``[range, bearing]`` (bearing in
    (−π, π]). Returns the counts (N,) and the measurements (Σ counts, 2), UAV-major."""
    counts = np.array([rng.poisson(rate) for rng in rngs], dtype=np.int64)
    z = np.empty((int(counts.sum()), 2))
    at = 0
    for rng, c in zip(rngs, counts.tolist(), strict=True):
        u = rng.random((c, 2))
        z[at:at + c, 0] = max_range * np.sqrt(u[:, 0])  # uniform over the disk's area
        z[at:at + c, 1] = np.pi - 2 * np.pi * u[:, 1]
        at += c
    return counts, z


def ball_clutter(rngs: list, rate: float, max_range: float) -> tuple[np.ndarray, np.ndarray]:
    """Each UAV's false detections of one scan from its own stream (``rngs``, one per UAV): a Poisson(``rate``)
    count, each uniform over the volume of the ball of radius ``max_range`` around it, as ``[range, bearing,
    elevation]``: range ``max_range · u^(1/3)``, bearing uniform in (−π, π], elevation ``arcsin(2v − 1)``. Returns
    the counts (N,) and the measurements (Σ counts, 3), UAV-major."""
    counts = np.array([rng.poisson(rate) for rng in rngs], dtype=np.int64)
    z = np.empty((int(counts.sum()), 3))
    at = 0
    for rng, c in zip(rngs, counts.tolist(), strict=True):
        u = rng.random((c, 3))
        z[at:at + c, 0] = max_range * np.cbrt(u[:, 0])  # uniform over the ball's volume: P(ρ ≤ r) = (r / R)³
        z[at:at + c, 1] = np.pi - 2 * np.pi * u[:, 1]
        z[at:at + c, 2] = np.arcsin(2.0 * u[:, 2] - 1.0)  # sin ε uniform in [−1, 1): uniform over the sphere
        at += c
    return counts, z


def square_clutter(rngs: list, rate: float, half_width: float) -> tuple[np.ndarray, np.ndarray]:
    """Each UAV's false detections of one scan from its own stream (``rngs``, one per UAV): a Poisson(``rate``)
    count, each uniform over the footprint ``[−half_width, half_width]²`` around it. Returns the counts (N,) and
    the relative positions (Σ counts, 2), UAV-major."""
    counts = np.array([rng.poisson(rate) for rng in rngs], dtype=np.int64)
    z = np.concatenate([half_width * (2.0 * rng.random((c, 2)) - 1.0)
                        for rng, c in zip(rngs, counts.tolist(), strict=True)]) if len(rngs) else np.zeros((0, 2))
    return counts, z


def unlabelled(det: Detections) -> Detections:
    """``det`` with every label removed: a sensor that cannot tell the objects apart."""
    return Detections(det.owner, det.z, det.sensor_pos, np.full(len(det), UNLABELLED, dtype=det.label.dtype),
                      det.n_uavs, None, det.frame, det.footprint, det.taken)


def _rows(det: Detections, keep: np.ndarray) -> Detections:
    return Detections(det.owner[keep], det.z[keep], det.sensor_pos[keep], det.label[keep], det.n_uavs, None,
                      None if det.frame is None else det.frame[keep], det.footprint, det.taken)
