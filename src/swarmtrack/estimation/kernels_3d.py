"""Compiled fast path of the 3-D constant-velocity filter with the range-bearing-elevation update (numba).

The readable reference is :mod:`swarmtrack.estimation.information` (``recover``, ``predict``) with
:mod:`swarmtrack.estimation.elevation` (the update in information form); these kernels compute the same cycle for
``cv3d`` (state ``[x, y, vx, vy, z, vz]``, :mod:`swarmtrack.models.three_d`) with a diagonal ``Q`` and the
``position`` update, one agent at a time, and the tests hold them to it::

    x_pred = cv3d_predicted_position(x, dt)                            # F x, position part
    I, i = cv3d_position_contributions(x_pred, sensor, z, σr, σβ, σε)  # own measurement information (eq. 6)
    ... add the neighbours' I, i (fusion by plain sums, eq. 7) ...
    flags = cv3d_cycle(x, P, dt, q, I, i)                              # predict + update, in place

As :func:`~swarmtrack.estimation.kernels.fs_cycle`, the cycle is written in covariance form with the rank-3
position update done by Woodbury's identity, so no 6 x 6 matrix is inverted; flags as
:func:`~swarmtrack.estimation.kernels.cv_cycle` (:func:`~swarmtrack.estimation.kernels.check_flags` reads them).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from swarmtrack.estimation.kernels import (
    _INF,
    _POSTERIOR,
    _PREDICT,
    _fill_nan,
    _ldl_check_source,
    _predicted_covariance_source,
    _solve3,
)

#: E = F − I of ``cv3d``: each position row takes ``dt`` times its velocity.
_CV3D_E = ((0, 2, "dt"), (1, 3, "dt"), (4, 5, "dt"))
#: The position states ``[x, y, z]`` of ``cv3d``.
_X, _Y, _Z = 0, 1, 4

_namespace = {"_INF": _INF}
for _source in (_ldl_check_source("_positive_definite6", 6),
                _predicted_covariance_source("_cv3d_predicted_covariance", 6, _CV3D_E)):
    exec(compile(_source, "<generated in swarmtrack.estimation.kernels_3d>", "exec"), _namespace)
del _source
_positive_definite6 = numba.njit(fastmath=False, inline="always")(_namespace.pop("_positive_definite6"))
_cv3d_predicted_covariance = numba.njit(fastmath=False, inline="always")(
    _namespace.pop("_cv3d_predicted_covariance"))


@numba.njit(cache=True, fastmath=False)
def cv3d_predicted_position(x, dt):
    """Predicted positions ``[x + dt·vx, y + dt·vy, z + dt·vz]`` (N, 3): where to linearise the update."""
    n = x.shape[0]
    out = np.empty((n, 3))
    for k in range(n):
        out[k, 0] = x[k, 0] + dt * x[k, 2]
        out[k, 1] = x[k, 1] + dt * x[k, 3]
        out[k, 2] = x[k, 4] + dt * x[k, 5]
    return out


@numba.njit(cache=True, fastmath=False)
def cv3d_position_contributions(x_pred_pos, sensor_pos, z, sigma_range, sigma_bearing, sigma_elevation, min_range,
                                own_var=0.0):
    """Position-mode information ``I`` (N, 3, 3), ``i`` (N, 3) of ``z = [ρ, β, ε]`` (N, 3): the compiled
    ``RangeBearingElevationUpdate(σr, σβ, σε, "position", min_range, own_sigma).contributions``.

    With the predicted line of sight ``u``, its horizontal normal ``v`` and vertical normal ``w`` (orthonormal),
    ``I = u uᵀ/(σr² + o) + v vᵀ/(max(ρ̂ cos ε̂, m)² σβ² + o) + w wᵀ/(ρ̂² σε² + o)`` (``ρ̂`` floored at ``m =
    min_range``, ``o = own_var``) and ``i = I (sensor + z_ρ (cos z_ε cos z_β, cos z_ε sin z_β, sin z_ε))``."""
    n = x_pred_pos.shape[0]
    I = np.empty((n, 3, 3))
    iv = np.empty((n, 3))
    wr = 1.0 / (sigma_range * sigma_range + own_var)
    sb2 = sigma_bearing * sigma_bearing
    se2 = sigma_elevation * sigma_elevation
    for k in range(n):
        sx, sy, sz = sensor_pos[k, 0], sensor_pos[k, 1], sensor_pos[k, 2]
        dx, dy, dz = x_pred_pos[k, 0] - sx, x_pred_pos[k, 1] - sy, x_pred_pos[k, 2] - sz
        horizontal = math.hypot(dx, dy)
        r = math.hypot(horizontal, dz)
        cb, sb = (dx / horizontal, dy / horizontal) if horizontal > 0.0 else (1.0, 0.0)  # atan2(0, 0) = 0
        ce, se = (horizontal / r, dz / r) if r > 0.0 else (1.0, 0.0)
        rho = max(r, min_range)
        lever = max(rho * ce, min_range)
        wb = 1.0 / (lever * lever * sb2 + own_var)
        we = 1.0 / (rho * rho * se2 + own_var)
        u0, u1, u2 = ce * cb, ce * sb, se
        w0, w1, w2 = -se * cb, -se * sb, ce
        i00 = wr * u0 * u0 + wb * sb * sb + we * w0 * w0
        i01 = wr * u0 * u1 - wb * sb * cb + we * w0 * w1
        i02 = wr * u0 * u2 + we * w0 * w2
        i11 = wr * u1 * u1 + wb * cb * cb + we * w1 * w1
        i12 = wr * u1 * u2 + we * w1 * w2
        i22 = wr * u2 * u2 + we * w2 * w2
        zr, zb, ze = z[k, 0], z[k, 1], z[k, 2]
        flat = zr * math.cos(ze)
        px, py, pz = sx + flat * math.cos(zb), sy + flat * math.sin(zb), sz + zr * math.sin(ze)
        I[k, 0, 0], I[k, 1, 1], I[k, 2, 2] = i00, i11, i22
        I[k, 0, 1], I[k, 1, 0] = i01, i01
        I[k, 0, 2], I[k, 2, 0] = i02, i02
        I[k, 1, 2], I[k, 2, 1] = i12, i12
        iv[k, 0] = i00 * px + i01 * py + i02 * pz
        iv[k, 1] = i01 * px + i11 * py + i12 * pz
        iv[k, 2] = i02 * px + i12 * py + i22 * pz
    return I, iv


@numba.njit(cache=True, fastmath=False)
def cv3d_cycle(x, P, dt, q, I, i):
    """One ``cv3d`` filter cycle for N agents, **in place** on ``x`` (N, 6), ``P`` (N, 6, 6); returns flags (N,).

    The information-form reference's cycle (``predict`` → ``add_position_information`` at ``[x, y, z]`` →
    ``recover``) in covariance form, with ``U = [e_x, e_y, e_z]`` and ``Λ`` the fused 3 x 3 information ``I``::

        x⁻ = F x,  P⁻ = F P Fᵀ + diag(q)
        P = P⁻ − P⁻ U D Uᵀ P⁻,  D = C⁻¹ Λ,  C = I₃ + Λ Uᵀ P⁻ U     (Woodbury: P = (P⁻⁻¹ + U Λ Uᵀ)⁻¹)
        x = x⁻ + P U (i − Λ Uᵀ x⁻)                                 (x = P (P⁻⁻¹ x⁻ + U i))

    ``I, i`` linearised at :func:`cv3d_predicted_position`. A flag is set when ``P⁻`` or ``P`` is not positive
    definite or not finite; that agent's ``x, P`` are NaN."""
    n = x.shape[0]
    d = 6
    flags = np.zeros(n, np.uint8)
    A = np.empty((d, d))
    xp = np.empty(d)
    PU = np.empty((d, 3))
    for k in range(n):
        for a in range(d):
            xp[a] = x[k, a]
        xp[0] += dt * x[k, 2]
        xp[1] += dt * x[k, 3]
        xp[4] += dt * x[k, 5]
        _cv3d_predicted_covariance(P, k, A, q, (dt,))
        if not _positive_definite6(A):
            flags[k] = _PREDICT
            _fill_nan(x, P, k)
            continue
        l00, l11, l22 = I[k, 0, 0], I[k, 1, 1], I[k, 2, 2]
        l01 = 0.5 * (I[k, 0, 1] + I[k, 1, 0])
        l02 = 0.5 * (I[k, 0, 2] + I[k, 2, 0])
        l12 = 0.5 * (I[k, 1, 2] + I[k, 2, 1])
        for a in range(d):  # P⁻ U
            PU[a, 0] = A[a, _X]
            PU[a, 1] = A[a, _Y]
            PU[a, 2] = A[a, _Z]
        s00, s01, s02 = A[_X, _X], A[_X, _Y], A[_X, _Z]
        s11, s12, s22 = A[_Y, _Y], A[_Y, _Z], A[_Z, _Z]
        # D = C⁻¹ Λ, C = I₃ + Λ S (S = Uᵀ P⁻ U), on the rows of [C | Λ]; D's symmetric part
        (d00, d01, d02), (d10, d11, d12), (d20, d21, d22) = _solve3(
            (1.0 + (l00 * s00 + l01 * s01 + l02 * s02), l00 * s01 + l01 * s11 + l02 * s12,
             l00 * s02 + l01 * s12 + l02 * s22, l00, l01, l02),
            (l01 * s00 + l11 * s01 + l12 * s02, 1.0 + (l01 * s01 + l11 * s11 + l12 * s12),
             l01 * s02 + l11 * s12 + l12 * s22, l01, l11, l12),
            (l02 * s00 + l12 * s01 + l22 * s02, l02 * s01 + l12 * s11 + l22 * s12,
             1.0 + (l02 * s02 + l12 * s12 + l22 * s22), l02, l12, l22))
        d01 = 0.5 * (d01 + d10)
        d02 = 0.5 * (d02 + d20)
        d12 = 0.5 * (d12 + d21)
        # the innovation in information units, i − Λ Uᵀ x⁻
        r0 = i[k, 0] - (l00 * xp[_X] + l01 * xp[_Y] + l02 * xp[_Z])
        r1 = i[k, 1] - (l01 * xp[_X] + l11 * xp[_Y] + l12 * xp[_Z])
        r2 = i[k, 2] - (l02 * xp[_X] + l12 * xp[_Y] + l22 * xp[_Z])
        for a in range(d):  # P = P⁻ − (P⁻ U D)(P⁻ U)ᵀ, lower triangle mirrored
            p0, p1, p2 = PU[a, 0], PU[a, 1], PU[a, 2]
            w0 = p0 * d00 + p1 * d01 + p2 * d02
            w1 = p0 * d01 + p1 * d11 + p2 * d12
            w2 = p0 * d02 + p1 * d12 + p2 * d22
            for b in range(a + 1):
                v = A[a, b] - (w0 * PU[b, 0] + w1 * PU[b, 1] + w2 * PU[b, 2])
                P[k, a, b] = v
                P[k, b, a] = v
        for a in range(d):
            x[k, a] = xp[a] + P[k, a, _X] * r0 + P[k, a, _Y] * r1 + P[k, a, _Z] * r2
        if not _positive_definite6(P[k]):
            flags[k] = _POSTERIOR
            _fill_nan(x, P, k)
    return flags


__all__ = ["cv3d_cycle", "cv3d_position_contributions", "cv3d_predicted_position"]
