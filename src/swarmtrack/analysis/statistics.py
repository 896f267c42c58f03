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


def binned_band(series, bin_s) -> dict | None:
    """Mean and std (ddof 0) over runs of one time series, per bin, with the count of runs that have the bin:
    ``series`` the runs' values (sequences, None or NaN for an empty bin), ``bin_s`` each run's bin width. Runs align
    on their bins from t = 0: a shorter run leaves its missing bins out, and a run with finer bins than the coarsest
    (a run too long for :data:`~swarmtrack.analysis.metrics.SERIES_MAX_BINS` 1-s bins) is merged into those, each fine
    bin weighing the same. Returns arrays ``t`` (bin centres), ``mean``, ``std`` (NaN where no run has the bin),
    ``n``, and ``bin_s``, ``runs``; None without runs."""
    if not len(series):
        return None
    width = float(max(bin_s))
    rows = []
    for values, fine in zip(series, bin_s, strict=True):
        v = np.asarray([np.nan if x is None else x for x in values], dtype=float)
        factor = int(round(width / float(fine)))
        if factor > 1:
            v = np.concatenate([v, np.full(-len(v) % factor, np.nan)]).reshape(-1, factor)
            counts = np.isfinite(v).sum(axis=1)
            v = np.where(counts > 0, np.nansum(v, axis=1) / np.maximum(counts, 1), np.nan)
        rows.append(v)
    grid = np.full((len(rows), max(len(v) for v in rows)), np.nan)
    for k, v in enumerate(rows):
        grid[k, :len(v)] = v
    n = np.isfinite(grid).sum(axis=0)
    mean = np.where(n > 0, np.nansum(grid, axis=0) / np.maximum(n, 1), np.nan)
    std = np.where(n > 0, np.sqrt(np.nansum((grid - mean) ** 2, axis=0) / np.maximum(n, 1)), np.nan)
    return {"t": (np.arange(grid.shape[1]) + 0.5) * width, "mean": mean, "std": std, "n": n, "bin_s": width,
            "runs": len(rows)}
