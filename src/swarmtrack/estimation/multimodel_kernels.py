"""The multi-model EKF's estimation step compiled (numba): every UAV's filters, and every world's of a batch, in one
call per side of the network (W20 Ch. 4).

The engine drives an estimator through share → channel → fuse → publish → channel → combine
(:meth:`~swarmtrack.onboard.stack.OnboardStack.estimation_step`); a compiled call cannot span the channel, so the step
is three calls, one per side of each exchange, each over all rows:

- :func:`share_step`: the camera's (or range-bearing sensor's) payload from the detections, and every filter's
  prediction (W20 eqs. 4.7-4.9);
- :func:`fuse_step`: each receiver's stacked measurements summed in position space (W20 eqs. 4.3-4.4), its
  update (eqs. 4.10-4.13), likelihood (eq. 4.31), NIS and residual window (eq. 4.28), and the message it publishes
  (the posterior on ``[x, y, vx, vy]``, the model's extra states as ``[ax, ay, ω]``);
- :func:`combine_ttest`: the T-test selection (eqs. 4.23-4.28) with the occlusion policy (4.38-4.40), the switch
  count and the output.

The readable reference is :class:`~swarmtrack.estimation.multimodel.MultiModelEstimator` with ``compiled=False``;
:mod:`swarmtrack.estimation.multimodel_compiled` drives these kernels on its state. They repeat the reference's
operations in its order: the prediction is :mod:`swarmtrack.estimation.predict_kernels`' (bit for bit), the sums
are ``np.add.at``'s in the measurements' order with OpenBLAS ``gemm``'s fused multiply-adds, the position solve is
LAPACK's (bit for bit), the residual windows' means are numpy's pairwise sums; the update inverts the 2 x 2
innovation covariance in closed form (the reference solves: equal to rounding). A filter whose posterior covariance
is not finite or not positive definite (a Cholesky pivot ≤ 0) is flagged, not raised inside numba.

Rows: ``n`` receivers (the estimator's rows), the filters' states in ``X`` (n, D), ``P`` (n, D, D), ``D`` the largest
model's dimension, row ``i``'s filter at ``pos[i]`` (its model's bank contiguous) with ``dim[i]`` states; messages
come from the swarm's UAVs (``Ns``, rows of the payloads). Links are a dense (n, Ns) mask or CSR lists
(:func:`links_of`); receiver ``i`` hears only its own world's UAVs ``world[i]·N .. world[i]·N + N − 1`` (N the team;
a batch's links are block-diagonal), and none of a square mask's diagonal.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from swarmtrack.estimation.predict_kernels import _ct, _fs, fma, fpft

_LOG_2PI = math.log(2.0 * math.pi)
#: Measurement kinds of :func:`fuse_step`.
CAMERA, RANGE_BEARING = 0, 1
#: Occlusion policies of :func:`combine_ttest`.
LAST, TRACE, EIGENVALUE = 0, 1, 2
#: Extra states of a model as ``[ax, ay, ω]``: none, CA's ``[ax, ay]``, CT's ``ω``.
NO_MOTION, CA_MOTION, CT_MOTION = 0, 1, 2


# --- links --------------------------------------------------------------------------------------------------------


def links_of(links) -> tuple:
    """``(dense, indptr, senders)`` for the kernels: a dense mask as it is (and empty lists), CSR links as their
    lists (and an empty mask)."""
    if isinstance(links, np.ndarray):
        return links, _NO_LIST, _NO_LIST
    return _NO_MASK, links.indptr, links.indices


_NO_LIST = np.zeros(1, dtype=np.int32)
_NO_MASK = np.zeros((0, 0), dtype=bool)


@njit(cache=True)
def _neighbours(links, i, lo, hi, out):
    """Receiver ``i``'s senders among ``lo .. hi − 1`` into ``out``, ascending (the edge list's order); their number.
    ``links``: ``(dense, indptr, senders)``."""
    dense, indptr, senders = links
    square = dense.shape[0] == dense.shape[1]
    k = 0
    if dense.shape[0] > 0:
        for j in range(lo, hi):
            if dense[i, j] and not (square and j == i):
                out[k] = j
                k += 1
        return k
    for e in range(indptr[i], indptr[i + 1]):
        j = senders[e]
        if lo <= j < hi and j != i:  # CSR links are square (a subset's are dense)
            out[k] = j
            k += 1
    return k


# --- share: payload and prediction ------------------------------------------------------------------------------


@njit(cache=True)
def _predict(kind, params, F_lin, Q, n_whole, x, P, d, xp, J, M):
    """One filter's ``x ← f(x)``, ``P ← sym(F P Fᵀ + Q)`` in place (``x`` (D,), ``P`` (D, D), its first ``d``
    states): :func:`~swarmtrack.estimation.predict_kernels.predict_bank`'s operations for one row."""
    if kind <= 1:
        F = F_lin[:d, :d]
        for r in range(d):
            acc = 0.0
            for k in range(d):
                if n_whole == 1:
                    acc += F_lin[r, k] * x[k]
                else:
                    acc = fma(x[k], F_lin[r, k], acc)
            xp[r] = acc
    else:
        F = J[:d, :d]
        if kind == 2:
            _ct(params[0], x[:d], xp[:d], F)
        else:
            _fs(params, x[:d], xp[:d], F)
    fpft(F, P[:d, :d], M[:d, :d], d)
    for r in range(d):
        for c in range(d):
            M[r, c] += Q[r, c]
    for r in range(d):
        x[r] = xp[r]
        for c in range(d):
            P[r, c] = 0.5 * (M[r, c] + M[c, r])


@njit(cache=True)
def share_step(detections, label, X, P, models):
    """The payload of each of the ``n`` rows of ``X`` (``z``, the aux rows ``[A | b]`` or the sensor position,
    ``seen``; NaN where row ``i`` did not detect ``label[i]``) from ``detections`` ``(owner, z, aux, label)``, and
    every filter predicted in place. ``models``: ``(bank, kind, params, F, Q, n_whole, dim)``: the bank of each of
    ``X``'s rows and, per bank, the model's number and parameters
    (:func:`~swarmtrack.estimation.predict_kernels.model_params`), ``Q``, the rows of the whole swarm's bank per
    world and the dimension."""
    owner, det_z, det_aux, det_label = detections
    n = X.shape[0]
    z = np.full((n, det_z.shape[1]), np.nan)
    aux = np.full((n,) + det_aux.shape[1:], np.nan)
    seen = np.zeros(n, dtype=np.bool_)
    for e in range(owner.shape[0]):  # a sensor gives at most one detection per UAV and label
        o = owner[e]
        if det_label[e] == label[o]:
            z[o] = det_z[e]
            aux[o] = det_aux[e]
            seen[o] = True
    bank, kind, params, F, Q, n_whole, dim = models
    D = X.shape[1]
    xp, J, M = np.empty(D), np.empty((D, D)), np.empty((D, D))
    for p in range(X.shape[0]):
        k = bank[p]
        _predict(kind[k], params[k], F[k], Q[k], n_whole[k], X[p], P[p], dim[k], xp, J, M)
    return z, aux, seen


# --- fuse: statistic, update, message ---------------------------------------------------------------------------


@njit(cache=True)
def _add_term(S, nu0, nu1, H, Rinv, logdet):
    """Add one measurement (``ν``, ``H`` (2, 2), ``R⁻¹`` (2, 2)) to a receiver's sums ``S`` = ``[I00, I01, I10, I11,
    b0, b1, s, Σ log det R, count]``: ``Hᵀ R⁻¹ H``, ``Hᵀ R⁻¹ ν``, ``νᵀ R⁻¹ ν`` as the reference's ``gemm`` and
    ``einsum`` compute them (in-order fused multiply-adds; in-order sums without)."""
    t00 = fma(H[1, 0], Rinv[1, 0], fma(H[0, 0], Rinv[0, 0], 0.0))  # Hᵀ R⁻¹
    t01 = fma(H[1, 0], Rinv[1, 1], fma(H[0, 0], Rinv[0, 1], 0.0))
    t10 = fma(H[1, 1], Rinv[1, 0], fma(H[0, 1], Rinv[0, 0], 0.0))
    t11 = fma(H[1, 1], Rinv[1, 1], fma(H[0, 1], Rinv[0, 1], 0.0))
    S[0] += fma(t01, H[1, 0], fma(t00, H[0, 0], 0.0))
    S[1] += fma(t01, H[1, 1], fma(t00, H[0, 1], 0.0))
    S[2] += fma(t11, H[1, 0], fma(t10, H[0, 0], 0.0))
    S[3] += fma(t11, H[1, 1], fma(t10, H[0, 1], 0.0))
    S[4] += (0.0 + t00 * nu0) + t01 * nu1
    S[5] += (0.0 + t10 * nu0) + t11 * nu1
    S[6] += (((0.0 + nu0 * Rinv[0, 0] * nu0) + nu0 * Rinv[0, 1] * nu1) + nu1 * Rinv[1, 0] * nu0) \
        + nu1 * Rinv[1, 1] * nu1
    S[7] += logdet
    S[8] += 1.0


@njit(cache=True)
def _add_measurement(S, meas, z, aux, x0, x1, H):
    """Add the measurement ``z`` with its aux row, linearised at the receiver's predicted position ``(x0, x1)``:
    the camera's ``ν = z − A x̂ − b``, ``H = A`` (:class:`~swarmtrack.estimation.measurements.CameraFrameMeasurement`)
    or the range-bearing sensor's ``ν = z − h(x̂)`` (bearing wrapped), ``H = ∂h/∂x``
    (:class:`~swarmtrack.estimation.measurements.RangeBearingMeasurement`)."""
    kind, Rinv, logdet, min_range = meas
    if kind == CAMERA:
        nu0 = (z[0] - ((0.0 + aux[0, 0] * x0) + aux[0, 1] * x1)) - aux[0, 2]
        nu1 = (z[1] - ((0.0 + aux[1, 0] * x0) + aux[1, 1] * x1)) - aux[1, 2]
        _add_term(S, nu0, nu1, aux[:, :2], Rinv, logdet)
        return
    dx, dy = x0 - aux[0, 0], x1 - aux[0, 1]  # (range_bearing.polar_model)
    rho = np.hypot(dx, dy)
    r = max(rho, min_range)
    r2 = r * r
    H[0, 0], H[0, 1], H[1, 0], H[1, 1] = dx / r, dy / r, -dy / r2, dx / r2
    a = np.pi - (z[1] - np.arctan2(dy, dx))  # wrap_angle: π − ((π − ν) mod 2π), numpy's floored mod
    m = np.fmod(a, 2.0 * np.pi)
    if m == 0.0:
        m = 0.0
    elif m < 0.0:
        m += 2.0 * np.pi
    _add_term(S, z[0] - rho, np.pi - m, H, Rinv, logdet)


@njit(cache=True)
def _solve(S, B, Y):
    """``ν = I⁻¹ b`` and ``sym(I⁻¹)`` of a receiver's sums ``S`` as ``np.linalg.solve(I, [b | E])`` computes them
    (LAPACK's ``getrf``/``getrs``: the row of the larger pivot first, the multiplier and the back substitution by
    reciprocals, as OpenBLAS does); ``Y``'s first column ``ν``, the rest ``I⁻¹``. ``B`` (2, 3) is a scratch."""
    a00, a01, a10, a11 = S[0], S[1], S[2], S[3]
    B[0, 0], B[0, 1], B[0, 2] = S[4], 1.0, 0.0
    B[1, 0], B[1, 1], B[1, 2] = S[5], 0.0, 1.0
    if abs(a10) > abs(a00):  # partial pivoting
        a00, a01, a10, a11 = a10, a11, a00, a01
        for j in range(3):
            B[0, j], B[1, j] = B[1, j], B[0, j]
    inv00 = 1.0 / a00
    l10 = a10 * inv00
    u11 = a11 - l10 * a01
    inv11 = 1.0 / u11
    for j in range(3):
        Y[1, j] = (B[1, j] - l10 * B[0, j]) * inv11
        Y[0, j] = (B[0, j] - a01 * Y[1, j]) * inv00


@njit(cache=True)
def _update(x, P, d, S, Y, K, AP, L):
    """Update one filter (``x`` (D,), ``P`` (D, D), its first ``d`` states, in place) with the position-space
    statistic of its stacked measurements (sums ``S``, solve ``Y``): W20 eqs. 4.10-4.13 (Joseph form), the stacked
    likelihood of eq. 4.31, the NIS and the per-measurement posterior residual of eq. 4.28. Returns ``loglik, nis,
    eps, ok``."""
    r00 = 0.5 * (Y[0, 1] + Y[0, 1])  # sym(I⁻¹)
    r01 = 0.5 * (Y[0, 2] + Y[1, 1])
    r11 = 0.5 * (Y[1, 2] + Y[1, 2])
    s00 = P[0, 0] + r00
    s01 = 0.5 * (P[0, 1] + P[1, 0]) + r01
    s11 = P[1, 1] + r11
    det_s = s00 * s11 - s01 * s01
    i00, i01, i11 = s11 / det_s, -s01 / det_s, s00 / det_s
    for k in range(d):  # K = P Eᵀ S⁻¹ (eq. 4.10)
        K[k, 0] = i00 * P[0, k] + i01 * P[1, k]
        K[k, 1] = i01 * P[0, k] + i11 * P[1, k]
    n0, n1 = Y[0, 0], Y[1, 0]
    d0 = K[0, 0] * n0 + K[0, 1] * n1  # the position's move, for the posterior residual
    d1 = K[1, 0] * n0 + K[1, 1] * n1
    ok = True
    for k in range(d):  # eq. 4.12
        x[k] += K[k, 0] * n0 + K[k, 1] * n1
        ok &= np.isfinite(x[k])
    for k in range(d):  # (I − K E) P
        for j in range(d):
            AP[k, j] = P[k, j] - K[k, 0] * P[0, j] - K[k, 1] * P[1, j]
    for k in range(d):  # Joseph form: (I − K E) P (I − K E)ᵀ + K R Kᵀ, symmetrised
        for j in range(k + 1):
            v_kj = AP[k, j] - AP[k, 0] * K[j, 0] - AP[k, 1] * K[j, 1]
            v_jk = AP[j, k] - AP[j, 0] * K[k, 0] - AP[j, 1] * K[k, 1]
            krk = (K[k, 0] * (r00 * K[j, 0] + r01 * K[j, 1]) + K[k, 1] * (r01 * K[j, 0] + r11 * K[j, 1]))
            P[k, j] = P[j, k] = 0.5 * (v_kj + v_jk) + krk
    for k in range(d):  # Cholesky pivots: positive definite and finite
        for j in range(k + 1):
            acc = P[k, j]
            for q in range(j):
                acc -= L[k, q] * L[j, q]
            if j == k:
                if not acc > 0.0:
                    ok = False
                    acc = 1.0
                L[k, k] = math.sqrt(acc)
            else:
                L[k, j] = acc / L[j, j]
    I00, I01, I10, I11, b0, b1, s, logdet_r, count = S[0], S[1], S[2], S[3], S[4], S[5], S[6], S[7], S[8]
    quad = (n0 * n0 * s11 - 2.0 * n0 * n1 * s01 + n1 * n1 * s00) / det_s
    ia01 = 0.5 * (I01 + I10)
    det_i = I00 * I11 - I01 * I10
    nin = n0 * (I00 * n0 + I01 * n1) + n1 * (I10 * n0 + I11 * n1)
    loglik = (-0.5 * quad - 0.5 * math.log(det_s) - _LOG_2PI - 0.5 * (s - nin)
              + (1.0 - count) * _LOG_2PI - 0.5 * math.log(det_i) - 0.5 * logdet_r)
    e = s - 2.0 * (d0 * b0 + d1 * b1) + (d0 * d0 * I00 + 2.0 * d0 * d1 * ia01 + d1 * d1 * I11)
    return loglik, quad, e / count, ok


@njit(cache=True)
def fuse_step(meas, mine, got, links, team, state, fresh):
    """Stack each receiver's own measurement and those its links delivered, and update its filter; then the
    message it publishes.

    ``meas``: ``(kind, R⁻¹, log det R, min_range)`` (:data:`CAMERA` or :data:`RANGE_BEARING`); ``mine`` and
    ``got``: payloads ``(z, aux, seen)`` of the receivers' own rows and of every sender; ``links``:
    ``(dense, indptr, senders)``; ``team``: ``(N, world)``; ``state``: ``(X, P, pos, dim, motion, initialised,
    windows)``, ``motion`` each row's :data:`NO_MOTION`, :data:`CA_MOTION` or :data:`CT_MOTION`; ``fresh``: rows
    that started from this step's measurements (not updated). ``X``, ``P`` are updated in place.

    Returns the rows' ``loglik``, ``nis`` (NaN where not updated), ``measured``, the residual windows (a new array,
    shifted where updated), ``ok`` (False: the posterior is not finite or not positive definite) and whether all are,
    and the message: ``x`` (n, 4), ``P`` (n, 4, 4) on ``[x, y, vx, vy]`` (NaN before a filter started) and
    ``motion`` (n, 3)."""
    X, P, pos, dim, motion_kind, initialised, windows = state
    N, world = team
    n, D = pos.shape[0], X.shape[1]
    loglik, nis = np.full(n, np.nan), np.full(n, np.nan)
    measured, ok = np.zeros(n, dtype=np.bool_), np.ones(n, dtype=np.bool_)
    new_windows = windows.copy()
    W = windows.shape[1]
    out_x, out_P, out_motion = np.empty((n, 4)), np.empty((n, 4, 4)), np.zeros((n, 3))
    S, H, B, Y = np.empty(9), np.empty((2, 2)), np.empty((2, 3)), np.empty((2, 3))
    K, AP, L = np.empty((D, 2)), np.empty((D, D)), np.empty((D, D))
    heard = np.empty(N, dtype=np.int64)
    own_z, own_aux, own_seen = mine
    got_z, got_aux, got_seen = got
    for i in range(n):
        p, d = pos[i], dim[i]
        x, Pi = X[p], P[p]
        S[:] = 0.0
        if own_seen[i]:
            _add_measurement(S, meas, own_z[i], own_aux[i], x[0], x[1], H)
        for k in range(_neighbours(links, i, world[i] * N, world[i] * N + N, heard)):
            j = heard[k]
            if got_seen[j]:
                _add_measurement(S, meas, got_z[j], got_aux[j], x[0], x[1], H)
        if S[8] > 0.0 and not fresh[i]:
            _solve(S, B, Y)
            loglik[i], nis[i], eps, ok[i] = _update(x, Pi, d, S, Y, K, AP, L)
            measured[i] = True
            for w in range(W - 1):
                new_windows[i, w] = windows[i, w + 1]
            new_windows[i, W - 1] = eps
        for r in range(4):
            out_x[i, r] = x[r] if initialised[i] else np.nan
            for c in range(4):
                out_P[i, r, c] = Pi[r, c] if initialised[i] else np.nan
        if motion_kind[i] == CA_MOTION:
            out_motion[i, 0], out_motion[i, 1] = x[4], x[5]
        elif motion_kind[i] == CT_MOTION:
            out_motion[i, 2] = x[4]
    return loglik, nis, measured, new_windows, (ok, ok.all()), (out_x, out_P, out_motion)


# --- combine: the T-test ----------------------------------------------------------------------------------------


@njit(cache=True)
def _window_mean(w):
    """The mean of a residual window's entries that are not NaN (NaN: none), its sum numpy's pairwise sum
    (:func:`~swarmtrack.estimation.fusion.window_score`: ``np.where(have, w, 0).sum() / max(n, 1)``)."""
    L = w.shape[0]
    count = 0
    for k in range(L):
        count += not np.isnan(w[k])
    if count == 0:
        return np.nan
    if L < 8:
        total = 0.0
        for k in range(L):
            total += w[k] if not np.isnan(w[k]) else 0.0
        return total / count
    r = np.empty(8)
    for j in range(8):
        r[j] = w[j] if not np.isnan(w[j]) else 0.0
    k = 8
    while k < L - L % 8:
        for j in range(8):
            r[j] += w[k + j] if not np.isnan(w[k + j]) else 0.0
        k += 8
    total = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while k < L:
        total += w[k] if not np.isnan(w[k]) else 0.0
        k += 1
    return total / count


@njit(cache=True)
def _position_size(P, policy):
    """Occlusion policies' measure of a position covariance: its trace (eq. 4.39) or its largest eigenvalue
    (4.40, :func:`~swarmtrack.estimation.fusion.select_least_max_eigenvalue`'s closed form)."""
    a, c = P[0, 0], P[1, 1]
    if policy == TRACE:
        return a + c
    b = 0.5 * (P[0, 1] + P[1, 0])
    return 0.5 * (a + c) + np.hypot(0.5 * (a - c), b)


@njit(cache=True)
def combine_ttest(got, links, team, own, policy, switches):
    """Each receiver's output: the valid candidate (its own filter once started; a neighbour's whose message
    arrived and whose filter started) with the least mean residual (W20 eqs. 4.23-4.28); where no valid candidate
    measured this step, the occlusion policy (:data:`LAST`: the last winner while valid, eq. 4.38; :data:`TRACE`,
    :data:`EIGENVALUE`: 4.39, 4.40). ``got``: ``(x, P, measured, started, window, motion)`` of every sender;
    ``team``: ``(N, world)``; ``own``: ``(candidate, initialised, winner)``, each receiver's own candidate number,
    whether its filter started and its last winner (−1: none). Adds the switches in place (W20 Fig. 4.9); returns
    the winners (−1: none), the outputs ``x`` (n, 4), ``P`` (n, 4, 4) (NaN without a winner) and the winners'
    ``[ax, ay, ω]`` (n, 3) (zero without)."""
    got_x, got_P, got_measured, got_started, got_window, got_motion = got
    N, world = team
    candidate, initialised, last = own
    n = candidate.shape[0]
    winner = np.empty(n, dtype=np.int64)
    out_x, out_P, out_motion = np.empty((n, 4)), np.empty((n, 4, 4)), np.zeros((n, 3))
    heard = np.empty(N, dtype=np.int64)
    valid = np.empty(N, dtype=np.bool_)
    for i in range(n):
        base = world[i] * N
        valid[:] = False
        for k in range(_neighbours(links, i, base, base + N, heard)):
            valid[heard[k] % N] = got_started[heard[k]]
        valid[candidate[i]] = initialised[i]
        best, best_score, evidence = -1, np.inf, False
        for c in range(N):
            if valid[c]:
                evidence |= got_measured[base + c]
                score = _window_mean(got_window[base + c])
                if np.isfinite(score) and score < best_score:
                    best, best_score = c, score
        if initialised[i] and not evidence:  # occluded
            if policy == LAST:
                if last[i] >= 0 and valid[last[i]]:
                    best = last[i]
            else:
                best, best_size = -1, np.inf
                for c in range(N):
                    if valid[c]:
                        size = _position_size(got_P[base + c], policy)
                        if np.isfinite(size) and size < best_size:
                            best, best_size = c, size
        switches[i] += best >= 0 and last[i] >= 0 and best != last[i]
        winner[i] = best
        for r in range(4):
            out_x[i, r] = got_x[base + best, r] if best >= 0 else np.nan
            for c in range(4):
                out_P[i, r, c] = got_P[base + best, r, c] if best >= 0 else np.nan
        if best >= 0:
            out_motion[i] = got_motion[base + best]
    return winner, out_x, out_P, out_motion
