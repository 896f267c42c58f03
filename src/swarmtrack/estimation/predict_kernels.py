"""Compiled prediction of a bank of filters of one motion model (numba): ``f(x)``, the Jacobian ``F`` and
``F P Fᵀ + Q`` (symmetrised) in one call, for the CV, CA, CT and FS models.

The readable references are the models' ``f``/``jacobian`` (:mod:`swarmtrack.models`) and
:func:`swarmtrack.estimation.kalman.ekf_predict` / :func:`swarmtrack.estimation.information.predict`. The kernels
here compute the same numbers **bit for bit** on a machine whose numpy matrix products are OpenBLAS's ``gemm``
with fused multiply-adds summed in index order (the x86-64 Haswell and later kernels, this project's machines):
every product below is written as that sequence of ``fma`` (:func:`fma`, LLVM's ``llvm.fma.f64``), the
elementwise formulas in numpy's order of operations, and ``sin``, ``cos`` from the same libm. A numpy product of a
single row (``x Fᵀ`` of a one-filter bank) is a ``gemv``, summed without fused multiply-adds, and so is it here.
On another BLAS the results agree to rounding (≤ 1e-12 relative, ``tests/estimation/test_predict_kernels.py``
states the tolerance it holds there). The tests compare the kernels with the references on random inputs and on
a short run.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.core.extending import intrinsic

from swarmtrack.models.ca import ConstantAcceleration
from swarmtrack.models.ct import SMALL_TURN, ConstantTurn
from swarmtrack.models.cv import ConstantVelocity
from swarmtrack.models.fs import FullStateQuadrotor

#: The models with a compiled prediction, by class (a subclass may change ``f``: it takes the reference).
KINDS = {ConstantVelocity: 0, ConstantAcceleration: 1, ConstantTurn: 2, FullStateQuadrotor: 3}
_LOG_2PI = float(np.log(2.0 * np.pi))  # as swarmtrack.estimation.fusion's


@intrinsic
def fma(typingctx, a, b, c):
    """``a·b + c`` rounded once (LLVM's ``llvm.fma.f64``), as BLAS kernels accumulate."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        fnty = ir.FunctionType(ir.DoubleType(), [ir.DoubleType()] * 3)
        return builder.call(cgutils.get_or_insert_function(builder.module, fnty, "llvm.fma.f64"), args)

    return sig, codegen


def has_kernel(model) -> bool:
    """Whether ``model`` has a compiled prediction (a built-in CV, CA, CT or FS model)."""
    return type(model) in KINDS


def model_params(model) -> tuple[int, np.ndarray, np.ndarray]:
    """``(kind, params, F)`` for :func:`predict_bank`: the model's number, ``[dt, mass, Ixx, Iyy, g]`` (the FS
    model's constants; the others read ``dt`` only) and the constant ``F`` of a linear model (else an empty
    (0, 0) array)."""
    kind = KINDS[type(model)]
    params = np.array([model.dt, getattr(model, "mass", 0.0), getattr(model, "Ixx", 0.0),
                       getattr(model, "Iyy", 0.0), getattr(model, "g", 0.0)])
    F = np.ascontiguousarray(model.F, dtype=float) if model.linear else np.zeros((0, 0))
    return kind, params, F


@njit(cache=True)
def _turn_terms(a):
    """:func:`swarmtrack.models.ct.turn_terms` for one angle: ``S, C, S', C'`` (the same operations)."""
    if abs(a) < SMALL_TURN:
        a2 = a * a
        S = 1.0 - a2 / 6.0 * (1.0 - a2 / 20.0 * (1.0 - a2 / 42.0 * (1.0 - a2 / 72.0)))
        C = a / 2.0 * (1.0 - a2 / 12.0 * (1.0 - a2 / 30.0 * (1.0 - a2 / 56.0)))
        dS = -a / 3.0 * (1.0 - a2 / 10.0 * (1.0 - a2 / 28.0 * (1.0 - a2 / 54.0)))
        dC = 0.5 - a2 / 8.0 * (1.0 - a2 / 18.0 * (1.0 - a2 / 40.0 * (1.0 - a2 / 70.0)))
        return S, C, dS, dC
    sin_a, cos_a = np.sin(a), np.cos(a)
    h = np.sin(0.5 * a)
    one_minus_cos = 2.0 * (h * h)
    a_sq = a * a
    return sin_a / a, one_minus_cos / a, (a * cos_a - sin_a) / a_sq, (a * sin_a - one_minus_cos) / a_sq


@njit(cache=True)
def _ct(T, x, xp, J):
    """CT ``f`` and ``∂f/∂x`` of one state (:class:`~swarmtrack.models.ct.ConstantTurn`'s operations)."""
    px, py, vx, vy, w = x[0], x[1], x[2], x[3], x[4]
    a = w * T
    S, C, dS, dC = _turn_terms(a)
    sin_a, cos_a = np.sin(a), np.cos(a)
    xp[0] = px + T * (vx * S - vy * C)
    xp[1] = py + T * (vx * C + vy * S)
    xp[2] = vx * cos_a - vy * sin_a
    xp[3] = vx * sin_a + vy * cos_a
    xp[4] = w
    J[:, :] = 0.0
    J[0, 0] = 1.0
    J[0, 2] = T * S
    J[0, 3] = -T * C
    J[0, 4] = T * T * (vx * dS - vy * dC)
    J[1, 1] = 1.0
    J[1, 2] = T * C
    J[1, 3] = T * S
    J[1, 4] = T * T * (vx * dC + vy * dS)
    J[2, 2] = cos_a
    J[2, 3] = -sin_a
    J[2, 4] = -T * (vx * sin_a + vy * cos_a)
    J[3, 2] = sin_a
    J[3, 3] = cos_a
    J[3, 4] = T * (vx * cos_a - vy * sin_a)
    J[4, 4] = 1.0


@njit(cache=True)
def _fs(p, x, xp, J):
    """FS ``f`` and ``∂f/∂x`` of one state (:class:`~swarmtrack.models.fs.FullStateQuadrotor`'s operations)."""
    dt, m, Ixx, Iyy, g = p[0], p[1], p[2], p[3], p[4]
    phi, theta, thrust = x[5], x[6], x[11]
    sphi, cphi, sth, cth = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
    xp[:] = x
    xp[0] += dt * x[2]
    xp[1] += dt * x[3]
    xp[2] += dt * thrust / m * sth
    xp[3] -= dt * thrust / m * sphi * cth
    xp[4] += dt * (-g + cphi * cth * thrust / m)
    xp[5] += dt * x[7]
    xp[6] += dt * x[8]
    xp[7] += dt * x[9] / Ixx
    xp[8] += dt * x[10] / Iyy
    J[:, :] = 0.0
    for k in range(12):
        J[k, k] = 1.0
    J[0, 2] = dt
    J[1, 3] = dt
    J[2, 6] = dt * thrust / m * cth
    J[2, 11] = dt / m * sth
    J[3, 5] = -dt * thrust / m * cphi * cth
    J[3, 6] = dt * thrust / m * sphi * sth
    J[3, 11] = -dt / m * sphi * cth
    J[4, 5] = -dt * thrust / m * sphi * cth
    J[4, 6] = -dt * thrust / m * cphi * sth
    J[4, 11] = dt / m * cphi * cth
    J[5, 7] = dt
    J[6, 8] = dt
    J[7, 9] = dt / Ixx
    J[8, 10] = dt / Iyy


@njit(cache=True)
def fpft(F, P, out, rows):
    """``(F P) Fᵀ`` of one filter into ``out`` (``rows`` × ``rows``, the first ``rows`` rows of ``F``), each product
    a ``gemm``'s in-order fused multiply-adds (module docstring); ``FP`` is ``F P`` (a scratch)."""
    d = P.shape[0]
    FP = np.empty((rows, d))
    for r in range(rows):
        for c in range(d):
            acc = 0.0
            for k in range(d):
                acc = fma(F[r, k], P[k, c], acc)
            FP[r, c] = acc
    for r in range(rows):
        for c in range(rows):
            acc = 0.0
            for k in range(d):
                acc = fma(FP[r, k], F[c, k], acc)
            out[r, c] = acc


@njit(cache=True)
def predict_bank(kind, params, F_lin, x, P, Q, n_whole):
    """Predict filters ``x`` (n, d), ``P`` (n, d, d) of model ``kind`` (:func:`model_params`): returns
    ``x_pred = f(x)``, ``F`` (n, d, d) the Jacobian at ``x`` and ``P_pred = sym(F P Fᵀ + Q)``, the numbers of
    :func:`~swarmtrack.estimation.kalman.ekf_predict`. ``n_whole``: the number of rows the reference's linear
    ``x Fᵀ`` is taken over (the whole swarm's bank, :meth:`~swarmtrack.network.rows.Rows.rowwise`): one row is
    numpy's ``gemv`` (no fused multiply-add), several its ``gemm``."""
    n, d = x.shape
    x_pred = np.empty((n, d))
    F = np.empty((n, d, d))
    P_pred = np.empty((n, d, d))
    M = np.empty((d, d))
    for i in range(n):
        if kind <= 1:
            F[i] = F_lin
            for r in range(d):
                acc = 0.0
                for k in range(d):
                    if n_whole == 1:
                        acc += F_lin[r, k] * x[i, k]
                    else:
                        acc = fma(x[i, k], F_lin[r, k], acc)
                x_pred[i, r] = acc
        elif kind == 2:
            _ct(params[0], x[i], x_pred[i], F[i])
        else:
            _fs(params, x[i], x_pred[i], F[i])
        fpft(F[i], P[i], M, d)
        for r in range(d):
            for c in range(d):
                M[r, c] += Q[r, c]
        for r in range(d):
            for c in range(d):
                P_pred[i, r, c] = 0.5 * (M[r, c] + M[c, r])
    return x_pred, F, P_pred


@njit(cache=True)
def position_block(F, P, Q):
    """``sym(F[:2] P F[:2]ᵀ + Q[:2, :2])`` (n, 2, 2) of filters ``F``, ``P`` (n, d, d): the predicted position
    covariance as the IMM's reference computes it (:mod:`swarmtrack.estimation.imm`)."""
    n = P.shape[0]
    out = np.empty((n, 2, 2))
    M = np.empty((2, 2))
    for i in range(n):
        fpft(F[i], P[i], M, 2)
        for r in range(2):
            for c in range(2):
                M[r, c] += Q[r, c]
        for r in range(2):
            for c in range(2):
                out[i, r, c] = 0.5 * (M[r, c] + M[c, r])
    return out


@njit(cache=True)
def position_loglik(I, i, x_pos, P_pos):
    """``log N(I⁻¹ i − x̂⁻[:2]; 0, P⁻[:2, :2] + I⁻¹)`` per UAV, NaN where ``I`` is singular or the covariance not
    positive definite: the numbers of the IMM's reference (:func:`swarmtrack.estimation.imm._position_loglik`, its
    closed-form 2 x 2 inverse and :func:`swarmtrack.estimation.fusion.log_gaussian`'s unrolled Cholesky, operation
    for operation)."""
    n = I.shape[0]
    out = np.empty(n)
    for k in range(n):
        a, b, d = I[k, 0, 0], I[k, 0, 1], I[k, 1, 1]
        if not a * d - I[k, 0, 1] * I[k, 1, 0] > 0:
            out[k] = np.nan
            continue
        det = a * d - b * b
        r00, r11, r01 = d / det, a / det, -b / det
        nu0 = (r00 * i[k, 0] + r01 * i[k, 1]) - x_pos[k, 0]
        nu1 = (r01 * i[k, 0] + r11 * i[k, 1]) - x_pos[k, 1]
        s00 = 0.5 * ((P_pos[k, 0, 0] + r00) + (P_pos[k, 0, 0] + r00))
        s10 = 0.5 * ((P_pos[k, 1, 0] + r01) + (P_pos[k, 0, 1] + r01))
        s11 = 0.5 * ((P_pos[k, 1, 1] + r11) + (P_pos[k, 1, 1] + r11))
        if not s00 > 0:
            out[k] = np.nan
            continue
        l00 = np.sqrt(s00)
        l10 = s10 / l00
        pivot = s11 - l10 * l10
        if not pivot > 0:
            out[k] = np.nan
            continue
        l11 = np.sqrt(pivot)
        y0 = nu0 / l00
        y1 = (nu1 - l10 * y0) / l11
        logdet = np.log(l00) + np.log(l11)
        maha = y0 * y0 + y1 * y1
        v = -0.5 * (2 * _LOG_2PI + 2.0 * logdet + maha)
        out[k] = v if np.isfinite(v) else np.nan
    return out
