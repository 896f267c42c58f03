"""Gaussian labelled multi-Bernoulli (LMB) filter with loopy-belief-propagation data association.

The multi-target state is a set of labelled Bernoulli tracks (Reuter, Vo, Vo & Dietmayer 2014, "The labeled
multi-Bernoulli filter", IEEE TSP 62(12)): track ``ℓ`` exists with probability ``r`` and, if it does, its state
has the density ``N(m, P)``. One cycle::

    predict     r ← P_S r,  m ← F m,  P ← F P Fᵀ + Q                      (LMB prediction, linear-Gaussian)
    update      marginal association probabilities of tracks and detections by loopy belief propagation
                (Williams & Lau 2014, :mod:`swarmtrack.estimation.lbp`), then each track's posterior existence
                and density from its marginals (the LMB approximation of the δ-GLMB posterior, Reuter et al.)
    births      adaptive birth: one Bernoulli per detection, weighted by the probability that no track took it
                (Reuter et al. 2014, adaptive birth distribution)
    prune       drop tracks with small existence, cap their number

The measurement is a 2-D position, ``H = [I₂ 0]`` (the first two state entries), each detection ``z_j`` with its
own covariance ``R_j`` (converted range-bearing detections differ per detection); clutter has the intensity
``kappa_j`` (per m²) at ``z_j``. Each track's density is ONE Gaussian: after an update its posterior mixture (the
missed-detection component plus one Kalman-updated component per gated detection) is collapsed by moment matching,
which is exact when the association is certain.

The update's hot loop (gating, likelihoods, Kalman updates, LBP, moment matching) runs either as the readable numpy
reference or as numba kernels (``compiled=True``, ``@numba.njit(cache=True)``, serial, no fastmath); the tests
hold the two to the same numbers.

Multi-sensor use (iterated corrector): :meth:`LMBFilter.predict` once per step, :meth:`LMBFilter.correct` once per
sensor batch in a fixed order, :meth:`LMBFilter.finish`. A batch's births are appended after its update, so the
next batch of the same step (another sensor's) can already confirm them; with one sensor, the next step's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from swarmtrack.estimation.information import symmetrize
from swarmtrack.estimation.kalman import ekf_update
from swarmtrack.estimation.lbp import MAX_ITER, TOL, lbp, lbp_reference

#: Dimension of the detections: the position ``[x, y]``, the first two state entries.
MEAS_DIM = 2
_LOG_2PI = math.log(2.0 * math.pi)


@dataclass(frozen=True, eq=False)
class Tracks:
    """K labelled Bernoulli tracks with Gaussian densities: ``label`` (K,) int64, existence probabilities ``r``
    (K,), means ``m`` (K, n), covariances ``P`` (K, n, n). Compared by identity (``eq=False``): compare the arrays."""

    label: np.ndarray
    r: np.ndarray
    m: np.ndarray
    P: np.ndarray

    def __post_init__(self) -> None:
        label = np.asarray(self.label, dtype=np.int64).reshape(-1)
        k = label.shape[0]
        r = np.asarray(self.r, dtype=np.float64).reshape(k)
        m = np.asarray(self.m, dtype=np.float64)
        if m.ndim != 2 or m.shape[0] != k:
            raise ValueError(f"m must be (K, n) with K = {k}, got {m.shape}")
        P = np.asarray(self.P, dtype=np.float64)
        if P.shape != (k, m.shape[1], m.shape[1]):
            raise ValueError(f"P must be {(k, m.shape[1], m.shape[1])}, got {P.shape}")
        for name, value in (("label", label), ("r", r), ("m", m), ("P", P)):
            object.__setattr__(self, name, value)

    @classmethod
    def empty(cls, n: int = 4) -> Tracks:
        """No tracks, state dimension ``n``."""
        return cls(np.zeros(0, np.int64), np.zeros(0), np.zeros((0, n)), np.zeros((0, n, n)))

    def __len__(self) -> int:
        return int(self.label.shape[0])

    @property
    def n(self) -> int:
        """The state dimension."""
        return int(self.m.shape[1])

    def take(self, index) -> Tracks:
        """The tracks at ``index`` (integer indices or a boolean mask), in that order."""
        return Tracks(self.label[index], self.r[index], self.m[index], self.P[index])

    def concat(self, other: Tracks) -> Tracks:
        """These tracks followed by ``other``'s."""
        return Tracks(np.concatenate([self.label, other.label]), np.concatenate([self.r, other.r]),
                      np.concatenate([self.m, other.m]), np.concatenate([self.P, other.P]))


def cv_model(dt: float, accel_std: float) -> tuple[np.ndarray, np.ndarray]:
    """Planar constant-velocity model of the state ``[x, y, vx, vy]``: ``(F, Q)``, both (4, 4).

    ``Q`` is the discrete white-noise acceleration model (Bar-Shalom, Li & Kirubarajan 2001, Sec. 6.3.2):
    ``σ² [[dt⁴/4, dt³/2], [dt³/2, dt²]]`` per axis, ``σ = accel_std``.
    """
    dt = float(dt)
    eye = np.eye(2)
    F = np.block([[eye, dt * eye], [np.zeros((2, 2)), eye]])
    q = float(accel_std) ** 2
    Q = q * np.block([[dt**4 / 4 * eye, dt**3 / 2 * eye], [dt**3 / 2 * eye, dt**2 * eye]])
    return F, Q


def predict(tracks: Tracks, F: np.ndarray, Q: np.ndarray, survival) -> Tracks:
    """LMB prediction of surviving tracks, linear-Gaussian (Reuter et al. 2014, prediction of an LMB):
    ``r P_S``, ``F m``, ``F P Fᵀ + Q`` (symmetrised); ``survival`` P_S a scalar or one per track (K,).
    Labels are kept; births are added separately (:func:`births`)."""
    F = np.asarray(F, dtype=np.float64)
    r = tracks.r * np.broadcast_to(np.asarray(survival, dtype=np.float64), tracks.r.shape)
    P = symmetrize(F @ tracks.P @ F.T + np.asarray(Q, dtype=np.float64))
    return Tracks(tracks.label.copy(), r, tracks.m @ F.T, P)


# ----------------------------------------------------------------------------------------------------------------
# The update: numpy reference
# ----------------------------------------------------------------------------------------------------------------


def _likelihoods_reference(m, P, z, R, gate):
    """Gating, likelihoods and Kalman updates of every track-detection pair (numpy reference).

    With ``ν = z_j − H m_i``, ``S = H P_i Hᵀ + R_j``: the pair is gated in when ``d² = νᵀ S⁻¹ ν ≤ gate``; then
    ``g_ij = N(ν; 0, S)``, else ``g_ij = 0``. The updated means and covariances (K, M, n), (K, M, n, n) are the
    Kalman update's (Joseph form, :func:`~swarmtrack.estimation.kalman.ekf_update`) for gated pairs and the
    predicted ``m_i, P_i`` otherwise (so that every number stays finite).
    """
    n = m.shape[1]
    H = np.eye(MEAS_DIM, n)
    nu = z[None, :, :] - m[:, None, :MEAS_DIM]  # (K, M, 2)
    S = symmetrize(P[:, None, :MEAS_DIM, :MEAS_DIM] + R[None])
    d2 = np.einsum("kma,kma->km", nu, np.linalg.solve(S, nu[..., None])[..., 0])
    gated = d2 <= gate
    g = np.where(gated, np.exp(-0.5 * d2 - _LOG_2PI - 0.5 * np.linalg.slogdet(S)[1]), 0.0)
    m_upd, P_upd = ekf_update(m[:, None, :], P[:, None], H, R[None], nu)
    m_upd = np.where(gated[..., None], m_upd, m[:, None, :])
    P_upd = np.where(gated[..., None, None], P_upd, P[:, None])
    return g, m_upd, P_upd


def _miss_factor(r, pd):
    """``r (1 − p_D) / (1 − r p_D)``: the existence of a track given that it generated no detection (0 when
    ``1 − r p_D = 0``)."""
    denom = 1.0 - r * pd
    return np.divide(r * (1.0 - pd), denom, out=np.zeros_like(r), where=denom > 0.0)


def _posterior_reference(r, m, P, pd, p, m_upd, P_upd):
    """Posterior existence and moment-matched density of every track (numpy reference).

    ``r' = Σ_j p_i,j+1 + p_i0 r_i (1 − p_D)/(1 − r_i p_D)``; the density is the mixture of the predicted Gaussian
    (weight ``p_i0 r_i (1 − p_D)/(1 − r_i p_D)``) and the Kalman-updated ones (weights ``p_i,j+1``), normalised by
    ``r'`` and collapsed to one Gaussian: ``m' = Σ w_c m_c``, ``P' = Σ w_c (P_c + (m_c − m')(m_c − m')ᵀ)``.
    A track with ``r' = 0`` keeps its predicted density.
    """
    w = np.concatenate([(p[:, 0] * _miss_factor(r, pd))[:, None], p[:, 1:]], axis=1)  # (K, M + 1)
    r_new = w.sum(axis=1)
    alive = r_new > 0.0
    w = w[alive] / r_new[alive, None]
    means = np.concatenate([m[alive, None, :], m_upd[alive]], axis=1)  # (K', M + 1, n)
    covs = np.concatenate([P[alive, None], P_upd[alive]], axis=1)
    m_new = m.copy()
    P_new = P.copy()
    m_new[alive] = np.einsum("kc,kca->ka", w, means)
    d = means - m_new[alive, None, :]
    P_new[alive] = symmetrize(np.einsum("kc,kcab->kab", w, covs + d[..., :, None] * d[..., None, :]))
    return np.clip(r_new, 0.0, 1.0), m_new, P_new


def _update_reference(r, m, P, z, R, pd, kappa, gate, tol, max_iter):
    """The update of :func:`update` in numpy: ``(r', m', P', p_free)``."""
    g, m_upd, P_upd = _likelihoods_reference(m, P, z, R, gate)
    psi0 = 1.0 - r * pd
    psi = (r * pd)[:, None] * g / kappa[None, :]
    p, p_free = lbp_reference(psi0, psi, tol, max_iter)
    r_new, m_new, P_new = _posterior_reference(r, m, P, pd, p, m_upd, P_upd)
    return r_new, m_new, P_new, p_free


# ----------------------------------------------------------------------------------------------------------------
# The update: numba kernel
# ----------------------------------------------------------------------------------------------------------------


@numba.njit(cache=True, fastmath=False)
def _kalman_pair(m, P, R, i, j, chol, t, m_upd, P_upd):
    """Joseph-form Kalman update of track ``i`` (``m[i]``, symmetric ``P[i]``) with detection ``j`` (covariance
    ``R[j]``) into ``m_upd[i, j]``, ``P_upd[i, j]``, as :func:`_likelihoods_reference`, given ``chol = (l00, l10,
    l11)`` the Cholesky factor of ``S = H P Hᵀ + R_j`` and ``t = S⁻¹ ν``: the gain ``K = P Hᵀ S⁻¹`` by solves with
    ``L``, ``m + K ν = m + P Hᵀ t``, ``(I − K H) P (I − K H)ᵀ + K R Kᵀ``."""
    n = m.shape[1]
    l00, l10, l11 = chol
    Kg = np.empty((n, 2))
    A = np.empty((n, n))
    for a in range(n):
        # row a of K: solve S k = (P[a, 0], P[a, 1])
        y0 = P[i, a, 0] / l00
        y1 = (P[i, a, 1] - l10 * y0) / l11
        Kg[a, 1] = y1 / l11
        Kg[a, 0] = (y0 - l10 * Kg[a, 1]) / l00
        m_upd[i, j, a] = m[i, a] + P[i, a, 0] * t[0] + P[i, a, 1] * t[1]
    for a in range(n):  # A = I − K H
        for b in range(n):
            A[a, b] = (1.0 if a == b else 0.0) - (Kg[a, b] if b < MEAS_DIM else 0.0)
    for a in range(n):  # Joseph form, lower triangle mirrored
        for b in range(a + 1):
            acc = 0.0
            for c in range(n):
                row = 0.0
                for e in range(n):
                    row += A[a, e] * P[i, e, c]
                acc += row * A[b, c]
            acc += Kg[a, 0] * (R[j, 0, 0] * Kg[b, 0] + R[j, 0, 1] * Kg[b, 1]) \
                + Kg[a, 1] * (R[j, 1, 0] * Kg[b, 0] + R[j, 1, 1] * Kg[b, 1])
            P_upd[i, j, a, b] = acc
            P_upd[i, j, b, a] = acc


@numba.njit(cache=True, fastmath=False)
def _moment_match(w, m, P, m_upd, P_upd, m_out, P_out):
    """Collapse ``w[0] N(m, P) + Σ_j w[j+1] N(m_upd[j], P_upd[j])`` (``Σ w = 1``) to one Gaussian in ``m_out``,
    ``P_out``, as :func:`_posterior_reference`; components of weight 0 are skipped."""
    n = m.shape[0]
    M = m_upd.shape[0]
    for a in range(n):
        acc = w[0] * m[a]
        for j in range(M):
            if w[j + 1] > 0.0:
                acc += w[j + 1] * m_upd[j, a]
        m_out[a] = acc
    for a in range(n):
        for b in range(a + 1):
            acc = w[0] * (P[a, b] + (m[a] - m_out[a]) * (m[b] - m_out[b]))
            for j in range(M):
                if w[j + 1] > 0.0:
                    acc += w[j + 1] * (P_upd[j, a, b] + (m_upd[j, a] - m_out[a]) * (m_upd[j, b] - m_out[b]))
            P_out[a, b] = acc
            P_out[b, a] = acc


@numba.njit(cache=True, fastmath=False)
def _likelihood_kernel(r, m, P, z, R, pd, kappa, gate):
    """Gating, likelihoods, association weights and Kalman updates of every pair, compiled (as
    :func:`_likelihoods_reference` and the weights of :func:`_update_reference`): ``(psi0, psi, Ps, m_upd, P_upd)``
    with ``Ps`` the symmetric parts of ``P``; ``m_upd, P_upd`` are set for the gated pairs only (``psi > 0``)."""
    K, n = m.shape
    M = z.shape[0]
    Ps = np.empty((K, n, n))
    for i in range(K):
        for a in range(n):
            for b in range(n):
                Ps[i, a, b] = 0.5 * (P[i, a, b] + P[i, b, a])
    m_upd = np.empty((K, M, n))
    P_upd = np.empty((K, M, n, n))
    psi0 = np.empty(K)
    psi = np.zeros((K, M))
    for i in range(K):
        psi0[i] = 1.0 - r[i] * pd[i]
        for j in range(M):
            # gate first, in registers (most pairs are out): S = H P Hᵀ + R_j = L Lᵀ, d² = |L⁻¹ ν|²
            s00 = Ps[i, 0, 0] + R[j, 0, 0]
            s01 = Ps[i, 0, 1] + R[j, 0, 1]
            d = Ps[i, 1, 1] + R[j, 1, 1] - s01 * s01 / s00 if s00 > 0.0 else 0.0
            if not d > 0.0:
                continue
            l00 = math.sqrt(s00)
            l10 = s01 / l00
            l11 = math.sqrt(d)
            w0 = (z[j, 0] - m[i, 0]) / l00
            w1 = (z[j, 1] - m[i, 1] - l10 * w0) / l11
            d2 = w0 * w0 + w1 * w1
            if not d2 <= gate:
                continue
            g = math.exp(-0.5 * d2 - _LOG_2PI - math.log(l00 * l11))  # N(ν; 0, S), det S = (l00 l11)²
            psi[i, j] = r[i] * pd[i] * g / kappa[j]
            t1 = w1 / l11  # Lᵀ t = w: t = S⁻¹ ν
            _kalman_pair(m, Ps, R, i, j, (l00, l10, l11), ((w0 - l10 * t1) / l00, t1), m_upd, P_upd)
    return psi0, psi, Ps, m_upd, P_upd


@numba.njit(cache=True, fastmath=False)
def _posterior_kernel(r, pd, p, m, Ps, m_upd, P_upd):
    """Posterior existence and moment-matched density of every track, compiled (as :func:`_posterior_reference`):
    ``(r', m', P')``."""
    K, n = m.shape
    M = p.shape[1] - 1
    r_new = np.empty(K)
    m_new = m.copy()
    P_new = Ps.copy()
    w = np.empty(M + 1)
    for i in range(K):
        denom = 1.0 - r[i] * pd[i]
        miss = r[i] * (1.0 - pd[i]) / denom if denom > 0.0 else 0.0
        w[0] = p[i, 0] * miss
        total = w[0]
        for j in range(M):
            w[j + 1] = p[i, j + 1]
            total += w[j + 1]
        r_new[i] = min(max(total, 0.0), 1.0)
        if total > 0.0:
            for c in range(M + 1):
                w[c] /= total
            _moment_match(w, m[i], Ps[i], m_upd[i], P_upd[i], m_new[i], P_new[i])
    return r_new, m_new, P_new


def _update_compiled(r, m, P, z, R, pd, kappa, gate, tol, max_iter):
    """The update of :func:`update` by the numba kernels: :func:`_likelihood_kernel`, LBP
    (:func:`~swarmtrack.estimation.lbp.lbp`), :func:`_posterior_kernel`; same numbers as :func:`_update_reference`.

    The three are called from here, not from one kernel: numba's cache of a kernel is keyed on its own module's
    source only, so a kernel calling ``lbp`` would keep running a cached old ``lbp`` after lbp.py changed."""
    psi0, psi, Ps, m_upd, P_upd = _likelihood_kernel(r, m, P, z, R, pd, kappa, gate)
    p, p_free = lbp(psi0, psi, tol, max_iter)
    r_new, m_new, P_new = _posterior_kernel(r, pd, p, m, Ps, m_upd, P_upd)
    return r_new, m_new, P_new, p_free


# ----------------------------------------------------------------------------------------------------------------
# The public steps
# ----------------------------------------------------------------------------------------------------------------


def _detections(z, R, kappa) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    z = np.ascontiguousarray(np.asarray(z, dtype=np.float64).reshape(-1, MEAS_DIM))
    M = z.shape[0]
    R = np.ascontiguousarray(symmetrize(np.asarray(R, dtype=np.float64).reshape(M, MEAS_DIM, MEAS_DIM)))
    kappa = np.ascontiguousarray(np.broadcast_to(np.asarray(kappa, dtype=np.float64), (M,)))
    if (kappa <= 0.0).any():
        raise ValueError("the clutter intensity kappa must be > 0 at every detection")
    return z, R, kappa


def update(tracks: Tracks, z, R, pd, kappa, gate: float, compiled: bool = True, tol: float = TOL,
           max_iter: int = MAX_ITER) -> tuple[Tracks, np.ndarray]:
    """LMB update with one batch of 2-D position detections, data association by loopy belief propagation.

    For each pair of track ``i`` and detection ``j`` with ``d² = νᵀ S⁻¹ ν ≤ gate`` (``ν = z_j − H m_i``,
    ``S = H P_i Hᵀ + R_j``) the likelihood is ``g_ij = N(ν; 0, S)``; the association weights are
    ``ψ0_i = 1 − r_i p_D`` and ``ψ_ij = r_i p_D g_ij / κ_j`` (0 for pairs gated out), their marginals ``p`` come
    from LBP (Williams & Lau 2014) and the posterior of each track is (Reuter et al. 2014, LMB update with
    marginal association probabilities)::

        r_i' = Σ_j p_i,j+1 + p_i0 r_i (1 − p_D) / (1 − r_i p_D)          (0 when 1 − r_i p_D = 0; clipped to [0, 1])
        p_i'(x) ∝ p_i0 r_i (1 − p_D)/(1 − r_i p_D) N(x; m_i, P_i) + Σ_j p_i,j+1 N(x; m_ij, P_ij)

    with ``m_ij, P_ij`` the Kalman update (Joseph form) of track ``i`` with detection ``j``. The mixture is collapsed
    to one Gaussian by moment matching (its mean, and its covariance including the spread of the means): exact
    when the association is certain, an approximation otherwise.

    Parameters
    ----------
    tracks : Tracks
        The predicted tracks (state dimension ``n ≥ 2``, position first).
    z : (M, 2) array
        The detections' positions.
    R : (M, 2, 2) array
        Each detection's covariance.
    pd : float or (K,) array
        Detection probability of each track.
    kappa : float or (M,) array
        Clutter intensity at each detection (per m², > 0).
    gate : float
        Threshold on the squared Mahalanobis distance ``d²``.
    compiled : bool
        Run the numba kernels (default) or the numpy reference; both give the same numbers.
    tol, max_iter
        LBP's convergence tolerance and iteration bound (:func:`~swarmtrack.estimation.lbp.lbp`).

    Returns
    -------
    tracks : Tracks
        The updated tracks, same labels and order.
    p_free : (M,) array
        Probability that each detection was generated by none of the tracks (weights for :func:`births`).
    """
    z, R, kappa = _detections(z, R, kappa)
    K = len(tracks)
    pd = np.ascontiguousarray(np.broadcast_to(np.asarray(pd, dtype=np.float64), (K,)))
    r = np.ascontiguousarray(tracks.r)
    m = np.ascontiguousarray(tracks.m)
    P = np.ascontiguousarray(tracks.P)
    if compiled:
        r_new, m_new, P_new, p_free = _update_compiled(r, m, P, z, R, pd, kappa, float(gate), float(tol),
                                                     int(max_iter))
    else:
        r_new, m_new, P_new, p_free = _update_reference(r, m, symmetrize(P), z, R, pd, kappa, float(gate),
                                                        float(tol), int(max_iter))
    return Tracks(tracks.label.copy(), r_new, m_new, P_new), p_free


def births(z, R, weight, birth_rate: float, r_max: float, velocity_std: float, labels) -> Tracks:
    """Adaptive birth (Reuter et al. 2014, adaptive birth distribution): one Bernoulli per detection.

    ``r_B(z_j) = min(r_max, λ_B w_j / max(1, Σ_j' w_j'))`` with ``w_j`` the probability that no track took
    detection ``j`` (``p_free`` of the update of the same batch) and ``λ_B = birth_rate`` the expected number of
    births; the density ``N([z_j, 0, 0], blockdiag(R_j, velocity_std² I₂))`` (state ``[x, y, vx, vy]``); labels
    ``labels`` (M,), one per detection (an int: ``labels``, ``labels + 1``, ... in detection order).

    Reuter et al. normalise the weights by ``Σ w`` whatever it is; here by at least 1, so that a batch whose
    detections the tracks explain (``Σ w`` small: a lone detection of a known object from another UAV's sensor)
    begets births of total existence ``λ_B Σ w``, not ``λ_B``: otherwise each such detection would start a twin of
    the track that explains it, which the next batches confirm beside it.
    """
    z, R, _ = _detections(z, R, 1.0)
    M = z.shape[0]
    w = np.broadcast_to(np.asarray(weight, dtype=np.float64), (M,))
    r = np.minimum(r_max, birth_rate * w / max(1.0, float(w.sum())))
    m = np.concatenate([z, np.zeros((M, 2))], axis=1)
    P = np.zeros((M, 4, 4))
    P[:, :2, :2] = R
    P[:, 2, 2] = P[:, 3, 3] = float(velocity_std) ** 2
    labels = np.arange(labels, labels + M, dtype=np.int64) if np.ndim(labels) == 0 else labels
    return Tracks(labels, r, m, P)


def prune(tracks: Tracks, threshold: float = 1e-3, max_tracks: int | None = None) -> Tracks:
    """The tracks with ``r ≥ threshold``, at most ``max_tracks`` of them (those of largest ``r``, ties to the
    smaller label), in label order."""
    keep = np.flatnonzero(tracks.r >= threshold)
    if max_tracks is not None and keep.size > max_tracks:
        order = np.lexsort((tracks.label[keep], -tracks.r[keep]))  # r descending, then label ascending
        keep = keep[order[:max_tracks]]
    keep = keep[np.argsort(tracks.label[keep], kind="stable")]
    return tracks.take(keep)


def merge_twins(tracks: Tracks, gate: float) -> Tracks:
    """Tracks that are one object's twice (the squared Mahalanobis distance of their positions, with the sum of
    their position covariances, at most ``gate``) kept once: the likelier (ties: the older label); the other
    dropped. Twins arise where two UAVs began the same object from different
    detections and their tracks meet by fusion, and where one batch's birth and another's were of one object."""
    k = len(tracks)
    if k < 2:
        return tracks
    order = np.lexsort((tracks.label, -tracks.r))  # likeliest first, ties to the older label
    m, P = tracks.m[order, :2], tracks.P[order, :2, :2]
    d = m[:, None, :] - m[None, :, :]
    S = P[:, None] + P[None, :]
    d2 = np.einsum("abi,abi->ab", d, np.linalg.solve(S, d[..., None])[..., 0])
    alive = np.ones(k, dtype=bool)
    for a in range(k):
        if alive[a]:
            alive[(d2[a] <= gate) & (np.arange(k) > a)] = False
    return tracks.take(np.sort(order[alive]))


def estimates(tracks: Tracks, threshold: float = 0.5) -> Tracks:
    """The confirmed tracks: those with ``r > threshold``."""
    return tracks.take(np.flatnonzero(tracks.r > threshold))


class LMBFilter:
    """An LMB filter: its tracks and a label counter.

    One step: :meth:`predict`, :meth:`correct` once per sensor batch in a fixed order (iterated corrector), then
    :meth:`finish`. Deterministic: the same inputs give the same labels and numbers.

    Parameters
    ----------
    compiled : bool
        Run the update's numba kernels (default) or its numpy reference.

    The tracks are planar constant-velocity ones, state ``[x, y, vx, vy]`` (as :func:`births` makes them).
    """

    def __init__(self, compiled: bool = True) -> None:
        self.tracks = Tracks.empty(4)
        self.next_label = 0
        self.compiled = compiled

    def predict(self, F: np.ndarray, Q: np.ndarray, survival) -> None:
        """Predict every track (:func:`predict`)."""
        self.tracks = predict(self.tracks, F, Q, survival)

    def correct(self, z, R, pd, kappa, gate: float, birth_rate: float, r_max: float, velocity_std: float,
                labels=None) -> np.ndarray:
        """One sensor batch: :func:`update` with its detections, then :func:`births` from the same detections
        weighted by their ``p_free``, appended, labelled ``labels`` (M,) (None: new labels from the counter).
        ``pd`` is per track of the tracks before this batch (or a scalar). Returns ``p_free`` (M,)."""
        updated, p_free = update(self.tracks, z, R, pd, kappa, gate, compiled=self.compiled)
        if labels is None:
            labels = self.next_label
            self.next_label += len(p_free)
        born = births(z, R, p_free, birth_rate, r_max, velocity_std, labels)
        self.tracks = updated.concat(born)
        return p_free

    def finish(self, threshold: float = 1e-3, max_tracks: int | None = None, merge: float | None = None) -> None:
        """End of a step: :func:`merge_twins` within ``merge`` (None: not), then :func:`prune`."""
        if merge is not None:
            self.tracks = merge_twins(self.tracks, merge)
        self.tracks = prune(self.tracks, threshold, max_tracks)

    def estimates(self, threshold: float = 0.5) -> Tracks:
        """The confirmed tracks (:func:`estimates`)."""
        return estimates(self.tracks, threshold)


__all__ = ["MEAS_DIM", "LMBFilter", "Tracks", "births", "cv_model", "estimates", "merge_twins", "predict", "prune",
           "update"]
