"""Fusing a neighbour's tracks into one's own (issue 40): label agreement by assignment, and the geometric average of
two Gaussian Bernoulli tracks.

Two UAVs' filters may hold the same object under the same label (a label names the detection that began the track,
so two filters that began it from the same detection agree) or under different ones (each began it from its own
detections). :func:`match` pairs a neighbour's tracks with one's own: first by label, then, among the rest, by the
assignment (``scipy.optimize.linear_sum_assignment``) that minimises the sum of the squared Mahalanobis distances of
their positions, pairs beyond the χ²(2) ``gate`` left out.

A matched pair is fused by the geometric average (GA) of the two Bernoulli densities with weights ``w`` and
``1 − w`` (Fantacci, Vo, Vo, Battistelli and Chisci 2018, "Robust fusion for multisensor multiobject tracking",
IEEE SPL 25(5), the GA fusion of labelled multi-Bernoulli densities, label-wise): for Gaussian densities the
normalised weighted geometric mean is covariance intersection (Julier and Uhlmann 1997),

    P⁻¹ = w P₁⁻¹ + (1 − w) P₂⁻¹,   P⁻¹ m = w P₁⁻¹ m₁ + (1 − w) P₂⁻¹ m₂,

and the existence probability is

    r = r₁ʷ r₂¹⁻ʷ K / ((1 − r₁)ʷ (1 − r₂)¹⁻ʷ + r₁ʷ r₂¹⁻ʷ K),   K = ∫ N(x; m₁, P₁)ʷ N(x; m₂, P₂)¹⁻ʷ dx.

The GA never counts the same information twice (it is robust to the unknown correlation of two UAVs' tracks that
share detections), so a track passed back and forth over a loop of UAVs does not grow more certain than it is.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.optimize import linear_sum_assignment


def ga_bernoulli(r1: float, m1: np.ndarray, P1: np.ndarray, r2: float, m2: np.ndarray, P2: np.ndarray,
                 w: float = 0.5) -> tuple[float, np.ndarray, np.ndarray]:
    """The geometric average of two Gaussian Bernoulli components (module docstring): ``(r, m, P)``. Covariance
    intersection adds information matrices, so each covariance's is formed, by Cholesky solves (4 x 4, both positive
    definite: a filter's covariances); ``P`` symmetrised."""
    n = len(m1)
    c1, c2 = cho_factor(P1), cho_factor(P2)
    I1, I2 = cho_solve(c1, np.eye(n)), cho_solve(c2, np.eye(n))  # information matrices from the factors
    info = w * I1 + (1.0 - w) * I2
    eta = w * (I1 @ m1) + (1.0 - w) * (I2 @ m2)
    ci = cho_factor(info)
    m = cho_solve(ci, eta)
    P = cho_solve(ci, np.eye(n))
    P = 0.5 * (P + P.T)
    # log K = −½ [w log|P₁| + (1−w) log|P₂| + log|Λ| + w m₁ᵀI₁m₁ + (1−w) m₂ᵀI₂m₂ − ηᵀΛ⁻¹η], Λ = info
    logdet = lambda c: 2.0 * np.log(np.diag(c[0])).sum()  # noqa: E731 - |P| from its Cholesky factor
    log_k = -0.5 * (w * logdet(c1) + (1.0 - w) * logdet(c2) + logdet(ci)
                    + w * m1 @ I1 @ m1 + (1.0 - w) * m2 @ I2 @ m2 - eta @ m)
    if r1 <= 0.0 or r2 <= 0.0:
        return 0.0, m, P
    if r1 >= 1.0 and r2 >= 1.0:
        return 1.0, m, P
    log_yes = w * np.log(r1) + (1.0 - w) * np.log(r2) + log_k
    log_no = w * np.log1p(-min(r1, 1.0)) + (1.0 - w) * np.log1p(-min(r2, 1.0)) if max(r1, r2) < 1.0 else -np.inf
    r = np.exp(-np.logaddexp(0.0, log_no - log_yes))  # 1 / (1 + e^(log_no − log_yes)), without overflow
    return float(r), m, P


def match(own_labels: np.ndarray, own_m: np.ndarray, own_P: np.ndarray, labels: np.ndarray, m: np.ndarray,
          P: np.ndarray, gate: float) -> tuple[list[tuple[int, int]], np.ndarray]:
    """Pairs ``(own, theirs)`` of a neighbour's tracks (``labels``, ``m``, ``P``) with one's own, by label, then by
    the assignment of the positions within the ``gate`` (module docstring); and the neighbour's tracks left
    unmatched (indices)."""
    pairs: list[tuple[int, int]] = []
    index = {int(label): k for k, label in enumerate(own_labels.tolist())}
    rest_theirs = []
    taken = np.zeros(len(own_labels), dtype=bool)
    for j, label in enumerate(labels.tolist()):
        k = index.get(int(label))
        if k is None:
            rest_theirs.append(j)
        else:
            pairs.append((k, j))
            taken[k] = True
    rest_own = np.flatnonzero(~taken)
    theirs = np.asarray(rest_theirs, dtype=np.int64)
    if not len(theirs) or not len(rest_own):
        return pairs, theirs
    d = own_m[rest_own, None, :2] - m[None, theirs, :2]  # (A, B, 2)
    S = own_P[rest_own, None, :2, :2] + P[None, theirs, :2, :2]
    cost = np.einsum("abi,abi->ab", d, np.linalg.solve(S, d[..., None])[..., 0])
    big = gate * 1e3 + 1.0
    rows, cols = linear_sum_assignment(np.where(cost <= gate, cost, big))
    ok = cost[rows, cols] <= gate
    pairs += [(int(rest_own[a]), int(theirs[b])) for a, b in zip(rows[ok], cols[ok], strict=True)]
    left = np.ones(len(theirs), dtype=bool)
    left[cols[ok]] = False
    return pairs, theirs[left]
