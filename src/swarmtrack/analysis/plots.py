"""The figures of one run: those every run with a followed target gets (L24 Figs. 5-7: trajectories, distances to
the target, inter-agent distances), then those of the kinds it used (their registered
:class:`~swarmtrack.registry.Figure` s, drawn by each capability's ``figures`` module: the estimates and errors of a
Gaussian estimator, W20's model figures, the formation MPC's, IB21's uncertainty); :func:`save_run_figures`.

Every ``plot_*`` function takes a :class:`~swarmtrack.sim.recorder.Recording`, writes one PNG and returns its
:class:`~pathlib.Path`. The shared style (colours, titles, phase marks, legends, the atomic save) is
:mod:`swarmtrack.analysis.figure_style`; for pairs, the min-max envelope over *all* pairs is shaded in grey when
lines were left out.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.axes import Axes

from swarmtrack import registry
from swarmtrack.analysis import metrics
from swarmtrack.analysis.figure_style import (
    MAX_LINES,
    TARGET_COLOR,
    agent_color,
    figure_title,
    mark_phases,
    new_figure,
    pair_labels,
    place_legend,
    save_figure,
    time_axis,
)
from swarmtrack.sim.recorder import Recording

__all__ = ["RUN_FIGURES", "draw_pair_distances", "plot_inter_agent_distances", "plot_target_distances",
           "plot_trajectories", "save_run_figures"]


def plot_trajectories(rec: Recording, path: str | Path, agent: int | None = 0) -> Path:
    """L24 Fig. 5: the target's and one agent's (``agent``, 0-based) actual trajectory.

    ``agent=None`` draws all agents (the first :data:`MAX_LINES`).
    """
    n = rec.n_agents
    if agent is None:
        agents = list(range(min(n, MAX_LINES)))
        what = "Target and agent trajectories"
    else:
        if not 0 <= agent < n:
            raise ValueError(f"agent {agent} out of range for {n} agents")
        agents = [agent]
        what = f"Target and agent {agent + 1} trajectories"
    fig = new_figure((7.5, 6.5))
    ax = fig.subplots()
    ax.plot(rec.target[:, 0], rec.target[:, 1], color=TARGET_COLOR, lw=2.0, label="target", zorder=4)
    for i in agents:
        c = agent_color(i)
        ax.plot(rec.uav[:, i, 0], rec.uav[:, i, 1], color=c, lw=1.0, label=f"agent {i + 1}", zorder=3)
        if len(rec.t):
            ax.plot(rec.uav[0, i, 0], rec.uav[0, i, 1], marker="o", color=c, ms=5, ls="none", zorder=5)
            ax.plot(rec.uav[-1, i, 0], rec.uav[-1, i, 1], marker="s", color=c, ms=5, ls="none", zorder=5)
    if len(rec.t):
        ax.plot(rec.target[0, 0], rec.target[0, 1], marker="o", color=TARGET_COLOR, ms=6, ls="none", zorder=5)
        ax.plot(rec.target[-1, 0], rec.target[-1, 1], marker="s", color=TARGET_COLOR, ms=6, ls="none",
                zorder=5)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.5)
    place_legend(ax, len(agents) + 1)
    shown = len(agents) if agent is None else None
    title = figure_title(rec, what, shown, n, "agents") + "\n(o start, \u25a1 end)"
    ax.set_title(title, fontsize=10)
    return save_figure(fig, path)


def plot_target_distances(rec: Recording, path: str | Path) -> Path:
    """L24 Fig. 6: ``||q_i - q_t||`` per UAV vs time."""
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    dist = metrics.target_distances(rec)
    fig = new_figure((9.0, 4.8))
    ax = fig.subplots()
    for i in range(shown):
        ax.plot(rec.t, dist[:, i], color=agent_color(i), lw=1.0, label=f"UAV {i + 1}")
    mark_phases(ax, rec)
    time_axis(ax, rec)
    ax.set_ylabel(r"$\|q_i - q_t\|$ [m]")
    ax.set_ylim(bottom=0.0)
    place_legend(ax, shown, outside=True)
    ax.set_title(figure_title(rec, "Relative distance between target and UAVs", shown, n, "UAVs"), fontsize=10)
    return save_figure(fig, path)


def draw_pair_distances(ax: Axes, rec: Recording, legend: bool = True) -> tuple[int, int]:
    """Pair distances, the desired spacing ``d`` and ``r_comm`` on ``ax``; return (pairs shown, total)."""
    dist, labels = metrics.pair_distances(rec), pair_labels(rec.n_agents)
    total = dist.shape[1]
    shown = min(total, MAX_LINES)
    if total > shown:
        ax.fill_between(rec.t, dist.min(axis=1), dist.max(axis=1), color="0.8", lw=0, zorder=1,
                        label=f"all {total} pairs (min-max)")
    for p in range(shown):
        ax.plot(rec.t, dist[:, p], color=agent_color(p), lw=1.0, label=labels[p], zorder=3)
    if np.isfinite(rec.d):  # a flocking run's desired distance (other controllers have none)
        ax.axhline(rec.d, color="black", lw=1.0, ls="-", label=f"d = {rec.d:g} m", zorder=2)
    ax.axhline(rec.r_comm, color="black", lw=1.0, ls="--", label=f"$r_{{comm}}$ = {rec.r_comm:g} m", zorder=2)
    if total == 0:
        ax.text(0.5, 0.5, "fewer than 2 agents: no pairs", transform=ax.transAxes, ha="center", va="center")
    time_axis(ax, rec)
    ax.set_ylabel("inter-agent distance [m]")
    ax.set_ylim(bottom=0.0)
    if legend:
        place_legend(ax, shown + 2, outside=True)
    return shown, total


def plot_inter_agent_distances(rec: Recording, path: str | Path) -> Path:
    """L24 Fig. 7 / L23 Fig. 1: each agent pair's distance vs time; ``d`` solid, ``r_comm`` dashed."""
    fig = new_figure((9.0, 4.8))
    ax = fig.subplots()
    shown, total = draw_pair_distances(ax, rec)
    mark_phases(ax, rec)
    ax.set_title(figure_title(rec, "Inter-agent distances and communication range", shown, total, "pairs"),
                 fontsize=10)
    return save_figure(fig, path)



def _follows(rec: Recording) -> bool:
    return rec.tracked is not None


#: The figures every run with a followed target gets.
RUN_FIGURES = (registry.Figure("trajectories.png", plot_trajectories, _follows),
               registry.Figure("target_distances.png", plot_target_distances, _follows),
               registry.Figure("inter_agent_distances.png", plot_inter_agent_distances, _follows))


def run_figures(rec: Recording) -> list[registry.Figure]:
    """The figures ``rec`` gets: :data:`RUN_FIGURES`, then those of the kinds it used
    (:func:`swarmtrack.analysis.metrics.run_kinds`), each file once, when they apply."""
    out, files = [], set()
    for fig in (*RUN_FIGURES, *(f for kind in metrics.run_kinds(rec) for f in kind.figures)):
        if fig.file not in files and fig.applies(rec):
            files.add(fig.file)
            out.append(fig)
    return out


def save_run_figures(rec: Recording, out_dir: str | Path) -> list[Path]:
    """Write the single-run figures of :func:`run_figures` into ``out_dir`` (created if needed); return their
    paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    return [registry.resolve(fig.draw)(rec, out_dir / fig.file) for fig in run_figures(rec)]
