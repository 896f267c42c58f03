"""What a run leaves behind: a :class:`Recording` of truth and onboard estimates at every estimation step.

Analysis (metrics, plots, reproductions) reads recordings, never live simulator objects.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

TIMESERIES_COLUMNS = (
    "t", "phase", "agent",
    "x_true", "y_true", "vx_true", "vy_true",
    "x_est", "y_est", "vx_est", "vy_est",
    "x_uav", "y_uav", "vx_uav", "vy_uav",
)


@dataclass
class Recording:
    """Arrays sampled at the estimation rate; K steps, N UAVs.

    ``target`` (K, 4) and ``uav`` (K, N, 4) are the truth ``[x, y, vx, vy]`` (the world's);
    ``estimate`` (K, N, 4) and ``covariance`` (K, N, 4, 4) are each UAV's onboard estimate of the target's
    ``[x, y, vx, vy]`` and its covariance. ``phase`` (K,) indexes ``phase_names``.
    """

    t: np.ndarray
    phase: np.ndarray
    phase_names: list[str]
    target: np.ndarray
    uav: np.ndarray
    estimate: np.ndarray
    covariance: np.ndarray
    d: float
    r_comm: float
    chase_start: float = 0.0
    meta: dict = field(default_factory=dict)

    @property
    def n_agents(self) -> int:
        return self.uav.shape[1]

    def write_timeseries(self, path: Path) -> None:
        """One row per UAV per estimation step (CSV)."""
        K, N = self.estimate.shape[:2]
        rows = np.empty((K, N, len(TIMESERIES_COLUMNS)))
        rows[:, :, 0] = self.t[:, None]
        rows[:, :, 1] = self.phase[:, None]
        rows[:, :, 2] = np.arange(N)[None, :]
        rows[:, :, 3:7] = self.target[:, None, :]
        rows[:, :, 7:11] = self.estimate
        rows[:, :, 11:15] = self.uav
        with open(path, "w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(TIMESERIES_COLUMNS)
            fmt = ["%.4f", "%d", "%d"] + ["%.6g"] * (len(TIMESERIES_COLUMNS) - 3)
            np.savetxt(fh, rows.reshape(K * N, -1), delimiter=",", fmt=fmt)
