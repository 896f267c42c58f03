"""The robustness study's figure (issue 11): degradation curves over runs."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from swarmtrack.analysis.figure_style import (
    agent_color,
    new_figure,
    save_figure,
)


def plot_degradation(curves: Mapping[str, Mapping[str, tuple]], xlabel: str, path: str | Path,
                     ticks: Sequence[str] | None = None) -> Path:
    """Degradation curves (issue 11's robustness study): one panel per metric, per setting (``curves``: label →
    metric → ``(x, mean, std)`` over runs) the mean with ±1 std error bars (NEES on a log scale); ``ticks``: names
    of a categorical x."""
    metrics_ = list(dict.fromkeys(m for per in curves.values() for m in per))
    fig = new_figure((5.5 * len(metrics_), 4.2))
    axes = np.atleast_1d(fig.subplots(1, len(metrics_)))
    for ax, m in zip(axes, metrics_, strict=True):
        for k, (label, per) in enumerate(curves.items()):
            if m in per and len(per[m][0]):
                x, mean, std = per[m]
                ax.errorbar(x, mean, yerr=std, marker="o", capsize=3, label=label, color=agent_color(k),
                            linestyle="none" if ticks is not None else "-")  # categories are not a curve
        ax.set_xlabel(xlabel)
        ax.set_ylabel(m)
        if m == "NEES":  # a consistent filter's 4 beside an overconfident one's hundreds
            ax.set_yscale("log")
        if ticks is not None:
            ax.set_xticks(range(len(ticks)), ticks, rotation=20, fontsize=8)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Mean, ±1 std over runs", fontsize=10)
    return save_figure(fig, path)
