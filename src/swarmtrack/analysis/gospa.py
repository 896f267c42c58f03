"""Distances between a set of estimates and the set of true objects: GOSPA (Rahmathullah, García-Fernández and
Svensson 2017, "Generalized optimal sub-pattern assignment metric", FUSION) with its split into localisation,
missed and false parts, and OSPA (Schuhmacher, Vo and Vo 2008). The multi-target metrics of issue 40 are built on
these; each is computed per step, on the positions (or any state vectors) of the two sets.

GOSPA of order ``p`` with cut-off ``c`` and ``alpha`` (0 < alpha <= 2), for estimates X (n) and truths Y (m)::

    d(X, Y) = ( min over assignments γ of  Σ_(i,j)∈γ  min(|x_i − y_j|, c)^p  +  c^p / alpha · (n + m − 2 |γ|) )^(1/p)

A pair is worth assigning when its cut-off distance to the p is below ``2 c^p / alpha`` (for alpha = 2: closer than
``c``); the rest are missed truths and false estimates, ``c^p / alpha`` each. The assignment is
:func:`scipy.optimize.linear_sum_assignment` on the pairs' gains. The split's parts are in the metric's p-th power
(``localisation + missed + false = distance^p``), as Stone Soup's ``GOSPAMetric`` reports them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment


@dataclass(frozen=True)
class Gospa:
    """One step's GOSPA: ``distance``; its p-th power split into ``localisation`` (the assigned pairs' cut-off
    distances to the p), ``missed`` and ``false`` (``c^p / alpha`` per missed truth and per false estimate); the
    counts ``n_missed`` and ``n_false``; ``assignment`` the truth each estimate is assigned to (−1: false)."""

    distance: float
    localisation: float
    missed: float
    false: float
    n_missed: int
    n_false: int
    assignment: np.ndarray


def _rows(points) -> np.ndarray:
    """``points`` as rows (n, k); an empty set as (0, 0)."""
    a = np.asarray(points, dtype=float)
    return a.reshape(len(a), -1) if a.size else np.zeros((len(a), 0))


def _distances(estimates, truths) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The two sets as rows and their Euclidean distances (n, m)."""
    x, y = _rows(estimates), _rows(truths)
    if len(x) and len(y) and x.shape[1] != y.shape[1]:
        raise ValueError(f"estimates of {x.shape[1]} numbers against truths of {y.shape[1]}")
    if not (len(x) and len(y)):
        return x, y, np.zeros((len(x), len(y)))
    return x, y, np.sqrt(((x[:, None, :] - y[None, :, :]) ** 2).sum(axis=-1))


def gospa(estimates, truths, c: float, p: float = 1.0, alpha: float = 2.0) -> Gospa:
    """GOSPA between ``estimates`` (n, k) and ``truths`` (m, k) (module docstring), Euclidean distance between rows."""
    if not c > 0 or not p >= 1 or not 0 < alpha <= 2:
        raise ValueError(f"GOSPA needs c > 0, p >= 1 and 0 < alpha <= 2 (got c={c}, p={p}, alpha={alpha})")
    x, y, d = _distances(estimates, truths)
    n, m = len(x), len(y)
    unassigned = c**p / alpha
    cost = np.minimum(d, c) ** p
    gain = np.minimum(cost - 2 * unassigned, 0.0)  # below 0: assigning the pair beats leaving both out
    assignment = np.full(n, -1, dtype=np.int64)
    if n and m:
        rows, cols = linear_sum_assignment(gain)
        keep = gain[rows, cols] < 0
        assignment[rows[keep]] = cols[keep]
    paired = assignment >= 0
    k = int(paired.sum())
    localisation = float(cost[np.flatnonzero(paired), assignment[paired]].sum())
    missed, false = unassigned * (m - k), unassigned * (n - k)
    return Gospa(float((localisation + missed + false) ** (1 / p)), localisation, missed, false, m - k, n - k,
                 assignment)


def ospa(estimates, truths, c: float, p: float = 1.0) -> float:
    """OSPA of order ``p`` with cut-off ``c`` between ``estimates`` (n, k) and ``truths`` (m, k): the mean cut-off
    distance to the p over the larger set's size, a point left over counting ``c``; 0 when both are empty."""
    if not c > 0 or not p >= 1:
        raise ValueError(f"OSPA needs c > 0 and p >= 1 (got c={c}, p={p})")
    x, y, d = _distances(estimates, truths)
    n, m = len(x), len(y)
    if not max(n, m):
        return 0.0
    cost = np.minimum(d, c) ** p
    total = 0.0
    if n and m:
        rows, cols = linear_sum_assignment(cost)
        total = float(cost[rows, cols].sum())
    return float(((total + c**p * abs(n - m)) / max(n, m)) ** (1 / p))
