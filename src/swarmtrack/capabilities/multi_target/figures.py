"""Figures of a multi-target tracker's runs (issue 40): the tracks over the truth, and GOSPA over time with its
split into localisation, missed and false parts."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from swarmtrack.analysis.figure_style import (
    TARGET_COLOR,
    agent_color,
    figure_title,
    new_figure,
    place_legend,
    save_figure,
    time_axis,
    whole_probe,
)
from swarmtrack.capabilities.multi_target.metrics import ALPHA, C, P, objects, per_step
from swarmtrack.sim.recorder import Recording


def plot_tracks(rec: Recording, path: str | Path, uav: int = 0) -> Path:
    """UAV ``uav``'s reported tracks (points, one colour per label) over the objects' true paths (lines) and the
    UAVs' positions."""
    fig = new_figure((7.5, 7.0))
    ax = fig.add_subplot(1, 1, 1)
    truth = np.concatenate([c.truth[:, objects(rec), :2] for c in rec.chunks(probes_wanted=False)])
    for k in range(truth.shape[1]):
        ax.plot(truth[:, k, 0], truth[:, k, 1], color=TARGET_COLOR, lw=1.6, alpha=0.8,
                label="true objects" if k == 0 else None, zorder=2)
    tracks, labels = whole_probe(rec, "tracks"), whole_probe(rec, "track_labels")
    if tracks is not None and labels is not None:
        lab = labels[:, uav].reshape(-1)
        xy = tracks[:, uav, :, :2].reshape(-1, 2)
        some = ~np.isnan(lab)
        colors = np.asarray([agent_color(int(v)) for v in lab[some]])
        ax.scatter(xy[some, 0], xy[some, 1], s=4, c=colors, label=f"UAV {uav + 1}'s tracks (colour: label)",
                   zorder=3)
    ax.plot(rec.uav[:, :, 0].reshape(-1), rec.uav[:, :, 1].reshape(-1), ".", color="0.3", ms=2, label="UAVs",
            zorder=1)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(figure_title(rec, "tracks over the truth"))
    place_legend(ax, 3)
    return save_figure(fig, path)


def plot_gospa(rec: Recording, path: str | Path) -> Path:
    """GOSPA over time (the mean over the UAVs whose samples came) as its three parts stacked, and the numbers of
    missed objects and false tracks."""
    fig = new_figure((10.0, 6.5))
    parts: dict[str, list[np.ndarray]] = {q: [] for q in ("localisation", "missed", "false", "n_missed", "n_false")}
    t = []
    for c in rec.chunks():
        v = per_step(rec, c)
        t.append(c.t)
        with np.errstate(invalid="ignore"):
            for q in parts:
                parts[q].append(np.nanmean(v[q], axis=1))
    tt = np.concatenate(t)
    mean = {q: np.concatenate(v) for q, v in parts.items()}
    ax = fig.add_subplot(2, 1, 1)
    # the parts are of GOSPA's p-th power: with p = 1 they add up to it
    ax.stackplot(tt, mean["localisation"], mean["missed"], mean["false"], labels=["localisation", "missed", "false"],
                 colors=[agent_color(0), agent_color(1), agent_color(2)], alpha=0.8)
    ax.set_ylabel(f"GOSPA{'' if P == 1 else f'^{P:g}'} [m]")
    ax.set_title(figure_title(rec, f"GOSPA (c = {C:g} m, p = {P:g}, α = {ALPHA:g}), mean over the UAVs"))
    time_axis(ax, rec)
    place_legend(ax, 3)
    ax = fig.add_subplot(2, 1, 2)
    ax.plot(tt, mean["n_missed"], color=agent_color(1), label="missed objects")
    ax.plot(tt, mean["n_false"], color=agent_color(2), label="false tracks")
    ax.set_ylabel("count, mean over UAVs")
    time_axis(ax, rec)
    place_legend(ax, 2)
    return save_figure(fig, path)
