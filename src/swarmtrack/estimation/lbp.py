"""Marginal association probabilities by loopy belief propagation (LBP).

Williams & Lau 2014 ("Approximate evaluation of marginal association probabilities with belief propagation",
IEEE TAES 50(4)): the joint association of K tracks and M measurements, each track taking at most one
measurement and each measurement at most one track, has the weight ``∏_i ψ_i,a(i)`` (``a(i) = 0``: track ``i``
missed or not existing, weight ``psi0[i]``; ``a(i) = j + 1``: track ``i`` generated measurement ``j``, weight
``psi[i, j]``, 0 outside the gate). Its marginals are approximated by passing messages on the bipartite graph of
track and measurement variables, in their simplified scalar form (``ν`` initialised to 1)::

    μ_ij = ψ_ij / (ψ0_i + Σ_{j' ≠ j} ψ_ij' ν_ij')          track i → measurement j
    ν_ij = 1 / (1 + Σ_{i' ≠ i} μ_i'j)                       measurement j → track i

iterated until the largest change of ``ν`` is below ``tol`` (or ``max_iter`` iterations). Messages exist on the
edges of the graph only, the pairs with ``ψ_ij > 0`` (a pair outside the gate carries ``μ_ij = 0``, and its ``ν_ij``
multiplies ``ψ_ij = 0``): the convergence test looks at those. The beliefs are then::

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
        Stop when the largest change of a message ``ν`` (over the pairs with ``ψ_ij > 0``) in one iteration is below
        ``tol``.
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
        change = np.abs(nu_new - nu)[psi > 0.0].max(initial=0.0)
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


# The kernel works on the graph's edges only (the pairs with ψ_ij > 0, few of K M after gating), listed track by track
# (CSR: row_start) and measurement by measurement (col_start, col_edge). The leave-one-out sums Σ_{j' ≠ j} (and
# Σ_{i' ≠ i}) are a prefix sum before the edge plus a suffix sum after it: O(1) per message, no cancellation (a total
# minus the left-out term could lose every digit when that term dominates), and right when a term is infinite.


@numba.njit(cache=True, fastmath=False)
def _edges(psi):
    """The edges ``ψ_ij > 0``: ``(row_start (K + 1,), col (E,), col_start (M + 1,), col_edge (E,))``; the edges of
    track ``i`` are ``row_start[i]:row_start[i + 1]`` (measurement ``col[e]``), those of measurement ``j`` are
    ``col_edge[col_start[j]:col_start[j + 1]]``, both in increasing order of the other index."""
    k, m = psi.shape
    row_start = np.zeros(k + 1, np.int64)
    col_start = np.zeros(m + 1, np.int64)
    for i in range(k):
        row_start[i + 1] = row_start[i]
        for j in range(m):
            if psi[i, j] > 0.0:
                row_start[i + 1] += 1
                col_start[j + 1] += 1
    for j in range(m):
        col_start[j + 1] += col_start[j]
    n_edges = row_start[k]
    col = np.empty(n_edges, np.int64)
    col_edge = np.empty(n_edges, np.int64)
    fill = col_start[:m].copy()
    e = 0
    for i in range(k):
        for j in range(m):
            if psi[i, j] > 0.0:
                col[e] = j
                col_edge[fill[j]] = e
                fill[j] += 1
                e += 1
    return row_start, col, col_start, col_edge


@numba.njit(cache=True, fastmath=False)
def _track_messages_kernel(psi0, weight, nu, mu, row_start, suffix):
    """``mu[e]`` = the track → measurement message of every edge, as :func:`_track_messages` (``weight[e]`` the
    edge's ``ψ``, ``nu[e]`` its current ``ν``); ``suffix`` (E + 1,) is scratch."""
    for i in range(psi0.shape[0]):
        lo, hi = row_start[i], row_start[i + 1]
        suffix[hi] = 0.0
        for e in range(hi - 1, lo - 1, -1):
            suffix[e] = suffix[e + 1] + weight[e] * nu[e]
        prefix = 0.0
        for e in range(lo, hi):
            denom = psi0[i] + (prefix + suffix[e + 1])
            mu[e] = weight[e] / denom if denom > 0.0 else math.inf
            prefix += weight[e] * nu[e]


@numba.njit(cache=True, fastmath=False)
def _measurement_messages_kernel(mu, nu, col_start, col_edge, suffix):
    """Overwrite ``nu[e]`` with the measurement → track message of every edge, as :func:`_measurement_messages`;
    returns the largest change. Every ``μ`` was computed from the old ``ν``: a Jacobi step, as the reference's.
    ``suffix`` (E + 1,) is scratch."""
    change = 0.0
    for j in range(col_start.shape[0] - 1):
        lo, hi = col_start[j], col_start[j + 1]
        suffix[hi] = 0.0
        for c in range(hi - 1, lo - 1, -1):
            suffix[c] = suffix[c + 1] + mu[col_edge[c]]
        prefix = 0.0
        for c in range(lo, hi):
            e = col_edge[c]
            v = 1.0 / (1.0 + (prefix + suffix[c + 1]))
            change = max(change, abs(v - nu[e]))
            nu[e] = v
            prefix += mu[e]
    return change


@numba.njit(cache=True, fastmath=False)
def lbp(psi0, psi, tol=TOL, max_iter=MAX_ITER):
    """Marginal association probabilities by loopy belief propagation (Williams & Lau 2014), compiled.

    Same inputs, outputs and numbers (to rounding) as :func:`lbp_reference`, for float64 ``psi0`` (K,) and
    ``psi`` (K, M): a numba kernel (``@numba.njit(cache=True)``, serial, no fastmath). It passes messages on the
    pairs with ``ψ_ij > 0`` only, with leave-one-out sums as prefix plus suffix sums: an iteration costs O(edges).
    """
    k, m = psi.shape
    p = np.zeros((k, m + 1))
    p_free = np.ones(m)
    for i in range(k):
        p[i, 0] = 1.0
    if k == 0 or m == 0:
        return p, p_free
    row_start, col, col_start, col_edge = _edges(psi)
    n_edges = col.shape[0]
    weight = np.empty(n_edges)
    for i in range(k):
        for e in range(row_start[i], row_start[i + 1]):
            weight[e] = psi[i, col[e]]
    nu = np.ones(n_edges)
    mu = np.empty(n_edges)
    suffix = np.empty(n_edges + 1)
    for _ in range(max_iter):
        _track_messages_kernel(psi0, weight, nu, mu, row_start, suffix)
        if _measurement_messages_kernel(mu, nu, col_start, col_edge, suffix) < tol:
            break
    _track_messages_kernel(psi0, weight, nu, mu, row_start, suffix)
    for i in range(k):
        lo, hi = row_start[i], row_start[i + 1]
        total = psi0[i]
        for e in range(lo, hi):
            total += weight[e] * nu[e]
        if total > 0.0:
            p[i, 0] = psi0[i] / total
            for e in range(lo, hi):
                p[i, col[e] + 1] = weight[e] * nu[e] / total
    for j in range(m):
        s = 0.0
        for c in range(col_start[j], col_start[j + 1]):
            s += mu[col_edge[c]]
        p_free[j] = 1.0 / (1.0 + s)
    return p, p_free


__all__ = ["MAX_ITER", "TOL", "lbp", "lbp_reference"]
