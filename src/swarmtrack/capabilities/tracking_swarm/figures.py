"""Figures of capability 1's runs: a Gaussian estimate against the truth (L24 Figs. 2-4 and the errors over time;
registered for every Gaussian estimator: the information filter, its centralized baseline, the IMM bank, the
multi-model EKF) and the flocking protocols compared (L23 Fig. 1)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from swarmtrack.analysis import metrics
from swarmtrack.analysis.figure_style import (
    MAX_LINES,
    TARGET_COLOR,
    agent_color,
    figure_title,
    mark_phases,
    mark_phases_on_path,
    new_figure,
    place_legend,
    save_figure,
    time_axis,
)
from swarmtrack.analysis.plots import draw_pair_distances
from swarmtrack.sim.recorder import Recording


def plot_altitude(rec: Recording, path: str | Path) -> Path:
    """A 3-D run (docs/three-d.md): the target's true height and each UAV's estimate of it over time, the UAVs'
    own heights, and the altitude error; and the trajectories in 3-D (the target's, its estimate by UAV 1, the
    UAVs')."""
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    fig = new_figure((15.0, 4.8))
    t = rec.t
    ax = fig.add_subplot(1, 3, 1)
    ax.plot(t, rec.target_altitude[:, 0], color=TARGET_COLOR, lw=2.0, label="true target", zorder=4)
    for i in range(shown):
        ax.plot(t, rec.altitude_estimate[:, i, 0], color=agent_color(i), lw=0.9, alpha=0.85,
                label=f"UAV {i + 1} estimate", zorder=3)
        ax.plot(t, rec.uav_altitude[:, i, 0], color=agent_color(i), lw=0.8, ls=":", zorder=2)
    mark_phases(ax, rec)
    time_axis(ax, rec)
    ax.set_ylabel("z [m]")
    ax.set_title("target height (dotted: the UAVs' own)")
    place_legend(ax, shown + 1)
    ax = fig.add_subplot(1, 3, 2)
    for i in range(shown):
        ax.plot(t, rec.altitude_estimate[:, i, 0] - rec.target_altitude[:, 0], color=agent_color(i), lw=0.9,
                label=f"UAV {i + 1}")
    ax.axhline(0.0, color="0.3", lw=0.6)
    mark_phases(ax, rec)
    time_axis(ax, rec)
    ax.set_ylabel("estimated − true z [m]")
    ax.set_title("altitude error")
    ax = fig.add_subplot(1, 3, 3, projection="3d")
    ax.plot(rec.target[:, 0], rec.target[:, 1], rec.target_altitude[:, 0], color=TARGET_COLOR, lw=2.0,
            label="true target")
    ax.plot(rec.estimate[:, 0, 0], rec.estimate[:, 0, 1], rec.altitude_estimate[:, 0, 0], color=agent_color(0),
            lw=0.9, label="UAV 1 estimate")
    for i in range(shown):
        ax.plot(rec.uav[:, i, 0], rec.uav[:, i, 1], rec.uav_altitude[:, i, 0], color=agent_color(i), lw=0.7,
                ls=":", label=f"UAV {i + 1}" if i == 0 else None)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title("trajectories in 3-D")
    ax.legend(fontsize=7, loc="upper left")
    fig.suptitle(figure_title(rec, "Altitude: estimated and true", shown, n, "UAVs"))
    return save_figure(fig, path)


def plot_estimates(rec: Recording, path: str | Path) -> Path:
    """L24 Figs. 2-4: x-velocity, y-velocity and trajectory; true target in green, each UAV's estimate."""
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    fig = new_figure((15.0, 4.8))
    axes = fig.subplots(1, 3)
    t = rec.t
    for ax, col, comp in ((axes[0], 2, "x"), (axes[1], 3, "y")):
        ax.plot(t, rec.target[:, col], color=TARGET_COLOR, lw=2.0, label="true target", zorder=4)
        for i in range(shown):
            ax.plot(t, rec.estimate[:, i, col], color=agent_color(i), lw=0.9, alpha=0.85,
                    label=f"UAV {i + 1} estimate", zorder=3)
        mark_phases(ax, rec)
        time_axis(ax, rec)
        ax.set_ylabel(f"$v_{comp}$ [m/s]")
        ax.set_title(f"target {comp}-velocity")
    ax = axes[2]
    ax.plot(rec.target[:, 0], rec.target[:, 1], color=TARGET_COLOR, lw=2.0, label="true target", zorder=4)
    for i in range(shown):
        ax.plot(rec.estimate[:, i, 0], rec.estimate[:, i, 1], color=agent_color(i), lw=0.9, alpha=0.85,
                label=f"UAV {i + 1} estimate", zorder=3)
    mark_phases_on_path(ax, rec)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("target trajectory")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.5)
    place_legend(ax, shown + 1)
    fig.suptitle(figure_title(rec, "Estimated and true target state", shown, n, "UAVs"))
    return save_figure(fig, path)



def plot_errors(rec: Recording, path: str | Path) -> Path:
    """Estimation error norms per UAV vs time: ``||q_hat_i - q_t||`` [m] and ``||p_hat_i - p_t||`` [m/s]."""
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    err = metrics.errors(rec)
    pos_err = np.linalg.norm(err[:, :, :2], axis=-1)
    vel_err = np.linalg.norm(err[:, :, 2:4], axis=-1)
    fig = new_figure((9.0, 6.5))
    axes = fig.subplots(2, 1, sharex=True)
    panels = ((axes[0], pos_err, "position error [m]"), (axes[1], vel_err, "velocity error [m/s]"))
    for ax, e, ylabel in panels:
        for i in range(shown):
            ax.plot(rec.t, e[:, i], color=agent_color(i), lw=0.9, label=f"UAV {i + 1}")
        mark_phases(ax, rec)
        time_axis(ax, rec)
        ax.set_ylabel(ylabel)
        ax.set_ylim(bottom=0.0)
    axes[0].set_xlabel("")
    place_legend(axes[0], shown, outside=True)
    fig.suptitle(figure_title(rec, "Target estimation error", shown, n, "UAVs"))
    return save_figure(fig, path)



def plot_flocking_comparison(results: Mapping[str, Recording], path: str | Path) -> Path:
    """L23 Fig. 1: inter-agent distances, one panel per variant (e.g. standard / integral / tailored)."""
    if not results:
        raise ValueError("plot_flocking_comparison needs at least one recording")
    names = list(results)
    fig = new_figure((5.0 * len(names), 4.5))
    axes = fig.subplots(1, len(names), sharey=True, squeeze=False)[0]
    notes = []
    for ax, name in zip(axes, names, strict=True):
        rec = results[name]
        shown, total = draw_pair_distances(ax, rec, legend=ax is axes[-1])
        ax.set_title(str(name))
        if shown < total:
            notes.append(f"{name}: first {shown} of {total} pairs")
    for ax in axes[1:]:
        ax.set_ylabel("")
    model = (results[names[0]].meta or {}).get("model")  # the panels differ by scenario: name only the model
    title = "Inter-agent distances by protocol" + (f" (estimator model: {str(model).upper()})" if model else "")
    if notes:
        title += "\n" + "; ".join(notes)
    fig.suptitle(title)
    return save_figure(fig, path)
