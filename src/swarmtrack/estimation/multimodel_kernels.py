"""Compiled fast path of the multi-model EKF's stacked update (numba), one filter at a time.

:meth:`swarmtrack.estimation.multimodel.MultiModelEstimator._bank_update` is the readable, batched numpy
*reference*; :func:`stacked_update` computes the same numbers (to rounding) with the 2 x 2 innovation covariance
inverted in closed form, in place on the bank's arrays, and flags each filter whose posterior covariance is not
finite or not positive definite (a Cholesky pivot ≤ 0) instead of raising inside numba. With three UAVs a step
of the reference is some hundred small numpy calls; this is one.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmtrack.estimation.predict_kernels import fma

_LOG_2PI = math.log(2.0 * math.pi)


@njit(cache=True)
def stacked_update(x, P, local, at, nu_pos, R_pos, I, b, s, logdet_r, count):
    """Update filters ``local`` of a bank (``x`` (n, d), ``P`` (n, d, d), in place) with the position-space
    statistic of their stacked measurements (row ``at[r]`` of ``nu_pos``, ``R_pos``, ``I``, ``b``, ``s``,
    ``logdet_r``, ``count``): W20 eqs. 4.10-4.13 (Joseph form), the stacked likelihood of eq. 4.31, the NIS and the
    per-measurement posterior residual of eq. 4.28. Returns ``loglik, nis, eps, ok`` (one per filter)."""
    m_rows = local.shape[0]
    d = x.shape[1]
    loglik = np.empty(m_rows)
    nis = np.empty(m_rows)
    eps = np.empty(m_rows)
    ok = np.ones(m_rows, dtype=np.bool_)
    K = np.empty((d, 2))
    AP = np.empty((d, d))
    L = np.empty((d, d))
    for r in range(m_rows):
        i, a = local[r], at[r]
        r00, r01, r11 = R_pos[a, 0, 0], R_pos[a, 0, 1], R_pos[a, 1, 1]
        s00 = P[i, 0, 0] + r00
        s01 = 0.5 * (P[i, 0, 1] + P[i, 1, 0]) + r01
        s11 = P[i, 1, 1] + r11
        det_s = s00 * s11 - s01 * s01
        i00, i01, i11 = s11 / det_s, -s01 / det_s, s00 / det_s
        for k in range(d):  # K = P Eᵀ S⁻¹ (eq. 4.10)
            K[k, 0] = i00 * P[i, 0, k] + i01 * P[i, 1, k]
            K[k, 1] = i01 * P[i, 0, k] + i11 * P[i, 1, k]
        n0, n1 = nu_pos[a, 0], nu_pos[a, 1]
        d0 = K[0, 0] * n0 + K[0, 1] * n1  # the position's move, for the posterior residual
        d1 = K[1, 0] * n0 + K[1, 1] * n1
        for k in range(d):  # eq. 4.12
            x[i, k] += K[k, 0] * n0 + K[k, 1] * n1
        for k in range(d):  # (I − K E) P
            for j in range(d):
                AP[k, j] = P[i, k, j] - K[k, 0] * P[i, 0, j] - K[k, 1] * P[i, 1, j]
        for k in range(d):  # Joseph form: (I − K E) P (I − K E)ᵀ + K R Kᵀ, symmetrised
            for j in range(k + 1):
                v_kj = AP[k, j] - AP[k, 0] * K[j, 0] - AP[k, 1] * K[j, 1]
                v_jk = AP[j, k] - AP[j, 0] * K[k, 0] - AP[j, 1] * K[k, 1]
                krk = (K[k, 0] * (r00 * K[j, 0] + r01 * K[j, 1]) + K[k, 1] * (r01 * K[j, 0] + r11 * K[j, 1]))
                P[i, k, j] = P[i, j, k] = 0.5 * (v_kj + v_jk) + krk
        for k in range(d):  # Cholesky pivots: positive definite and finite
            for j in range(k + 1):
                acc = P[i, k, j]
                for q in range(j):
                    acc -= L[k, q] * L[j, q]
                if j == k:
                    if not acc > 0.0:
                        ok[r] = False
                        acc = 1.0
                    L[k, k] = math.sqrt(acc)
                else:
                    L[k, j] = acc / L[j, j]
        quad = (n0 * n0 * s11 - 2.0 * n0 * n1 * s01 + n1 * n1 * s00) / det_s
        nis[r] = quad
        ia00, ia01, ia11 = I[a, 0, 0], 0.5 * (I[a, 0, 1] + I[a, 1, 0]), I[a, 1, 1]
        det_i = I[a, 0, 0] * I[a, 1, 1] - I[a, 0, 1] * I[a, 1, 0]
        nin = n0 * (I[a, 0, 0] * n0 + I[a, 0, 1] * n1) + n1 * (I[a, 1, 0] * n0 + I[a, 1, 1] * n1)
        loglik[r] = (-0.5 * quad - 0.5 * math.log(det_s) - _LOG_2PI - 0.5 * (s[a] - nin)
                     + (1.0 - count[a]) * _LOG_2PI - 0.5 * math.log(det_i) - 0.5 * logdet_r[a])
        e = s[a] - 2.0 * (d0 * b[a, 0] + d1 * b[a, 1]) + (d0 * d0 * ia00 + 2.0 * d0 * d1 * ia01 + d1 * d1 * ia11)
        eps[r] = e / count[a]
    return loglik, nis, eps, ok


@njit(cache=True)
def stacked_statistic(n, rows, nu, H, Rinv, logdet):
    """The sums over each receiver's stacked measurements (W20 eqs. 4.3-4.4, position block): ``I = Σ Hᵀ R⁻¹ H``,
    ``b = Σ Hᵀ R⁻¹ ν``, ``s = Σ νᵀ R⁻¹ ν``, ``Σ log det R`` and their number, for ``n`` receivers from the
    measurements ``e`` (receiver ``rows[e]``, in order) with ``nu`` (E, 2), ``H`` (E, 2, 2), ``Rinv`` (E, 2, 2)
    (diagonal, as every measurement model's is) and ``logdet`` (E,). The numbers of
    :meth:`~swarmtrack.estimation.multimodel.MultiModelEstimator._update`'s numpy sums bit for bit: its 2 x 2
    products are OpenBLAS ``gemm``'s in-order fused multiply-adds, its ``einsum`` sums in order without them, and
    ``np.add.at`` adds in the measurements' order from zero."""
    I = np.zeros((n, 2, 2))
    b = np.zeros((n, 2))
    s = np.zeros(n)
    logdet_r = np.zeros(n)
    count = np.zeros(n)
    HtRi = np.empty((2, 2))
    for e in range(rows.shape[0]):
        r = rows[e]
        for a in range(2):  # Hᵀ R⁻¹
            for c in range(2):
                HtRi[a, c] = fma(H[e, 1, a], Rinv[e, 1, c], fma(H[e, 0, a], Rinv[e, 0, c], 0.0))
        for a in range(2):
            for c in range(2):
                I[r, a, c] += fma(HtRi[a, 1], H[e, 1, c], fma(HtRi[a, 0], H[e, 0, c], 0.0))
        for a in range(2):
            b[r, a] += (0.0 + HtRi[a, 0] * nu[e, 0]) + HtRi[a, 1] * nu[e, 1]
        n0, n1 = nu[e, 0], nu[e, 1]
        s[r] += (((0.0 + n0 * Rinv[e, 0, 0] * n0) + n0 * Rinv[e, 0, 1] * n1) + n1 * Rinv[e, 1, 0] * n0) \
            + n1 * Rinv[e, 1, 1] * n1
        logdet_r[r] += logdet[e]
        count[r] += 1.0
    return I, b, s, logdet_r, count


@njit(cache=True)
def _add_camera_term(I, b, s, logdet_r, count, r, z, frame, x0, x1, Rinv, logdet):
    """Add one camera measurement of receiver ``r`` (``z`` (2,), ``frame`` ``[A | b]`` (2, 3), linearised at the
    receiver's predicted position ``(x0, x1)``) to its sums, as :func:`stacked_statistic` adds the terms of
    :meth:`~swarmtrack.estimation.measurements.CameraFrameMeasurement.terms` (``ν = z − A x̂ − b``, ``H = A``)."""
    n0 = (z[0] - ((0.0 + frame[0, 0] * x0) + frame[0, 1] * x1)) - frame[0, 2]
    n1 = (z[1] - ((0.0 + frame[1, 0] * x0) + frame[1, 1] * x1)) - frame[1, 2]
    h00, h01, h10, h11 = frame[0, 0], frame[0, 1], frame[1, 0], frame[1, 1]
    t00 = fma(h10, Rinv[1, 0], fma(h00, Rinv[0, 0], 0.0))  # Hᵀ R⁻¹
    t01 = fma(h10, Rinv[1, 1], fma(h00, Rinv[0, 1], 0.0))
    t10 = fma(h11, Rinv[1, 0], fma(h01, Rinv[0, 0], 0.0))
    t11 = fma(h11, Rinv[1, 1], fma(h01, Rinv[0, 1], 0.0))
    I[r, 0, 0] += fma(t01, h10, fma(t00, h00, 0.0))
    I[r, 0, 1] += fma(t01, h11, fma(t00, h01, 0.0))
    I[r, 1, 0] += fma(t11, h10, fma(t10, h00, 0.0))
    I[r, 1, 1] += fma(t11, h11, fma(t10, h01, 0.0))
    b[r, 0] += (0.0 + t00 * n0) + t01 * n1
    b[r, 1] += (0.0 + t10 * n0) + t11 * n1
    s[r] += (((0.0 + n0 * Rinv[0, 0] * n0) + n0 * Rinv[0, 1] * n1) + n1 * Rinv[1, 0] * n0) + n1 * Rinv[1, 1] * n1
    logdet_r[r] += logdet
    count[r] += 1.0


@njit(cache=True)
def camera_statistic(n, x_pos, own_rows, own_z, own_frame, recv, send, got_z, got_frame, Rinv, logdet):
    """:func:`stacked_statistic` of W20's camera measurements straight from the payloads: receiver ``r``'s own
    (``own_rows``; ``own_z`` (n, 2), ``own_frame`` (n, 2, 3)), then those its links delivered (``recv[e]`` from
    ``send[e]`` of ``got_z``, ``got_frame``), each linearised at ``x_pos`` (n, 2); ``Rinv`` (2, 2), ``logdet``:
    every measurement's ``R⁻¹`` and ``log det R``. The same numbers, without the measurements' arrays."""
    I = np.zeros((n, 2, 2))
    b = np.zeros((n, 2))
    s = np.zeros(n)
    logdet_r = np.zeros(n)
    count = np.zeros(n)
    for e in range(own_rows.shape[0]):
        r = own_rows[e]
        _add_camera_term(I, b, s, logdet_r, count, r, own_z[r], own_frame[r], x_pos[r, 0], x_pos[r, 1], Rinv, logdet)
    for e in range(recv.shape[0]):
        r, j = recv[e], send[e]
        _add_camera_term(I, b, s, logdet_r, count, r, got_z[j], got_frame[j], x_pos[r, 0], x_pos[r, 1], Rinv, logdet)
    return I, b, s, logdet_r, count


@njit(cache=True)
def position_solve(I, b):
    """``I⁻¹ b`` (n, 2) and ``sym(I⁻¹)`` (n, 2, 2) of each 2 x 2 ``I``: the numbers of ``np.linalg.solve(I, [b | E])``
    (LAPACK's ``getrf``/``getrs``: the row of the larger pivot first, the multiplier and the back substitution by
    reciprocals, as OpenBLAS computes them) and of ``symmetrize``."""
    n = I.shape[0]
    nu = np.empty((n, 2))
    R = np.empty((n, 2, 2))
    B = np.empty((2, 3))
    X = np.empty((2, 3))
    for k in range(n):
        a00, a01, a10, a11 = I[k, 0, 0], I[k, 0, 1], I[k, 1, 0], I[k, 1, 1]
        B[0, 0], B[0, 1], B[0, 2] = b[k, 0], 1.0, 0.0
        B[1, 0], B[1, 1], B[1, 2] = b[k, 1], 0.0, 1.0
        if abs(a10) > abs(a00):  # partial pivoting
            a00, a01, a10, a11 = a10, a11, a00, a01
            for j in range(3):
                B[0, j], B[1, j] = B[1, j], B[0, j]
        inv00 = 1.0 / a00
        l10 = a10 * inv00
        u11 = a11 - l10 * a01
        inv11 = 1.0 / u11
        for j in range(3):
            X[1, j] = (B[1, j] - l10 * B[0, j]) * inv11
            X[0, j] = (B[0, j] - a01 * X[1, j]) * inv00
        nu[k, 0], nu[k, 1] = X[0, 0], X[1, 0]
        R[k, 0, 0] = 0.5 * (X[0, 1] + X[0, 1])
        R[k, 0, 1] = 0.5 * (X[0, 2] + X[1, 1])
        R[k, 1, 0] = 0.5 * (X[1, 1] + X[0, 2])
        R[k, 1, 1] = 0.5 * (X[1, 2] + X[1, 2])
    return nu, R
