"""Metrics computed from a :class:`Recording` (truth is allowed here: this is the evaluation side).

Conventions (L24 Tables 1-3, L23 Table 1): a statistic is computed per UAV and then averaged over the UAVs.
Steps before the chase starts (the first 20 filter iterations, when the filter starts from no information)
are left out of the RMSE and spread, so that the numbers describe tracking, not initialisation.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.sim.recorder import Recording

COMPONENTS = ("x", "y", "vx", "vy")


def _window(rec: Recording) -> np.ndarray:
    """Steps after the chase starts (all steps if it never does)."""
    keep = rec.t >= rec.chase_start - 1e-9
    return keep if keep.any() else np.ones_like(keep)


def errors(rec: Recording) -> np.ndarray:
    """(K, N, 4) estimate minus truth of [x, y, vx, vy]."""
    return rec.estimate - rec.target[:, None, :]


def rmse_table(rec: Recording) -> dict[str, dict[str, float]]:
    """RMSE per phase and in total, per component, mean over UAVs (L24 Tables 1-3), in metres and m/s."""
    err = errors(rec)
    keep = _window(rec)
    table = {}
    groups = [(name, keep & (rec.phase == p)) for p, name in enumerate(rec.phase_names)] + [("total", keep)]
    for name, mask in groups:
        if not mask.any():
            continue
        per_uav = np.sqrt(np.mean(err[mask] ** 2, axis=0))  # (N, 4)
        table[name] = dict(zip(COMPONENTS, per_uav.mean(axis=0).tolist(), strict=True))
    return table


def spread_table(rec: Recording) -> dict[str, float]:
    """Standard deviation over time of each UAV's estimation error, mean over UAVs (L23 Table 1)."""
    err = errors(rec)[_window(rec)]
    return dict(zip(COMPONENTS, err.std(axis=0).mean(axis=0).tolist(), strict=True))


def reported_std(rec: Recording) -> dict[str, float]:
    """The filters' own standard deviation ``sqrt(P_ii)``, mean over time and UAVs (compare with the spread)."""
    sd = np.sqrt(np.diagonal(rec.covariance[_window(rec)], axis1=-2, axis2=-1)).mean(axis=(0, 1))
    return dict(zip(COMPONENTS, sd.tolist(), strict=True))


def nees(rec: Recording) -> float:
    """Mean normalised estimation error squared of [x, y, vx, vy] (4 for a consistent filter)."""
    err = errors(rec)[_window(rec)]
    cov = rec.covariance[_window(rec)]
    sol = np.linalg.solve(cov, err[..., None])[..., 0]
    return float(np.mean(np.einsum("...a,...a->...", err, sol)))


def target_distances(rec: Recording) -> np.ndarray:
    """(K, N) true distance of every UAV to the target."""
    return np.linalg.norm(rec.uav[:, :, :2] - rec.target[:, None, :2], axis=-1)


def pair_distances(rec: Recording) -> np.ndarray:
    """(K, P) true distance of every UAV pair (i < j)."""
    i, j = np.triu_indices(rec.n_agents, 1)
    return np.linalg.norm(rec.uav[:, i, :2] - rec.uav[:, j, :2], axis=-1)


def spacing_offset(rec: Recording, last: float = 10.0) -> float:
    """Steady-state inter-agent distance offset: mean, over the pairs that are neighbours at the end (mean
    distance over the last ``last`` seconds below r_comm), of ``|mean distance − d|``.

    Flocking regulates neighbours only (a_ij = 0 beyond r_comm), so a chain whose outer pair lies beyond r_comm
    is a valid α-lattice, not an offset; :func:`open_pairs` counts such pairs.
    """
    mean = pair_distances(rec)[rec.t >= rec.t[-1] - last].mean(axis=0)
    near = mean < rec.r_comm
    return float(np.mean(np.abs(mean[near] - rec.d))) if near.any() else float("nan")


def open_pairs(rec: Recording, last: float = 10.0) -> int:
    """Pairs that end beyond r_comm (not neighbours): a chain instead of a closed formation."""
    mean = pair_distances(rec)[rec.t >= rec.t[-1] - last].mean(axis=0)
    return int(np.sum(mean >= rec.r_comm))


def spacing_overshoot(rec: Recording) -> float:
    """Largest ``|distance − d|`` of any pair after that pair's distance first crosses d (L23 Fig. 1)."""
    dev = pair_distances(rec)[_window(rec)] - rec.d
    crossed = np.cumsum(np.diff(np.sign(dev), axis=0) != 0, axis=0) > 0
    after = np.where(crossed, np.abs(dev[1:]), 0.0)
    return float(after.max()) if after.size else 0.0


def summary(rec: Recording) -> dict:
    """All scalar metrics of one run, JSON-ready."""
    td = target_distances(rec)[_window(rec)]
    pd = pair_distances(rec)
    return {
        "rmse": rmse_table(rec),
        "spread": spread_table(rec),
        "reported_std": reported_std(rec),
        "nees": nees(rec),
        "target_distance": {"mean": float(td.mean()), "max": float(td.max())},
        "inter_agent_distance": {
            "min": float(pd.min()) if pd.size else float("nan"),
            "offset": spacing_offset(rec) if pd.size else float("nan"),
            "open_pairs": open_pairs(rec) if pd.size else 0,
            "overshoot": spacing_overshoot(rec) if pd.size else float("nan"),
        },
    }
