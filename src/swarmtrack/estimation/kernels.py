"""Compiled fast path of the constant-velocity (CV) information filter (numba).

This module is the *fast path*: hand-specialised numba kernels for one information-filter cycle of a bank
of CV filters (state ``[x, y, vx, vy]``), one agent at a time, with the 4 x 4 symmetric inversions done by
hand-written Cholesky factorisations. :mod:`swarmtrack.estimation.information` is the readable, batched
*reference* (any model, plain numpy); the kernels here compute the same numbers (to rounding) for the CV
model with a diagonal ``Q`` and the ``position`` range-bearing update, and the tests hold them to it.

One cycle (L24 Sec. 3.1 prediction, eqs. 6-7 update), with the state of a bank carried as the posterior
information ``Y, y`` *and* its moments ``x = Y⁻¹ y, P = Y⁻¹``::

    x_pred = cv_predicted_position(x, dt)                        # F x, position part (linearisation point)
    I, i = cv_position_contributions(x_pred, sensor, z, σr, σβ)  # own measurement information (eq. 6)
    ... add the neighbours' I, i (fusion by plain sums, eq. 7) ...
    flags = cv_cycle(Y, y, x, P, dt, q, I, i)                    # predict + update + recover, in place

``flags`` is a per-agent ``uint8`` array: 0 when the cycle went through, else a bit set of
:data:`PREDICT_NOT_PD` (``P(k|k-1)`` had a Cholesky pivot ≤ 0 or non-finite numbers) and
:data:`POSTERIOR_NOT_PD` (same for the posterior ``Y(k|k)``). The kernels never raise inside numba; a
flagged agent's outputs are NaN (see :func:`cv_cycle`) and :func:`check_flags` turns flags into the
reference's :class:`~swarmtrack.estimation.information.FilterDivergence`.

All kernels are ``@numba.njit(cache=True, fastmath=False)``, serial (one core), and take C-contiguous
float64 arrays; :func:`cv_information_cycle` is the checked pure-Python entry point.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from swarmtrack.estimation.information import FilterDivergence
from swarmtrack.sensors.range_bearing import MIN_RANGE

#: Flag bit: the predicted covariance ``P(k|k-1) = F P Fᵀ + Q`` is not positive definite / not finite.
PREDICT_NOT_PD = np.uint8(1)
#: Flag bit: the posterior information ``Y(k|k)`` is not positive definite / not finite (recover failed).
POSTERIOR_NOT_PD = np.uint8(2)

_PREDICT = 1
_POSTERIOR = 2
_NAN = math.nan
_INF = math.inf
_POSITION_COV_FLOOR = float(MIN_RANGE)  # the floor position_covariance applies on top of min_range
_NAN10 = (_NAN,) * 10  # a failed symmetric 4 x 4 (its lower triangle)
_NAN4 = (_NAN,) * 4


# Inlined at numba-IR level: ~15 % faster cycles than leaving the call to LLVM.
@numba.njit(cache=True, fastmath=False, inline="always")
def _chol_inv_solve4(a, b):
    """Inverse and ``A⁻¹ b`` of a symmetric 4 x 4 ``A`` by Cholesky ``A = L Lᵀ``: ``a`` its lower triangle row by
    row, ``(a00, a10, a11, a20, a21, a22, a30, a31, a32, a33)``, ``b`` = ``(b0, b1, b2, b3)``.

    Returns ``(ok, v, s)`` with ``v`` the lower triangle of ``A⁻¹ = L⁻ᵀ L⁻¹`` in the same order and ``s = A⁻¹ b``
    (forward then back substitution), tuples of scalars (registers, as the unrolled code needs). ``ok`` is False,
    and everything else NaN, when a pivot is ≤ 0 or non-finite or the results are not finite.
    """
    a00, a10, a11, a20, a21, a22, a30, a31, a32, a33 = a
    b0, b1, b2, b3 = b
    d = a00
    if not (d > 0.0 and d < _INF):
        return False, _NAN10, _NAN4
    l00 = math.sqrt(d)
    r0 = 1.0 / l00
    l10 = a10 * r0
    l20 = a20 * r0
    l30 = a30 * r0
    d = a11 - l10 * l10
    if not (d > 0.0 and d < _INF):
        return False, _NAN10, _NAN4
    l11 = math.sqrt(d)
    r1 = 1.0 / l11
    l21 = (a21 - l20 * l10) * r1
    l31 = (a31 - l30 * l10) * r1
    d = a22 - l20 * l20 - l21 * l21
    if not (d > 0.0 and d < _INF):
        return False, _NAN10, _NAN4
    l22 = math.sqrt(d)
    r2 = 1.0 / l22
    l32 = (a32 - l30 * l20 - l31 * l21) * r2
    d = a33 - l30 * l30 - l31 * l31 - l32 * l32
    if not (d > 0.0 and d < _INF):
        return False, _NAN10, _NAN4
    l33 = math.sqrt(d)
    r3 = 1.0 / l33

    # M = L⁻¹ (lower triangular), column by column.
    m10 = -r1 * (l10 * r0)
    m20 = -r2 * (l20 * r0 + l21 * m10)
    m21 = -r2 * (l21 * r1)
    m30 = -r3 * (l30 * r0 + l31 * m10 + l32 * m20)
    m31 = -r3 * (l31 * r1 + l32 * m21)
    m32 = -r3 * (l32 * r2)
    # A⁻¹ = Mᵀ M: (A⁻¹)_ij = Σ_{k ≥ max(i, j)} M_ki M_kj.
    v00 = r0 * r0 + m10 * m10 + m20 * m20 + m30 * m30
    v10 = r1 * m10 + m21 * m20 + m31 * m30
    v11 = r1 * r1 + m21 * m21 + m31 * m31
    v20 = r2 * m20 + m32 * m30
    v21 = r2 * m21 + m32 * m31
    v22 = r2 * r2 + m32 * m32
    v30 = r3 * m30
    v31 = r3 * m31
    v32 = r3 * m32
    v33 = r3 * r3

    # A s = b: L w = b, then Lᵀ s = w.
    w0 = b0 * r0
    w1 = (b1 - l10 * w0) * r1
    w2 = (b2 - l20 * w0 - l21 * w1) * r2
    w3 = (b3 - l30 * w0 - l31 * w1 - l32 * w2) * r3
    s3 = w3 * r3
    s2 = (w2 - l32 * s3) * r2
    s1 = (w1 - l21 * s2 - l31 * s3) * r1
    s0 = (w0 - l10 * s1 - l20 * s2 - l30 * s3) * r0

    if not math.isfinite(v00 + v11 + v22 + v33 + s0 + s1 + s2 + s3):
        return False, _NAN10, _NAN4
    return True, (v00, v10, v11, v20, v21, v22, v30, v31, v32, v33), (s0, s1, s2, s3)


@numba.njit(cache=True, fastmath=False)
def _store_sym4(M, k, v):
    """``M[k]`` = the symmetric 4 x 4 of lower triangle ``v`` (row by row, as :func:`_chol_inv_solve4` gives it)."""
    v00, v10, v11, v20, v21, v22, v30, v31, v32, v33 = v
    M[k, 0, 0] = v00
    M[k, 1, 0] = v10
    M[k, 0, 1] = v10
    M[k, 1, 1] = v11
    M[k, 2, 0] = v20
    M[k, 0, 2] = v20
    M[k, 2, 1] = v21
    M[k, 1, 2] = v21
    M[k, 2, 2] = v22
    M[k, 3, 0] = v30
    M[k, 0, 3] = v30
    M[k, 3, 1] = v31
    M[k, 1, 3] = v31
    M[k, 3, 2] = v32
    M[k, 2, 3] = v32
    M[k, 3, 3] = v33


@numba.njit(cache=True, fastmath=False)
def _store4(v, k, s):
    s0, s1, s2, s3 = s
    v[k, 0] = s0
    v[k, 1] = s1
    v[k, 2] = s2
    v[k, 3] = s3


@numba.njit(cache=True, fastmath=False)
def cv_recover(Y, y):
    """``x = Y⁻¹ y`` (N, 4) and ``P = Y⁻¹`` (N, 4, 4) by Cholesky, plus per-agent flags (N,) uint8.

    Same as :func:`swarmtrack.estimation.information.recover` (the symmetric part of ``Y`` is used). An
    agent whose ``Y`` is not positive definite / not finite gets :data:`POSTERIOR_NOT_PD` and NaN ``x, P``.
    """
    n = Y.shape[0]
    x = np.empty((n, 4))
    P = np.empty((n, 4, 4))
    flags = np.zeros(n, np.uint8)
    for k in range(n):
        ok, v, s = _chol_inv_solve4(
            (
                Y[k, 0, 0],
                0.5 * (Y[k, 1, 0] + Y[k, 0, 1]),
                Y[k, 1, 1],
                0.5 * (Y[k, 2, 0] + Y[k, 0, 2]),
                0.5 * (Y[k, 2, 1] + Y[k, 1, 2]),
                Y[k, 2, 2],
                0.5 * (Y[k, 3, 0] + Y[k, 0, 3]),
                0.5 * (Y[k, 3, 1] + Y[k, 1, 3]),
                0.5 * (Y[k, 3, 2] + Y[k, 2, 3]),
                Y[k, 3, 3],
            ),
            (y[k, 0], y[k, 1], y[k, 2], y[k, 3]),
        )
        if not ok:
            flags[k] = _POSTERIOR
        _store_sym4(P, k, v)
        _store4(x, k, s)
    return x, P, flags


@numba.njit(cache=True, fastmath=False)
def cv_predicted_position(x, dt):
    """Predicted positions ``(F x)[:2] = [x + dt·vx, y + dt·vy]`` (N, 2): where to linearise eq. 6."""
    n = x.shape[0]
    out = np.empty((n, 2))
    for k in range(n):
        out[k, 0] = x[k, 0] + dt * x[k, 2]
        out[k, 1] = x[k, 1] + dt * x[k, 3]
    return out


@numba.njit(cache=True, fastmath=False)
def cv_cycle(Y, y, x, P, dt, q, I, i):
    """One CV information-filter cycle for N agents, **in place** on ``Y, y, x, P``; returns flags (N,).

    Inputs: posterior information ``Y`` (N, 4, 4), ``y`` (N, 4) and its moments ``x = Y⁻¹ y`` (N, 4),
    ``P = Y⁻¹`` (N, 4, 4) (from the previous call or :func:`cv_recover`); period ``dt``; ``q`` (4,) the
    diagonal of ``Q``; fused position-block information ``I`` (N, 2, 2), ``i`` (N, 2) linearised at
    ``cv_predicted_position(x, dt)``. Per agent (symmetric parts of ``P`` and ``I`` are used)::

        x⁻ = F x,  P⁻ = F P Fᵀ + Q,  Y⁻ = (P⁻)⁻¹,  y⁻ = (P⁻)⁻¹ x⁻        (L24 Sec. 3.1, Cholesky of P⁻)
        Y = Y⁻ + [[I, 0], [0, 0]],  y = y⁻ + [i, 0]                        (L24 eq. 7)
        P = Y⁻¹,  x = Y⁻¹ y                                                (recover, Cholesky of Y)

    with ``F = [[1, 0, dt, 0], [0, 1, 0, dt], [0, 0, 1, 0], [0, 0, 0, 1]]``. On failure the agent's flag
    gets :data:`PREDICT_NOT_PD` (then ``Y, y, x, P`` are all NaN) or :data:`POSTERIOR_NOT_PD` (then
    ``Y, y`` hold the offending posterior information and ``x, P`` are NaN).
    """
    n = Y.shape[0]
    flags = np.zeros(n, np.uint8)
    T = dt
    q0 = q[0]
    q1 = q[1]
    q2 = q[2]
    q3 = q[3]
    for k in range(n):
        # Posterior moments (symmetric part of P).
        p00 = P[k, 0, 0]
        p10 = 0.5 * (P[k, 1, 0] + P[k, 0, 1])
        p11 = P[k, 1, 1]
        p20 = 0.5 * (P[k, 2, 0] + P[k, 0, 2])
        p21 = 0.5 * (P[k, 2, 1] + P[k, 1, 2])
        p22 = P[k, 2, 2]
        p30 = 0.5 * (P[k, 3, 0] + P[k, 0, 3])
        p31 = 0.5 * (P[k, 3, 1] + P[k, 1, 3])
        p32 = 0.5 * (P[k, 3, 2] + P[k, 2, 3])
        p33 = P[k, 3, 3]
        # x⁻ = F x.
        xp0 = x[k, 0] + T * x[k, 2]
        xp1 = x[k, 1] + T * x[k, 3]
        xp2 = x[k, 2]
        xp3 = x[k, 3]
        # P⁻ = F P Fᵀ + Q with the CV structure: rows 0, 1 of F P are P0 + T P2, P1 + T P3.
        g00 = p00 + T * p20
        g02 = p20 + T * p22
        g10 = p10 + T * p30
        g12 = p21 + T * p32
        g11 = p11 + T * p31
        g13 = p31 + T * p33
        ok, v, s = _chol_inv_solve4(
            (
                g00 + T * g02 + q0,
                g10 + T * g12,
                g11 + T * g13 + q1,
                p20 + T * p22,
                p21 + T * p32,
                p22 + q2,
                p30 + T * p32,
                p31 + T * p33,
                p32,
                p33 + q3,
            ),
            (xp0, xp1, xp2, xp3),
        )
        if not ok:
            flags[k] = _PREDICT
            _store_sym4(Y, k, _NAN10)
            _store4(y, k, _NAN4)
            _store_sym4(P, k, _NAN10)
            _store4(x, k, _NAN4)
            continue
        # Update (eq. 7): add the fused position-block information.
        Yk = (
            v[0] + I[k, 0, 0],
            v[1] + 0.5 * (I[k, 1, 0] + I[k, 0, 1]),
            v[2] + I[k, 1, 1],
            v[3],
            v[4],
            v[5],
            v[6],
            v[7],
            v[8],
            v[9],
        )
        yk = (s[0] + i[k, 0], s[1] + i[k, 1], s[2], s[3])
        _store_sym4(Y, k, Yk)
        _store4(y, k, yk)
        # Recover x, P from the posterior information.
        ok, v, s = _chol_inv_solve4(Yk, yk)
        if not ok:
            flags[k] = _POSTERIOR
        _store_sym4(P, k, v)
        _store4(x, k, s)
    return flags


@numba.njit(cache=True, fastmath=False)
def cv_position_contributions(x_pred_pos, sensor_pos, z, sigma_range, sigma_bearing, min_range, own_var=0.0):
    """Position-mode measurement information ``I`` (N, 2, 2), ``i`` (N, 2) (L24 eq. 6, L24 Sec. 4).

    Matches ``RangeBearingUpdate(sigma_range, sigma_bearing, "position", min_range).contributions`` for
    ``x_pred_pos``, ``sensor_pos``, ``z = [range, bearing]`` all (N, 2): with ``ρ̂, β̂`` the predicted range
    (floored at ``min_range``) and bearing from the sensor, ``R = Λ diag(σr², ρ̂²σβ²) Λᵀ``, ``I = R⁻¹``
    (computed as ``Λ diag(1/σr², 1/(ρ̂²σβ²)) Λᵀ``) and ``i = I · (sensor + z_ρ (cos z_β, sin z_β))``; ``own_var``:
    the UAV's own position variance per axis, added to both (isotropic, so exactly ``R + own_var I``).
    """
    n = x_pred_pos.shape[0]
    I = np.empty((n, 2, 2))
    iv = np.empty((n, 2))
    wr = 1.0 / (sigma_range * sigma_range + own_var)
    sb2 = sigma_bearing * sigma_bearing
    for k in range(n):
        sx = sensor_pos[k, 0]
        sy = sensor_pos[k, 1]
        dx = x_pred_pos[k, 0] - sx
        dy = x_pred_pos[k, 1] - sy
        r = math.hypot(dx, dy)
        if r > 0.0:
            c = dx / r
            s = dy / r
        else:  # atan2(0, 0) = 0 in the reference
            c = 1.0
            s = 0.0
        rho = max(max(r, min_range), _POSITION_COV_FLOOR)
        wt = 1.0 / (rho * rho * sb2 + own_var)
        I00 = wr * c * c + wt * s * s
        I11 = wr * s * s + wt * c * c
        I01 = (wr - wt) * c * s
        zr = z[k, 0]
        zb = z[k, 1]
        px = sx + zr * math.cos(zb)
        py = sy + zr * math.sin(zb)
        I[k, 0, 0] = I00
        I[k, 0, 1] = I01
        I[k, 1, 0] = I01
        I[k, 1, 1] = I11
        iv[k, 0] = I00 * px + I01 * py
        iv[k, 1] = I01 * px + I11 * py
    return I, iv


def _f64(a, shape, name):
    arr = np.ascontiguousarray(a, dtype=np.float64)
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    return arr


def cv_information_cycle(Y, y, dt, q, I, i, x=None, P=None):
    """One CV information-filter cycle for a bank of N agents (fast path of the reference cycle).

    Equations (L24 Sec. 3.1 prediction from the posterior moments; L24 eqs. 6-7 update)::

        x(k|k-1) = F x(k-1|k-1)
        P(k|k-1) = F P(k-1|k-1) Fᵀ + Q,                 Q = diag(q)
        Y(k|k-1) = P(k|k-1)⁻¹,     y(k|k-1) = Y(k|k-1) x(k|k-1)
        Y(k|k)   = Y(k|k-1) + Σ_j Hᵀ I_j H,   y(k|k) = y(k|k-1) + Σ_j Hᵀ i_j      (H = [I₂ 0])
        P(k|k)   = Y(k|k)⁻¹,       x(k|k) = P(k|k) y(k|k)

    ``I`` (N, 2, 2), ``i`` (N, 2) are the already fused (own + neighbours') position-block contributions
    ``Σ_j I_j, Σ_j i_j`` (eq. 6, e.g. from :func:`cv_position_contributions` at
    :func:`cv_predicted_position`). ``x, P`` are the posterior moments of ``Y, y``; when either is None they
    are recovered from ``Y, y`` first (one more Cholesky per agent).

    Returns ``(Y, y, x, P, flags)``: the posterior information and moments, and the per-agent ``uint8``
    flags (0 = fine, else :data:`PREDICT_NOT_PD` / :data:`POSTERIOR_NOT_PD` bits; flagged agents carry
    NaNs, see :func:`cv_cycle`). Arrays that are already C-contiguous float64 of the right shape are
    updated in place; others are copied, so always use the returned arrays.
    """
    Y = _f64(Y, np.shape(Y)[:1] + (4, 4), "Y")
    n = Y.shape[0]
    y = _f64(y, (n, 4), "y")
    I = _f64(I, (n, 2, 2), "I")
    i = _f64(i, (n, 2), "i")
    q = np.ascontiguousarray(np.broadcast_to(np.asarray(q, dtype=np.float64), (4,)))
    dt = float(dt)
    if x is None or P is None:
        x, P, flags0 = cv_recover(Y, y)
    else:
        x = _f64(x, (n, 4), "x")
        P = _f64(P, (n, 4, 4), "P")
        flags0 = None
    flags = cv_cycle(Y, y, x, P, dt, q, I, i)
    if flags0 is not None:
        flags |= flags0
    return Y, y, x, P, flags


@numba.njit(cache=True, fastmath=False)
def position_nis(z, sensor_pos, x_pred_pos, P, F2, Q2, I):
    """Compiled twin of :meth:`swarmtrack.estimation.information.InformationEstimator._own_nis` for a linear
    model: the NIS (N,) of each agent's own converted range-bearing measurement, ``νᵀ S⁻¹ ν`` with
    ``ν = q(z) − x̂(k|k−1)[:2]`` and ``S = I⁻¹ + (F P Fᵀ + Q)[:2, :2]`` (``F2 = F[:2]``, ``Q2 = Q[:2, :2]``)."""
    n, dim = P.shape[0], P.shape[1]
    out = np.empty(n)
    for k in range(n):
        p00 = 0.0
        p01 = 0.0
        p11 = 0.0
        for a in range(dim):  # (F2 P F2ᵀ), symmetric 2 x 2
            fa0 = 0.0
            fa1 = 0.0
            for b in range(dim):
                fa0 += P[k, a, b] * F2[0, b]
                fa1 += P[k, a, b] * F2[1, b]
            p00 += F2[0, a] * fa0
            p01 += F2[0, a] * fa1
            p11 += F2[1, a] * fa1
        a_ = I[k, 0, 0]
        b_ = I[k, 0, 1]
        d_ = I[k, 1, 1]
        det_i = a_ * d_ - b_ * b_
        s00 = d_ / det_i + p00 + Q2[0, 0]
        s01 = -b_ / det_i + p01 + Q2[0, 1]
        s11 = a_ / det_i + p11 + Q2[1, 1]
        n0 = sensor_pos[k, 0] + z[k, 0] * math.cos(z[k, 1]) - x_pred_pos[k, 0]
        n1 = sensor_pos[k, 1] + z[k, 0] * math.sin(z[k, 1]) - x_pred_pos[k, 1]
        out[k] = (n0 * n0 * s11 - 2.0 * n0 * n1 * s01 + n1 * n1 * s00) / (s00 * s11 - s01 * s01)
    return out


def _ldl_check_source(name: str, n: int) -> str:
    """Source of a straight-line positive-definiteness check of a symmetric ``n x n`` matrix (see
    :data:`_positive_definite12`): the right-looking LDLᵀ elimination with every entry a local variable.

    Written out because numba keeps the looped factorisation's scratch matrix in memory and does not vectorise
    its triangular loops; the unrolled one runs in registers, about 3x faster at n = 12.
    """
    lines = [f"def {name}(A):"]
    for r in range(n):
        lines.append("    " + "; ".join(f"a{r}_{c} = A[{r}, {c}]" for c in range(r + 1)))
    lines.append("    ok = True")
    for j in range(n):
        lines.append(f"    d = a{j}_{j}")
        lines.append("    ok &= (d > 0.0) & (d < _INF)")
        if j == n - 1:
            break
        lines.append("    rd = 1.0 / d")
        for c in range(j + 1, n):  # trailing lower triangle -= l_c a_·j, l_c = a_cj / d
            lines.append(f"    l = a{c}_{j} * rd")
            lines.append("    " + "; ".join(f"a{r}_{c} -= a{r}_{j} * l" for r in range(c, n)))
    lines.append("    return ok")
    return "\n".join(lines) + "\n"


#: E = F − I of the FS model (models/fs.py: jacobian) as (row, column, name of the value in fs_cycle); T = thrust.
_FS_E = ((0, 2, "dt"), (1, 3, "dt"), (2, 6, "e26"), (2, 11, "e2T"), (3, 5, "e35"), (3, 6, "e36"), (3, 11, "e3T"),
         (4, 5, "e45"), (4, 6, "e46"), (4, 11, "e4T"), (5, 7, "dt"), (6, 8, "dt"), (7, 9, "e79"), (8, 10, "e8X"))


def _predicted_covariance_source(name: str, n: int, pattern) -> str:
    """Source of ``name(P, k, A, q, values)``: ``A = F S Fᵀ + diag(q)`` for ``S`` the symmetric part of ``P[k]``
    and ``F = I + E``, ``E`` sparse with ``pattern`` ((row, column, value name), ...), ``values`` the tuple of the
    named values in their order of first appearance; every entry a local.

    ``G = F S = S + E S`` on the rows E touches, then ``A = G Fᵀ = G + G Eᵀ`` on the lower triangle, mirrored
    (``A`` exactly symmetric). The same arithmetic as the looped form, about 8 % faster for FS.
    """
    rows: dict = {}
    for r, c, v in pattern:
        rows.setdefault(r, []).append((c, v))
    names = tuple(dict.fromkeys(v for _, _, v in pattern))

    def s(a, c):
        return f"s{max(a, c)}_{min(a, c)}"

    def g(a, c):
        return f"g{a}_{c}" if a in rows else s(a, c)

    lines = [f"def {name}(P, k, A, q, values):", f"    {', '.join(names)}, = values"]
    for a in range(n):
        lines.append("    " + "; ".join(f"s{a}_{c} = 0.5 * (P[k, {a}, {c}] + P[k, {c}, {a}])" for c in range(a + 1)))
    for a in sorted(rows):
        terms = lambda c, a=a: " + ".join([s(a, c)] + [f"{v} * {s(e, c)}" for e, v in rows[a]])  # noqa: E731
        lines.append("    " + "; ".join(f"g{a}_{c} = {terms(c)}" for c in range(n)))
    for a in range(n):
        for c in range(a + 1):
            expr = " + ".join([g(a, c)] + [f"{v} * {g(a, e)}" for e, v in rows.get(c, [])])
            if a == c:
                lines.append(f"    A[{a}, {a}] = {expr} + q[{a}]")
            else:
                lines.append(f"    v = {expr}")
                lines.append(f"    A[{a}, {c}] = v; A[{c}, {a}] = v")
    return "\n".join(lines) + "\n"


# The generated helpers are compiled under a pseudo file name (tracebacks do not point into this file's lines);
# fs_cycle's cache holds their code. The LDLᵀ check is a call, not inlined: fs_cycle compiles in ~7 s, not ~11 s.
_namespace = {"_INF": _INF}
for _source in (_ldl_check_source("_positive_definite12", 12),
                _predicted_covariance_source("_fs_predicted_covariance", 12, _FS_E)):
    exec(compile(_source, "<generated in swarmtrack.estimation.kernels>", "exec"), _namespace)
del _source
#: ``_positive_definite12(A)``: whether the symmetric 12 x 12 ``A`` (lower triangle read) is positive definite and
#: finite, i.e. every LDLᵀ pivot (the square of a Cholesky pivot) is > 0 and < inf. A NaN or inf anywhere in the
#: lower triangle reaches a later pivot (as NaN or -inf), so the pivots alone carry the finiteness check.
_positive_definite12 = numba.njit(fastmath=False)(_namespace.pop("_positive_definite12"))
#: ``_fs_predicted_covariance(P, k, A, q, (dt, e26, …))``: FS's ``P⁻ = F P Fᵀ + Q`` of agent ``k`` into ``A`` (12, 12).
_fs_predicted_covariance = numba.njit(fastmath=False, inline="always")(_namespace.pop("_fs_predicted_covariance"))


@numba.njit(cache=True, fastmath=False)
def fs_cycle(x, P, dt, q, I, i, mass, Ixx, Iyy, g, w_vz):
    """One full-state (FS) quadrotor filter cycle for N agents, **in place** on ``x, P`` (12 states,
    :class:`~swarmtrack.models.fs.FullStateQuadrotor`); returns flags (N,) as :func:`cv_cycle`.

    The same cycle as the information-form reference (``predict`` → ``add_position_information`` → the fake
    ``vz = 0`` measurement → ``recover``), written in covariance form so that no 12 x 12 matrix is inverted:

        x⁻ = f(x),  P⁻ = F P Fᵀ + Q     (F = I + E: E's 14 entries only, _FS_E)
        M = U Λ Uᵀ,  U = [e_x, e_y, e_vz],  Λ = blockdiag(I, w_vz)     (the added information, rank ≤ 3)
        P = P⁻ − P⁻ U D Uᵀ P⁻,  D = C⁻¹ Λ,  C = I₃ + Λ Uᵀ P⁻ U        (Woodbury: P = (P⁻⁻¹ + M)⁻¹; D symmetric)
        x = x⁻ + P (u − M x⁻),  u = [i, 0, …]                         (x = P (Y⁻ x⁻ + u))

    ``I, i`` are linearised at ``cv_predicted_position(x, dt)`` (FS's position rows are CV's). A flag is set when
    ``P⁻`` or ``P`` is not positive definite (an LDLᵀ pivot ≤ 0) or not finite; that agent's ``x, P`` are NaN.
    Only the symmetric part of the given ``P`` is read; ``P⁻`` and ``P`` are computed on one triangle and mirrored.
    """
    n = x.shape[0]
    d = 12
    flags = np.zeros(n, np.uint8)
    A = np.empty((d, d))
    xp = np.empty(d)
    PU = np.empty((d, 3))
    W = np.empty((d, 3))
    e79 = dt / Ixx
    e8X = dt / Iyy
    for k in range(n):
        phi, theta, thrust = x[k, 5], x[k, 6], x[k, 11]
        sphi, cphi, sth, cth = math.sin(phi), math.cos(phi), math.sin(theta), math.cos(theta)
        for a in range(d):
            xp[a] = x[k, a]
        xp[0] += dt * x[k, 2]
        xp[1] += dt * x[k, 3]
        xp[2] += dt * thrust / mass * sth
        xp[3] -= dt * thrust / mass * sphi * cth
        xp[4] += dt * (-g + cphi * cth * thrust / mass)
        xp[5] += dt * x[k, 7]
        xp[6] += dt * x[k, 8]
        xp[7] += dt * x[k, 9] / Ixx
        xp[8] += dt * x[k, 10] / Iyy
        # E's state-dependent entries (models/fs.py: jacobian); e_rc is E[r, c], T the thrust (state 11)
        e26 = dt * thrust / mass * cth
        e2T = dt / mass * sth
        e35 = -dt * thrust / mass * cphi * cth
        e36 = dt * thrust / mass * sphi * sth
        e3T = -dt / mass * sphi * cth
        e45 = -dt * thrust / mass * sphi * cth
        e46 = -dt * thrust / mass * cphi * sth
        e4T = dt / mass * cphi * cth
        _fs_predicted_covariance(P, k, A, q, (dt, e26, e2T, e35, e36, e3T, e45, e46, e4T, e79, e8X))
        if not _positive_definite12(A):
            flags[k] = _PREDICT
            _fill_nan(x, P, k)
            continue
        # Woodbury with U = [e_x, e_y, e_vz], Λ = blockdiag(I, w_vz)
        l00 = I[k, 0, 0]
        l11 = I[k, 1, 1]
        l01 = 0.5 * (I[k, 0, 1] + I[k, 1, 0])
        for a in range(d):  # P⁻ U
            PU[a, 0] = A[a, 0]
            PU[a, 1] = A[a, 1]
            PU[a, 2] = A[a, 4]
        # D = C⁻¹ Λ, C = I₃ + Λ Uᵀ P⁻ U, by Gaussian elimination with partial pivoting on [C | Λ]; D's symmetric part
        (d00, d01, d02), (d10, d11, d12), (d20, d21, d22) = _solve3(
            (1.0 + (l00 * A[0, 0] + l01 * A[1, 0]), l00 * A[0, 1] + l01 * A[1, 1], l00 * A[0, 4] + l01 * A[1, 4],
             l00, l01, 0.0),
            (l01 * A[0, 0] + l11 * A[1, 0], 1.0 + (l01 * A[0, 1] + l11 * A[1, 1]), l01 * A[0, 4] + l11 * A[1, 4],
             l01, l11, 0.0),
            (w_vz * A[4, 0], w_vz * A[4, 1], 1.0 + w_vz * A[4, 4], 0.0, 0.0, w_vz))
        d01 = 0.5 * (d01 + d10)
        d02 = 0.5 * (d02 + d20)
        d12 = 0.5 * (d12 + d21)
        # innovation in information units: u − M x⁻ on the U coordinates
        r0 = i[k, 0] - (l00 * xp[0] + l01 * xp[1])
        r1 = i[k, 1] - (l01 * xp[0] + l11 * xp[1])
        r2 = -w_vz * xp[4]
        for a in range(d):  # W = P⁻ U D
            p0, p1, p2 = PU[a, 0], PU[a, 1], PU[a, 2]
            W[a, 0] = p0 * d00 + p1 * d01 + p2 * d02
            W[a, 1] = p0 * d01 + p1 * d11 + p2 * d12
            W[a, 2] = p0 * d02 + p1 * d12 + p2 * d22
        for a in range(d):  # P = P⁻ − W (P⁻ U)ᵀ, lower triangle mirrored
            w0, w1, w2 = W[a, 0], W[a, 1], W[a, 2]
            for b in range(a + 1):
                v = A[a, b] - (w0 * PU[b, 0] + w1 * PU[b, 1] + w2 * PU[b, 2])
                P[k, a, b] = v
                P[k, b, a] = v
        for a in range(d):  # x = x⁻ + P U r (r on the U coordinates)
            x[k, a] = xp[a] + P[k, a, 0] * r0 + P[k, a, 1] * r1 + P[k, a, 4] * r2
        if not _positive_definite12(P[k]):
            flags[k] = _POSTERIOR
            _fill_nan(x, P, k)
    return flags


@numba.njit(cache=True, fastmath=False, inline="always")
def _solve3(r0, r1, r2):
    """``X = C⁻¹ B`` for 3 x 3 ``C, B`` given as the rows of ``[C | B]`` (three 6-tuples), by Gaussian elimination
    with partial pivoting; returns the rows of ``X`` (three 3-tuples). Scalars only: no scratch arrays."""
    if abs(r1[0]) > abs(r0[0]):  # pivot of column 0: the first row of largest magnitude
        if abs(r2[0]) > abs(r1[0]):
            r0, r2 = r2, r0
        else:
            r0, r1 = r1, r0
    elif abs(r2[0]) > abs(r0[0]):
        r0, r2 = r2, r0
    f = r1[0] / r0[0]
    r1 = (0.0, r1[1] - f * r0[1], r1[2] - f * r0[2], r1[3] - f * r0[3], r1[4] - f * r0[4], r1[5] - f * r0[5])
    f = r2[0] / r0[0]
    r2 = (0.0, r2[1] - f * r0[1], r2[2] - f * r0[2], r2[3] - f * r0[3], r2[4] - f * r0[4], r2[5] - f * r0[5])
    if abs(r2[1]) > abs(r1[1]):
        r1, r2 = r2, r1
    f = r2[1] / r1[1]
    r2 = (0.0, 0.0, r2[2] - f * r1[2], r2[3] - f * r1[3], r2[4] - f * r1[4], r2[5] - f * r1[5])
    x20 = r2[3] / r2[2]
    x21 = r2[4] / r2[2]
    x22 = r2[5] / r2[2]
    x10 = (r1[3] - r1[2] * x20) / r1[1]
    x11 = (r1[4] - r1[2] * x21) / r1[1]
    x12 = (r1[5] - r1[2] * x22) / r1[1]
    x00 = (r0[3] - r0[1] * x10 - r0[2] * x20) / r0[0]
    x01 = (r0[4] - r0[1] * x11 - r0[2] * x21) / r0[0]
    x02 = (r0[5] - r0[1] * x12 - r0[2] * x22) / r0[0]
    return (x00, x01, x02), (x10, x11, x12), (x20, x21, x22)


@numba.njit(cache=True, fastmath=False)
def _fill_nan(x, P, k):
    for a in range(x.shape[1]):
        x[k, a] = _NAN
        for b in range(x.shape[1]):
            P[k, a, b] = _NAN


def check_flags(flags, t: float) -> None:
    """Raise the reference's ``FilterDivergence`` naming the agents whose kernel flag is set."""
    flags = np.asarray(flags)
    if not flags.any():
        return
    bad = np.flatnonzero(flags)
    what = []
    if (flags & PREDICT_NOT_PD).any():
        what.append("predicted covariance is not positive definite")
    if (flags & POSTERIOR_NOT_PD).any():
        what.append("information matrix is not positive definite")
    raise FilterDivergence(bad, t, " / ".join(what))


__all__ = [
    "POSTERIOR_NOT_PD",
    "PREDICT_NOT_PD",
    "check_flags",
    "cv_cycle",
    "cv_information_cycle",
    "cv_position_contributions",
    "cv_predicted_position",
    "cv_recover",
    "fs_cycle",
    "position_nis",
]
