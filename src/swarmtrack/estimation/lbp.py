"""Marginal association probabilities by loopy belief propagation (LBP).

Williams & Lau 2014 ("Approximate evaluation of marginal association probabilities with belief propagation",
IEEE TAES 50(4)): the joint association of K tracks and M measurements, each track taking at most one
measurement and each measurement at most one track, has the weight ``∏_i ψ_i,a(i)`` (``a(i) = 0``: track ``i``
missed or not existing, weight ``psi0[i]``; ``a(i) = j + 1``: track ``i`` generated measurement ``j``, weight
``psi[i, j]``, 0 outside the gate). Its marginals are approximated by passing messages on the bipartite graph of
track and measurement variables, in their simplified scalar form (``ν`` initialised to 1)::

    μ_ij = ψ_ij / (ψ0_i + Σ_{j' ≠ j} ψ_ij' ν_ij')          track i → measurement j
    ν_ij = 1 / (1 + Σ_{i' ≠ i} μ_i'j)                       measurement j → track i

iterated until the largest change of ``ν`` is below ``tol`` (or ``max_iter`` iterations). The beliefs are then::

    p_i0 ∝ ψ0_i,   p_i,j+1 ∝ ψ_ij ν_ij      (each row normalised)
    p_free_j = 1 / (1 + Σ_i μ_ij)           (measurement j associated to no track: clutter or a new target)

On a graph without cycles (e.g. every measurement gated by one track only) the fixed point gives the exact
marginals; otherwise they are an approximation (Williams & Lau show it is a good one in practice).

Degenerate weights are allowed: ``psi0[i] = 0`` (a track certain to exist and to be detected) makes ``μ_ij``
infinite when ``j`` is the only measurement it can take, so that no other track can take ``j`` (``ν_i'j = 0``);
a row whose weights are all zero after the messages (an impossible track: it must be detected but nothing can
be its measurement) is reported as missed, ``p_i0 = 1``.

:func:`lbp_reference` is the readable numpy version; :func:`lbp` is the compiled kernel
(``@numba.njit(cache=True)``, serial, no fastmath) that the tests hold to the same numbers.
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: Default convergence tolerance on the largest change of a measurement → track message ``ν``.
TOL = 1e-10
#: Default bound on the number of message-passing iterations.
MAX_ITER = 200


def _checked(psi0, psi) -> tuple[np.ndarray, np.ndarray]:
    psi0 = np.ascontiguousarray(psi0, dtype=np.float64)
    psi = np.ascontiguousarray(psi, dtype=np.float64)
    if psi0.ndim != 1 or psi.ndim != 2 or psi.shape[0] != psi0.shape[0]:
        raise ValueError(f"psi0 must be (K,) and psi (K, M), got {psi0.shape} and {psi.shape}")
    return psi0, psi


def _track_messages(psi0: np.ndarray, psi: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """``μ_ij = ψ_ij / (ψ0_i + Σ_{j' ≠ j} ψ_ij' ν_ij')`` (Williams & Lau 2014), ``inf`` for a zero denominator
    under a positive ``ψ_ij`` and 0 where ``ψ_ij = 0``."""
    w = psi * nu
    m = psi.shape[1]
    others = np.where(np.eye(m, dtype=bool)[None, :, :], 0.0, w[:, None, :]).sum(axis=2)  # Σ over j' ≠ j
    denom = psi0[:, None] + others
    mu = np.divide(psi, denom, out=np.zeros_like(psi), where=denom > 0.0)
    return np.where((psi > 0.0) & (denom <= 0.0), np.inf, mu)


def _measurement_messages(mu: np.ndarray) -> np.ndarray:
    """``ν_ij = 1 / (1 + Σ_{i' ≠ i} μ_i'j)`` (Williams & Lau 2014); 0 when a sum is infinite."""
    k = mu.shape[0]
    others = np.where(np.eye(k, dtype=bool)[:, :, None], 0.0, mu[None, :, :]).sum(axis=1)  # Σ over i' ≠ i
    return 1.0 / (1.0 + others)


def lbp_reference(psi0, psi, tol: float = TOL, max_iter: int = MAX_ITER) -> tuple[np.ndarray, np.ndarray]:
    """Marginal association probabilities by loopy belief propagation (Williams & Lau 2014), numpy reference.

    Parameters
    ----------
    psi0 : (K,) array
        Weight of "track ``i`` not detected (or not existing)", ≥ 0.
    psi : (K, M) array
        Weight of "track ``i`` generated measurement ``j``", ≥ 0 (0 outside the gate).
    tol : float
        Stop when the largest change of a message ``ν`` in one iteration is below ``tol``.
    max_iter : int
        At most this many iterations.

    Returns
    -------
    p : (K, M + 1) array
        Marginal association probabilities of each track: column 0 missed / not existing, column ``j + 1``
        measurement ``j``; each row sums to 1.
    p_free : (M,) array
        Probability that measurement ``j`` is associated to no track, ``1 / (1 + Σ_i μ_ij)``.
    """
    psi0, psi = _checked(psi0, psi)
    k, m = psi.shape
    p = np.zeros((k, m + 1))
    p[:, 0] = 1.0
    if k == 0 or m == 0:
        return p, np.ones(m)
    nu = np.ones((k, m))
    for _ in range(max_iter):
        nu_new = _measurement_messages(_track_messages(psi0, psi, nu))
        change = np.abs(nu_new - nu).max()
        nu = nu_new
        if change < tol:
            break
    mu = _track_messages(psi0, psi, nu)
    beliefs = np.concatenate([psi0[:, None], psi * nu], axis=1)
    total = beliefs.sum(axis=1)
    ok = total > 0.0
    p[ok] = beliefs[ok] / total[ok, None]
    p_free = 1.0 / (1.0 + mu.sum(axis=0))
    return p, p_free


@numba.njit(cache=True, fastmath=False)
def _track_messages_kernel(psi0, psi, nu, mu):
    """Fill ``mu`` (K, M) with the track → measurement messages, as :func:`_track_messages`."""
    k, m = psi.shape
    for i in range(k):
        for j in range(m):
            if psi[i, j] <= 0.0:
                mu[i, j] = 0.0
                continue
            denom = psi0[i]
            for jj in range(m):
                if jj != j:
                    denom += psi[i, jj] * nu[i, jj]
            mu[i, j] = psi[i, j] / denom if denom > 0.0 else math.inf


@numba.njit(cache=True, fastmath=False)
def lbp(psi0, psi, tol=TOL, max_iter=MAX_ITER):
    """Marginal association probabilities by loopy belief propagation (Williams & Lau 2014), compiled.

    Same inputs, outputs and numbers (to rounding) as :func:`lbp_reference`, for float64 ``psi0`` (K,) and
    ``psi`` (K, M): a numba kernel (``@numba.njit(cache=True)``, serial, no fastmath).
    """
    k, m = psi.shape
    p = np.zeros((k, m + 1))
    p_free = np.ones(m)
    for i in range(k):
        p[i, 0] = 1.0
    if k == 0 or m == 0:
        return p, p_free
    nu = np.ones((k, m))
    mu = np.empty((k, m))
    for _ in range(max_iter):
        _track_messages_kernel(psi0, psi, nu, mu)
        change = 0.0
        for j in range(m):
            for i in range(k):
                s = 0.0
                for ii in range(k):
                    if ii != i:
                        s += mu[ii, j]
                v = 1.0 / (1.0 + s)
                change = max(change, abs(v - nu[i, j]))
                nu[i, j] = v  # every μ was computed from the old ν above: updating ν in place is still a Jacobi step
        if change < tol:
            break
    _track_messages_kernel(psi0, psi, nu, mu)
    for i in range(k):
        total = psi0[i]
        for j in range(m):
            total += psi[i, j] * nu[i, j]
        if total > 0.0:
            p[i, 0] = psi0[i] / total
            for j in range(m):
                p[i, j + 1] = psi[i, j] * nu[i, j] / total
    for j in range(m):
        s = 0.0
        for i in range(k):
            s += mu[i, j]
        p_free[j] = 1.0 / (1.0 + s)
    return p, p_free


__all__ = ["MAX_ITER", "TOL", "lbp", "lbp_reference"]
