"""Statistics over the runs of a study (seeds): mean, standard deviation and the 95 % t-interval of the mean."""

from __future__ import annotations

import numpy as np


def stats(values: list[float]) -> tuple[float, float]:
    """Mean and standard deviation over seeds."""
    a = np.asarray(values, dtype=float)
    return float(a.mean()), float(a.std())


def mean_std_ci(values) -> dict:
    """Mean, standard deviation (over seeds, as :func:`stats`) and the 95 % t-interval of the mean, and the count;
    None where undefined (no values; one value has no interval)."""
    a = np.asarray(list(values), dtype=float)
    if a.size == 0:
        return {"mean": None, "std": None, "ci95": None, "n": 0}
    mean, std = float(a.mean()), float(a.std())
    ci = None
    if a.size > 1:
        from scipy.stats import t

        half = float(t.ppf(0.975, a.size - 1) * a.std(ddof=1) / np.sqrt(a.size))
        ci = [mean - half, mean + half]
    return {"mean": mean, "std": std, "ci95": ci, "n": int(a.size)}
