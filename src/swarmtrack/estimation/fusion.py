"""Multi-model fusion kernels of W20 Ch. 4, batched over receivers (numpy).

A team of N UAVs each runs a covariance-form EKF with its own motion model (CV, CA or CT); the first four states
of every model are the common block ``[x, y, vx, vy]``. After each update a UAV shares its common-block posterior
``x (4,)``, ``P (4, 4)``, its measurement log-likelihood and a window of its last residuals, and every UAV fuses
the candidates it received (itself and the neighbours whose messages arrived) into its output estimate.

Every kernel here works on B independent fusion problems ("receivers") of M candidates at once: dense arrays
with a leading ``(B, M)`` and a boolean ``valid (B, M)`` (candidate m is available to receiver b). Entries of
unavailable candidates may hold anything, NaN included; they never reach a result. In the simulator
``B = M = N`` (receiver i's candidates are all N UAVs, masked by the links). There is no Python loop over B
(``ml_fuse`` loops over the small candidate axis M), no matrix inverse (solves and Cholesky factors), and every
covariance returned is symmetric. ``imm_mix`` and ``moment_combine`` read only the upper triangle of the input
covariances and return exactly symmetric ones (upper triangle mirrored); ``log_gaussian`` reads the lower
triangle. ``imm_mix`` holds O(B M² d²) numbers (every destination mixes every source), fine for the dense
``B = M = N`` of a simulator of tens of UAVs.

The fusion rules (W20 Sec. 4.3):

* T-test selection, eqs. 4.23-4.28: ``window_score`` then ``ttest_select``.
* The thesis' IMM, eqs. 4.31-4.35 (no mixing): ``imm_predict`` → ``imm_update`` (likelihoods from
  ``log_gaussian``) → ``moment_combine``.
* The standard IMM (Bar-Shalom) adds the interaction step: ``imm_mix`` (which also returns the predicted mode
  probabilities) → each model's own predict/update from the mixed prior → ``log_gaussian`` → ``imm_update`` →
  ``moment_combine``. ``extend_to_model`` carries a mixed common block into a model with more states.
* Maximum-likelihood fusion, eqs. 4.36-4.37: ``ml_fuse``.
* Occlusion policies, eqs. 4.39-4.40: ``select_least_trace``, ``select_least_max_eigenvalue`` (policy 4.38,
  keep the last T-test winner, is the caller's).

Mode-probability conventions: ``rho[i, j]`` is the probability of switching from model i to model j (rows sum
to 1, the same as FilterPy's ``IMMEstimator.M``), and the predicted probabilities are ``mu @ rho``.
"""

from __future__ import annotations

import functools

import numpy as np

from swarmtrack.estimation.information import symmetrize

_LOG_2PI = float(np.log(2.0 * np.pi))


#: The states every target model shares, first in each: ``[x, y, vx, vy]``; fusion across models works on them.
COMMON = 4


def default_markov(n: int, stay: float) -> np.ndarray:
    """A switching matrix over ``n`` models or filters: ``stay`` on the diagonal, the rest of each row spread evenly
    over the others (rows sum to 1)."""
    if n == 1:
        return np.ones((1, 1))
    rho = np.full((n, n), (1.0 - stay) / (n - 1))
    np.fill_diagonal(rho, stay)
    return rho


def _swap(A: np.ndarray) -> np.ndarray:
    return np.swapaxes(A, -1, -2)


def _check_valid(valid, shape) -> np.ndarray:
    valid = np.asarray(valid, dtype=bool)
    if valid.shape != tuple(shape):
        raise ValueError(f"valid has shape {valid.shape}, expected {tuple(shape)}")
    return valid


@functools.lru_cache(maxsize=32)
def _triangle(d: int):
    """Flat indices of the upper triangle of a d x d matrix, and for every flat entry its triangle position (made
    once per size, read-only: the IMM asks every step)."""
    iu0, iu1 = np.triu_indices(d)
    pos = np.empty((d, d), dtype=np.intp)
    pos[iu0, iu1] = pos[iu1, iu0] = np.arange(iu0.size)
    out = iu0, iu1, iu0 * d + iu1, pos.ravel()
    for a in out:
        a.flags.writeable = False
    return out


@functools.lru_cache(maxsize=32)
def _pairs(m: int):
    """``np.triu_indices(m, 1)``, made once per size, read-only."""
    out = np.triu_indices(m, 1)
    for a in out:
        a.flags.writeable = False
    return out


def _upper(P: np.ndarray, upper_flat: np.ndarray) -> np.ndarray:
    """The upper triangles ``(..., d(d+1)/2)`` of ``P (..., d, d)``."""
    d = P.shape[-1]
    return np.take(P.reshape(P.shape[:-2] + (d * d,)), upper_flat, axis=-1)


def _full(vals: np.ndarray, full_of: np.ndarray, d: int) -> np.ndarray:
    """Symmetric ``(..., d, d)`` matrices from their upper triangles (exactly symmetric by construction)."""
    return np.take(vals, full_of, axis=-1).reshape(vals.shape[:-1] + (d, d))


# --- T-test selection (W20 eqs. 4.23-4.28) -------------------------------------------------------------------


def window_score(windows: np.ndarray) -> np.ndarray:
    """T-test ranking statistic of each candidate's residual window (W20 eqs. 4.23-4.28).

    ``windows`` (..., W) holds each candidate's last W residuals, NaN where an entry is missing (start-up, lost
    messages). The thesis' statistic is ``t = (ε̄ − κ̄) / (S_d / √n)`` (eq. 4.28), where ``κ̄`` and ``S_d`` are
    common to all candidates, so ranking candidates by ``t`` is ranking them by ``ε̄``, the mean of the residual
    window. Eq. 4.24 sums n + 1 terms and divides by n, a constant factor that does not change the ranking; here
    ``ε̄`` is the plain mean over the available (non-NaN) entries, so a candidate with a short start-up window is
    comparable with one whose window is full. Returns ``ε̄`` (...), NaN where a window has no entry.
    """
    windows = np.asarray(windows, dtype=float)
    have = ~np.isnan(windows)
    n = have.sum(axis=-1)
    total = np.where(have, windows, 0.0).sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, total / np.maximum(n, 1), np.nan)


def ttest_select(score: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Index of the valid candidate with the lowest finite score (W20 eq. 4.28), per receiver.

    ``score`` (B, M) from ``window_score``, ``valid`` (B, M). Ties go to the lowest index; −1 where no candidate
    is valid with a finite score. Returns (B,) int.
    """
    score = np.asarray(score, dtype=float)
    ok = _check_valid(valid, score.shape) & np.isfinite(score)
    best = np.argmin(np.where(ok, score, np.inf), axis=-1)
    return np.where(ok.any(axis=-1), best, -1)


# --- Mode probabilities (W20 eqs. 4.31-4.35) -----------------------------------------------------------------


def log_gaussian(nu: np.ndarray, S: np.ndarray) -> np.ndarray:
    """``log N(ν; 0, S)`` by a Cholesky factor (the likelihood ``γ`` of W20 eq. 4.31, in log form).

    ``nu`` (..., m), ``S`` (..., m, m) with m the measurement dimension (eq. 4.31's ``√det S`` and ``(2π)^m``
    normaliser): ``−½ (m log 2π + log det S + νᵀ S⁻¹ ν)`` with ``S = L Lᵀ``, ``log det S = 2 Σ log L_ii`` and
    ``νᵀ S⁻¹ ν = ‖L⁻¹ ν‖²``. NaN where ``S`` is not positive definite or ``ν``/``S`` is not finite (such a
    candidate then carries no evidence in ``imm_update``).
    """
    nu = np.asarray(nu, dtype=float)
    S = np.asarray(S, dtype=float)
    m = nu.shape[-1]
    batch = np.broadcast_shapes(nu.shape[:-1], S.shape[:-2])
    nu, S = np.broadcast_to(nu, batch + (m,)), np.broadcast_to(S, batch + (m, m))
    if m <= _SMALL:
        return _log_gaussian_small(nu, S)
    finite = np.isfinite(S).all(axis=(-1, -2)) & np.isfinite(nu).all(axis=-1)
    eye = np.eye(m)
    if not finite.all():
        S = np.where(finite[..., None, None], S, eye)
    try:
        L = np.linalg.cholesky(S)
        bad = ~finite
    except np.linalg.LinAlgError:  # some rows are not positive definite: find them (off the fast path)
        with np.errstate(invalid="ignore"):
            bad = ~finite | ~(np.linalg.eigvalsh(symmetrize(S))[..., 0] > 0)
        L = np.linalg.cholesky(np.where(bad[..., None, None], eye, S))
    diag = np.diagonal(L, axis1=-2, axis2=-1)
    bad = bad | ~(diag > 0).all(axis=-1)
    y = np.linalg.solve(L, np.where(bad[..., None], 0.0, nu)[..., None])[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        out = -0.5 * (m * _LOG_2PI + 2.0 * np.log(diag).sum(axis=-1) + (y * y).sum(axis=-1))
    return np.where(bad, np.nan, out)


_SMALL = 4  # measurement dimensions up to this use the unrolled Cholesky below


def _log_gaussian_small(nu: np.ndarray, S: np.ndarray) -> np.ndarray:
    """``log_gaussian`` for small m: the Cholesky factor and the forward substitution unrolled over the
    m(m+1)/2 entries, each step vectorised over the batch (LAPACK's per-matrix call overhead dominates for
    2 x 2). Reads the lower triangle of ``S``, as ``np.linalg.cholesky`` does."""
    m = nu.shape[-1]
    L = [[None] * m for _ in range(m)]
    y = [None] * m
    ok = np.ones(nu.shape[:-1], dtype=bool)
    logdet = maha = 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        for j in range(m):
            pivot = S[..., j, j] - sum(L[j][k] * L[j][k] for k in range(j))
            ok &= pivot > 0  # False for NaN too
            ljj = np.sqrt(np.where(ok, pivot, 1.0))
            L[j][j] = ljj
            for i in range(j + 1, m):
                L[i][j] = (S[..., i, j] - sum(L[i][k] * L[j][k] for k in range(j))) / ljj
            y[j] = (nu[..., j] - sum(L[j][k] * y[k] for k in range(j))) / ljj
            logdet = logdet + np.log(ljj)
            maha = maha + y[j] * y[j]
        out = -0.5 * (m * _LOG_2PI + 2.0 * logdet + maha)
    return np.where(ok & np.isfinite(out), out, np.nan)


def imm_predict(mu: np.ndarray, rho: np.ndarray, matmul=np.matmul) -> np.ndarray:
    """Predicted mode probabilities ``μ_j(k|k−1) = Σ_i ρ_ij μ_i(k−1|k−1)`` (W20 eq. 4.34), i.e. ``mu @ rho``.

    ``mu`` (B, M), ``rho`` (M, M) with ``rho[i, j]`` the probability of switching from i to j (rows sum to 1).
    ``matmul``: how the product is taken (a subset of a swarm's UAVs: :meth:`~swarmtrack.network.rows.Rows.matmul`,
    each row bit for bit the whole swarm's).
    """
    mu = np.asarray(mu, dtype=float)
    rho = np.asarray(rho, dtype=float)
    M = mu.shape[-1]
    if rho.shape != (M, M):
        raise ValueError(f"rho has shape {rho.shape}, expected {(M, M)}")
    return matmul(mu, rho)


def imm_update(mu_pred: np.ndarray, loglik: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Posterior mode probabilities ``μ_j = μ_j(k|k−1) γ_j / c`` (W20 eqs. 4.32-4.33), in log space.

    The normaliser is the SPEC's corrected ``c = Σ_j μ_j(k|k−1) γ_j`` (the thesis prints it differently),
    evaluated by log-sum-exp of ``log μ_j(k|k−1) + log γ_j`` so that likelihoods such as ``exp(−2000)`` do not
    underflow. ``mu_pred`` (B, M), ``loglik`` (B, M) = ``log γ`` (``log_gaussian``), ``valid`` (B, M).

    Candidates without evidence (``valid`` False or ``loglik`` NaN) keep their predicted probability; the
    predicted mass of the candidates with evidence, ``Σ_{j∈E} μ_j(k|k−1)``, is redistributed among them in
    proportion to ``μ_j(k|k−1) γ_j``, so a row's total is unchanged (1 for a normalised ``mu_pred``). With
    every candidate valid this is exactly eq. 4.32-4.33. A row where no candidate has evidence, or where the
    evidence is degenerate (every ``μ_j(k|k−1) γ_j`` zero, or a ``+inf`` log-likelihood), keeps ``mu_pred``.
    """
    mu_pred = np.asarray(mu_pred, dtype=float)
    loglik = np.asarray(loglik, dtype=float)
    ev = _check_valid(valid, mu_pred.shape) & ~np.isnan(loglik)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(ev, np.log(mu_pred) + np.where(ev, loglik, 0.0), -np.inf)
        top = a.max(axis=-1, keepdims=True)
        usable = np.isfinite(top)
        e = np.exp(a - np.where(usable, top, 0.0))
        share = e / e.sum(axis=-1, keepdims=True)
    mass = np.where(ev, mu_pred, 0.0).sum(axis=-1, keepdims=True)
    return np.where(ev & usable, mass * share, mu_pred)


def moment_combine(w: np.ndarray, x: np.ndarray, P: np.ndarray):
    """Moment-matched Gaussian of a weighted mixture (W20 eq. 4.35 and its covariance).

    ``x̄ = Σ_m w_m x_m`` and ``P̄ = Σ_m w_m (P_m + (x_m − x̄)(x_m − x̄)ᵀ)`` with the weights renormalised over
    the positive entries of each row. ``w`` (B, M), ``x`` (B, M, d), ``P`` (B, M, d, d). Entries with zero
    weight are ignored (they may hold NaN); a row with no positive weight gives NaN. Negative weights are an
    error. Returns ``x̄`` (B, d), ``P̄`` (B, d, d).
    """
    w = np.asarray(w, dtype=float)
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    if (w < 0).any():
        raise ValueError("moment_combine: negative weight")
    use = w > 0
    d = x.shape[-1]
    iu0, iu1, upper_flat, full_of = _triangle(d)
    with np.errstate(invalid="ignore", divide="ignore"):
        wn = np.where(use, w, 0.0)
        wn = (wn / wn.sum(axis=-1, keepdims=True))[..., None, :]  # (B, 1, M)
    if not use.all():
        x = np.where(use[..., None], x, 0.0)
        P = np.where(use[..., None, None], P, 0.0)
    xbar = wn @ x  # (B, 1, d)
    dx = x - xbar
    # Σ w (P + dx dxᵀ) on the upper triangles only, then mirrored: exactly symmetric
    vals = _upper(P, upper_flat)
    vals += np.take(dx, iu0, axis=-1) * np.take(dx, iu1, axis=-1)
    vals = wn @ vals
    return xbar[..., 0, :], _full(vals[..., 0, :], full_of, d)


def imm_mix(mu: np.ndarray, rho: np.ndarray, x: np.ndarray, P: np.ndarray, valid: np.ndarray | None = None,
            matmul=np.matmul):
    """IMM interaction (mixing) step (Bar-Shalom; W20 builds on it in Sec. 4.3.2).

    ``c̄_j = Σ_i ρ_ij μ_i``, ``μ_{i|j} = ρ_ij μ_i / c̄_j``, ``x0_j = Σ_i μ_{i|j} x_i`` and
    ``P0_j = Σ_i μ_{i|j} (P_i + (x_i − x0_j)(x_i − x0_j)ᵀ)``. ``mu`` (B, M), ``rho`` (M, M) with
    ``rho[i, j] = P(i → j)``, ``x`` (B, M, d), ``P`` (B, M, d, d), ``valid`` (B, M) or None (all valid).

    Invalid candidates are excluded as sources: the mixing weights of column j are ``ρ_ij μ_i`` over the valid
    i, renormalised to sum to 1. Every destination j gets a mixed prior (the caller decides which ones it runs).
    A column whose valid sources all have ``ρ_ij μ_i = 0`` is not mixed: ``x0_j = x_j``, ``P0_j = P_j``.
    The returned ``mu_pred = mu @ rho`` (``imm_predict``, over all candidates) is the ``μ(k|k−1)`` that
    ``imm_update`` takes, so that mass of a candidate without evidence is carried, not lost. ``matmul`` as in
    :func:`imm_predict`. Returns ``x0`` (B, M, d), ``P0`` (B, M, d, d), ``mu_pred`` (B, M).
    """
    mu = np.asarray(mu, dtype=float)
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    mu_pred = imm_predict(mu, rho, matmul)
    rho = np.asarray(rho, dtype=float)
    M, d = x.shape[-2], x.shape[-1]
    x_in, P_in = x, P
    mu_src = mu
    if valid is not None and _check_valid(valid, mu.shape).all():
        valid = None  # nothing to exclude: skip the masked copies
    if valid is not None:
        valid = _check_valid(valid, mu.shape)
        x = np.where(valid[..., None], x, 0.0)
        P = np.where(valid[..., None, None], P, 0.0)
        mu_src = np.where(valid, mu, 0.0)
    A = mu_src[..., :, None] * rho
    cbar = matmul(mu_src, rho) if valid is not None else mu_pred  # Σ over the valid sources i of ρ_ij μ_i, (B, M_j)
    mixed = cbar > 0
    W = np.swapaxes(A / np.where(mixed, cbar, 1.0)[..., None, :], -1, -2)  # W[b, j, i] = μ_{i|j}
    x0 = W @ x  # (B, M_j, d)
    # Σ_i W_ji (x_i − x0_j)(x_i − x0_j)ᵀ = Σ_{i<k} W_ji W_jk (x_i − x_k)(x_i − x_k)ᵀ (the weights of a column sum
    # to 1): the pairwise spreads do not depend on j and need no x0, and every term is positive semi-definite.
    # One product of the weights with [upper triangles of P_i; pairwise spreads], mirrored at the end, so P0 is
    # exactly symmetric. Written into preallocated blocks: fewer large temporaries.
    iu0, iu1, upper_flat, full_of = _triangle(d)
    ia, ka = _pairs(M)
    lead, pairs, nt = x.shape[:-2], ia.size, iu0.size
    terms = np.empty(lead + (M + pairs, nt))
    np.take(P.reshape(lead + (M, d * d)), upper_flat, axis=-1, out=terms[..., :M, :], mode="clip")
    dxp = x[..., ia, :] - x[..., ka, :]  # (B, pairs, d)
    np.multiply(np.take(dxp, iu0, axis=-1), np.take(dxp, iu1, axis=-1), out=terms[..., M:, :])
    weights = np.empty(lead + (M, M + pairs))
    weights[..., :M] = W
    np.multiply(W[..., ia], W[..., ka], out=weights[..., M:])
    P0 = _full(weights @ terms, full_of, d)
    if not mixed.all():
        x0 = np.where(mixed[..., None], x0, x_in)
        P0 = np.where(mixed[..., None, None], P0, P_in)
    return x0, P0, mu_pred


# --- Maximum-likelihood fusion (W20 eqs. 4.36-4.37) -----------------------------------------------------------


def ml_fuse(x: np.ndarray, P: np.ndarray, valid: np.ndarray, first: np.ndarray):
    """Maximum-likelihood (covariance) fusion, W20 eqs. 4.36-4.37, applied neighbour by neighbour.

    ``x`` (B, M, d), ``P`` (B, M, d, d) (common blocks; eq. 4.36's projection ``S`` is already applied),
    ``valid`` (B, M), ``first`` (B,) int: the receiver's own candidate. Starting from candidate ``first``, every
    other valid candidate m in index order is fused by ``K = P (P + P_m)⁻¹`` (one solve), ``x ← x + K (x_m − x)``
    and ``P ← P − K P``. The covariance is evaluated in the equal Joseph form
    ``(I − K) P (I − K)ᵀ + K P_m Kᵀ`` with ``I − K = P_m (P + P_m)⁻¹`` from the same solve, so it stays
    symmetric positive semi-definite under rounding. For two candidates the result is the closed form
    ``x = P2 (P1 + P2)⁻¹ x1 + P1 (P1 + P2)⁻¹ x2``, ``P = (P1⁻¹ + P2⁻¹)⁻¹``. Rows whose ``first`` is −1 or not
    valid give NaN. Returns ``x`` (B, d), ``P`` (B, d, d).
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    B, M, d = x.shape
    valid = _check_valid(valid, (B, M))
    first = np.asarray(first, dtype=int)
    rows = np.arange(B)
    f = np.clip(first, 0, M - 1)
    own = (first >= 0) & (first < M) & valid[rows, f]
    xf = np.where(own[:, None], x[rows, f], np.nan)
    Pf = np.where(own[:, None, None], P[rows, f], np.nan)
    eye = np.eye(d)
    for m in range(M):
        use = own & valid[:, m] & (first != m)
        if not use.any():
            continue
        u1, u2 = use[:, None], use[:, None, None]
        xm = np.where(u1, x[:, m], 0.0)
        Pm = np.where(u2, P[:, m], 0.0)
        Pa = np.where(u2, Pf, eye)
        sol = np.linalg.solve(np.where(u2, Pa + Pm, eye), np.concatenate([Pa, Pm], axis=-1))
        K, L = _swap(sol[..., :d]), _swap(sol[..., d:])  # P (P + P_m)⁻¹ and P_m (P + P_m)⁻¹ = I − K
        x_new = xf + (K @ (xm - np.where(u1, xf, 0.0))[..., None])[..., 0]
        P_new = symmetrize(L @ Pa @ _swap(L) + K @ Pm @ _swap(K))
        xf = np.where(u1, x_new, xf)
        Pf = np.where(u2, P_new, Pf)
    return xf, Pf


def extend_to_model(x: np.ndarray, P: np.ndarray, xc: np.ndarray, Pc: np.ndarray):
    """Carry a fused/mixed common block ``(xc, Pc)`` into a model with more states (first d states common).

    The model's own extra states are kept through their conditional on the common block:
    ``G = P_xc P_cc⁻¹`` (a solve), ``x_extra ← x_extra + G (xc − x_c)`` and
    ``P_new = [[Pc, Pc Gᵀ], [G Pc, G Pc Gᵀ + (P_xx − G P_cx)]]``, positive definite whenever ``Pc`` and the
    Schur complement ``P_xx − G P_cx`` are. Given the model's own block (``xc = x_c``, ``Pc = P_cc``) it
    returns the input. ``x`` (B, n), ``P`` (B, n, n), ``xc`` (B, d), ``Pc`` (B, d, d), d ≤ n; when n == d it
    returns ``(xc, Pc)``.
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    xc = np.asarray(xc, dtype=float)
    Pc = np.asarray(Pc, dtype=float)
    n, d = x.shape[-1], xc.shape[-1]
    if d > n:
        raise ValueError(f"common block of {d} states is larger than the model's {n}")
    if n == d:
        return xc.copy(), symmetrize(Pc)
    Pcc, Pcx, Pxx = P[..., :d, :d], P[..., :d, d:], P[..., d:, d:]
    G = _swap(np.linalg.solve(Pcc, Pcx))  # P_xc P_cc⁻¹ (P_cc symmetric)
    x_new = np.concatenate([xc, x[..., d:] + (G @ (xc - x[..., :d])[..., None])[..., 0]], axis=-1)
    GPc = G @ Pc
    lower = GPc @ _swap(G) + (Pxx - G @ Pcx)
    P_new = np.concatenate(
        [np.concatenate([Pc, _swap(GPc)], axis=-1), np.concatenate([GPc, lower], axis=-1)], axis=-2
    )
    return x_new, symmetrize(P_new)


# --- Occlusion policies (W20 eqs. 4.39-4.40) ------------------------------------------------------------------


def _masked_argmin(value: np.ndarray, valid: np.ndarray) -> np.ndarray:
    ok = _check_valid(valid, value.shape) & np.isfinite(value)
    best = np.argmin(np.where(ok, value, np.inf), axis=-1)
    return np.where(ok.any(axis=-1), best, -1)


def select_least_trace(Ppos: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Valid candidate with the least position-covariance trace (W20 eq. 4.39); −1 where none.

    ``Ppos`` (B, M, 2, 2): the position block (full covariances differ in size between models; only the leading
    2 × 2 block is read). Ties go to the lowest index. Returns (B,) int.
    """
    Ppos = np.asarray(Ppos, dtype=float)
    return _masked_argmin(Ppos[..., 0, 0] + Ppos[..., 1, 1], valid)


def select_least_max_eigenvalue(Ppos: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Valid candidate whose position covariance has the least largest eigenvalue (W20 eq. 4.40); −1 where none.

    ``Ppos`` (B, M, 2, 2) as in ``select_least_trace``; the eigenvalue of the symmetric 2 × 2 block in closed form
    ``(a + c)/2 + hypot((a − c)/2, b)``. Ties go to the lowest index. Returns (B,) int.
    """
    Ppos = np.asarray(Ppos, dtype=float)
    a, c = Ppos[..., 0, 0], Ppos[..., 1, 1]
    b = 0.5 * (Ppos[..., 0, 1] + Ppos[..., 1, 0])
    return _masked_argmin(0.5 * (a + c) + np.hypot(0.5 * (a - c), b), valid)
