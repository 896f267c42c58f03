"""W20 Ch. 4's gimballed camera compiled (numba): one frame of every UAV's camera, in every world of a batch, in one
call (truth side).

The readable references are :func:`swarmtrack.sensors.camera.sense` (the ideal camera), :func:`~swarmtrack.sensors.
camera.sense_worlds` (a batch of worlds) and :func:`~swarmtrack.sensors.camera.sense_imperfect` (the error budget);
:func:`frames` takes the last one's arguments and gives its numbers, bit for bit on this project's machines: the
gimbal angles are numpy's (``camera.angles``: its ``arctan2`` is not libm's, so it stays numpy), the rotations'
``sin``/``cos`` are libm's as numpy's are, the camera-frame products sum as numpy's ``einsum`` does
(``(c₀ r₀ + c₂ r₂) + c₁ r₁``), and the marker noise's powers take numpy's fast paths (:data:`EXACT_POWERS`; any
other exponent is libm's ``pow``, which numpy's SIMD power is not: :func:`exact` says whether a budget's are). On
another numpy the sums may differ in the last bit; the tests hold them to 1e-12.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from swarmtrack.sensors.detections import Detections

#: The exponents numpy takes an array to by a fast path (the marker noise's growth is then numpy's, bit for bit).
EXACT_POWERS = (0.0, 1.0, 2.0, 0.5, -1.0)
_NO_OFFSET = np.zeros((0, 0, 3))
_NO_SERVO = np.zeros((0, 2))
_NO_HIDDEN = np.zeros((0, 0), dtype=bool)


@njit(cache=True)
def _rotation(psi, theta, C):
    """:func:`~swarmtrack.sensors.camera.rotation_of` of one gimbal into ``C`` (3, 3)."""
    cp, sp, ct, st = np.cos(psi), np.sin(psi), np.cos(theta), np.sin(theta)
    C[0, 0], C[0, 1], C[0, 2] = sp, -cp, 0.0
    C[1, 0], C[1, 1], C[1, 2] = -ct * cp, -ct * sp, -st
    C[2, 0], C[2, 1], C[2, 2] = st * cp, st * sp, -ct


@njit(cache=True)
def _dot(C, a, r0, r1, r2):
    """Row ``a`` of ``C`` times ``(r0, r1, r2)`` as numpy's ``einsum`` sums it."""
    return (C[a, 0] * r0 + C[a, 2] * r2) + C[a, 1] * r1


@njit(cache=True)
def _power(x, p):
    """``x ** p`` as numpy takes an array to a scalar power (its fast paths, else ``pow``)."""
    if p == 1.0:
        return x
    if p == 0.0:
        return 1.0
    if p == 2.0:
        return x * x
    if p == 0.5:
        return np.sqrt(x)
    if p == -1.0:
        return 1.0 / x
    return x**p


@njit(cache=True)
def _frames(scene, commanded, pointed, offset, optics, noise, hidden):
    """The detections of every UAV of every world (module docstring). ``scene``: ``(objects (B, M, 2), uavs (B, n,
    2), stamped (B, n, 2), labels (B, M))``; ``commanded`` and ``pointed``: ``(ψ, θ)`` (B, n) each; ``offset`` (B, n,
    3) or empty (an ideal mount); ``optics``: ``(height, tan_half (2,), sigma, growth (3,))``; ``noise`` (B, n, M,
    2); ``hidden`` (n, M) or empty. Returns owner, label, z, the stamped position and ``[A | b]`` of each."""
    objects, uavs, stamped, labels = scene
    height, tan_half, sigma, growth = optics
    B, n, M = uavs.shape[0], uavs.shape[1], objects.shape[1]
    mounted, occluded = offset.shape[0] > 0, hidden.shape[0] > 0
    grows = growth[1] != 0.0 or growth[2] != 0.0
    pc = np.empty((B, n, M, 3))
    seen = np.zeros((B, n, M), dtype=np.bool_)
    C = np.empty((3, 3))
    count = 0
    for w in range(B):
        for i in range(n):
            _rotation(pointed[0][w, i], pointed[1][w, i], C)  # the true pose
            cx, cy, drop = uavs[w, i, 0], uavs[w, i, 1], height
            if mounted:
                cx, cy, drop = cx + offset[w, i, 0], cy + offset[w, i, 1], height + offset[w, i, 2]
            for m in range(M):
                r0, r1, r2 = objects[w, m, 0] - cx, objects[w, m, 1] - cy, -drop
                for a in range(3):
                    pc[w, i, m, a] = _dot(C, a, r0, r1, r2)
                z = pc[w, i, m, 2]
                seen[w, i, m] = (z > 0) & (abs(pc[w, i, m, 0]) <= tan_half[0] * z) & \
                    (abs(pc[w, i, m, 1]) <= tan_half[1] * z)
                if occluded and hidden[i, m]:
                    seen[w, i, m] = False
                count += seen[w, i, m]
    owner, label = np.empty(count, dtype=np.int64), np.empty(count, dtype=np.int64)
    zs, pos, frame = np.empty((count, 2)), np.empty((count, 2)), np.empty((count, 2, 3))
    k = 0
    for w in range(B):
        for i in range(n):
            first = k
            for m in range(M):
                if not seen[w, i, m]:
                    continue
                scale = sigma
                if grows:  # camera.marker_sigma
                    d = np.sqrt(((0.0 + pc[w, i, m, 0] * pc[w, i, m, 0]) + pc[w, i, m, 1] * pc[w, i, m, 1])
                                + pc[w, i, m, 2] * pc[w, i, m, 2])
                    drop = height + offset[w, i, 2] if mounted else height
                    scale = sigma * _power(d / growth[0], growth[1]) * _power(d / drop, growth[2])
                owner[k], label[k] = w * n + i, labels[w, m]
                zs[k, 0] = pc[w, i, m, 0] + scale * noise[w, i, m, 0]
                zs[k, 1] = pc[w, i, m, 1] + scale * noise[w, i, m, 1]
                k += 1
            if k == first:
                continue
            _rotation(commanded[0][w, i], commanded[1][w, i], C)  # the frame the UAV stamps (camera.ground_affine)
            sx, sy = stamped[w, i, 0], stamped[w, i, 1]
            t0, t1 = -_dot(C, 0, sx, sy, height), -_dot(C, 1, sx, sy, height)
            for e in range(first, k):
                pos[e, 0], pos[e, 1] = sx, sy
                frame[e, 0, 0], frame[e, 0, 1], frame[e, 0, 2] = C[0, 0], C[0, 1], t0
                frame[e, 1, 0], frame[e, 1, 1], frame[e, 1, 2] = C[1, 0], C[1, 1], t1
    return owner, label, zs, pos, frame


@njit(cache=True)
def _wrap(a):
    """:func:`~swarmtrack.sensors.range_bearing.wrap_angle`: ``π − ((π − a) mod 2π)``, numpy's floored mod."""
    m = np.fmod(np.pi - a, 2.0 * np.pi)
    if m == 0.0:
        m = 0.0
    elif m < 0.0:
        m += 2.0 * np.pi
    return np.pi - m


@njit(cache=True)
def _pointed(psi, theta, last, dt, servo, zero):
    """Each gimbal's servo angles (rows, 2) after ``dt`` s from ``last`` (or empty: the commanded ones) toward the
    commanded ``psi``, ``theta`` (:func:`~swarmtrack.sensors.camera.servo_step`; ``servo``: ``(deadband, speed)``),
    and the angles it points at, plus each servo's zero offset ``zero`` (rows, 2)."""
    deadband, speed = servo
    rows = psi.shape[0]
    actual, out_psi, out_theta = np.empty((rows, 2)), np.empty(rows), np.empty(rows)
    for i in range(rows):
        for a in range(2):
            c = psi[i] if a == 0 else theta[i]
            if last.shape[0] > 0:
                e = _wrap(c - last[i, a])
                move = min(max(e, -speed * dt), speed * dt) if np.isfinite(speed) else e  # np.clip
                c = _wrap(last[i, a] + (move if abs(e) > 0.5 * deadband else 0.0))
            actual[i, a] = c
        out_psi[i], out_theta[i] = actual[i, 0] + zero[i, 0], actual[i, 1] + zero[i, 1]
    return actual, (out_psi, out_theta)


def pointed(commanded, last, dt, budget, zero):
    """The servos' angles (rows, 2) and the angles ``(ψ, θ)`` the gimbals point at, as
    :class:`~swarmtrack.capabilities.multi_model.sensor.ImperfectCamera` computes them in numpy: from their ``last``
    angles (None: at the commanded ones) ``dt`` s ago toward the ``commanded`` ``(ψ, θ)``, plus their zero offsets
    ``zero`` (rows, 2)."""
    last = _NO_SERVO if last is None else last
    return _pointed(commanded[0], commanded[1], last, float(dt), (float(budget.deadband), float(budget.speed)), zero)


def exact(*powers: float) -> bool:
    """Whether :func:`frames` gives numpy's numbers for the marker noise's ``powers`` (:data:`EXACT_POWERS`)."""
    return all(p in EXACT_POWERS for p in powers)


def frames(objects, uavs, stamped, height, pointing, tan_half, sigma, noise, labels, hidden=None, taken=None):
    """:func:`swarmtrack.sensors.camera.sense_imperfect` compiled: its arguments, its detections and labels.
    ``pointing.offset`` may be None (an ideal mount: the camera at the UAV, ``height`` above the ground)."""
    commanded, pointed, offset, growth = pointing
    n = uavs.shape[1]
    owner, label, z, pos, frame = _frames(
        (objects, uavs, stamped, labels), commanded, pointed, _NO_OFFSET if offset is None else offset,
        (float(height), np.asarray(tan_half, dtype=float), float(sigma), np.asarray(growth, dtype=float)), noise,
        _NO_HIDDEN if hidden is None else hidden)
    return Detections(owner, z, pos, label, uavs.shape[0] * n, frame=frame, taken=taken), label
