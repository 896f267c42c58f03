"""The normalised estimation error squared ``eᵀ P⁻¹ e`` of many small systems at once, compiled: what the run's
metrics (:mod:`swarmtrack.capabilities.tracking_swarm.metrics`) and the live views (:mod:`swarmtrack.streams.frame`)
compute of each UAV's estimate."""

from __future__ import annotations

import functools

import numpy as np


def nees_per_uav(err: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """(k, N) normalised estimation error squared ``eᵀ P⁻¹ e`` of errors (k, N, d) with covariances (k, N, d, d).

    Compiled (:func:`_nees_rows`): ``np.sum(err * np.linalg.solve(cov, err[..., None])[..., 0], axis=-1)`` to
    round-off, without LAPACK's cost per matrix (a 10,000-UAV run has millions of 4 x 4 systems); a singular
    covariance raises ``LinAlgError`` as ``np.linalg.solve`` does, a NaN gives NaN."""
    shape, d = err.shape[:-1], err.shape[-1]
    e = np.ascontiguousarray(err, dtype=float).reshape(-1, d)
    p = np.ascontiguousarray(np.broadcast_to(cov, (*shape, d, d)), dtype=float).reshape(-1, d, d)
    out = np.empty(len(e))
    if _nees_kernel()(e, p, out) >= 0:
        raise np.linalg.LinAlgError("Singular matrix")
    return out.reshape(shape)


@functools.cache
def _nees_kernel():
    """:func:`_nees_rows` compiled (numba, imported on first use; cached on disk like the simulator's kernels) for
    C-contiguous arrays, the inputs read-only or not (one signature: each compilation costs seconds)."""
    import numba
    from numba import types

    def array(ndim: int, readonly: bool = True):
        return types.Array(types.float64, ndim, "C", readonly=readonly)

    return numba.njit([types.int64(array(2), array(3), array(1, False))], cache=True, fastmath=False)(_nees_rows)


def _nees_rows(err, cov, out):
    """``out[i] = err[i]ᵀ cov[i]⁻¹ err[i]`` for rows ``err`` (m, d), ``cov`` (m, d, d): Gaussian elimination with
    partial pivoting (LAPACK's choice of pivot) on a copy, then back substitution. Returns the first row whose
    covariance is singular (a zero pivot), −1 when none is."""
    m, d = err.shape
    a, x = np.empty((d, d)), np.empty(d)
    for i in range(m):
        for r in range(d):
            x[r] = err[i, r]
            for col in range(d):
                a[r, col] = cov[i, r, col]
        for col in range(d):
            p, big = col, abs(a[col, col])
            for r in range(col + 1, d):
                if abs(a[r, col]) > big:
                    p, big = r, abs(a[r, col])
            if a[p, col] == 0.0:
                return i
            if p != col:
                for k in range(d):
                    a[p, k], a[col, k] = a[col, k], a[p, k]
                x[p], x[col] = x[col], x[p]
            for r in range(col + 1, d):
                f = a[r, col] / a[col, col]
                for k in range(col + 1, d):
                    a[r, k] -= f * a[col, k]
                x[r] -= f * x[col]
        q = 0.0
        for r in range(d - 1, -1, -1):
            v = x[r]
            for k in range(r + 1, d):
                v -= a[r, k] * x[k]
            x[r] = v / a[r, r]
        for r in range(d):
            q += err[i, r] * x[r]
        out[i] = q
    return -1
