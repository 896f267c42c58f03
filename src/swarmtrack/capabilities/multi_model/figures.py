"""The multi-model distributed EKF's figures (W20 Figs. 4.4-4.11) from its per-UAV probes ``own_estimate`` (each
UAV's own model's posterior), ``detected``, ``winner`` (1-based UAV whose filter the output used), ``switches``
and, for the IMM kinds (and the IMM bank), ``probability``; and W20 Table 4.5 as a figure (the occlusion
policies compared)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from swarmtrack.analysis.figure_style import (
    MAX_LINES,
    PHASE_LINE,
    TARGET_COLOR,
    agent_color,
    figure_title,
    maybe_mark_phases,
    new_figure,
    place_legend,
    save_figure,
    time_axis,
    true_runs,
    whole_probe,
)
from swarmtrack.sim.recorder import Recording


def _model_names(rec: Recording) -> list[str]:
    """Upper-case model name of each UAV's filter (``estimator.models``), else ``"UAV i"``."""
    models = ((rec.meta or {}).get("estimator") or {}).get("models") or []
    return [str(models[i]).upper() if i < len(models) else f"UAV {i + 1}" for i in range(rec.n_agents)]



def _blind_intervals(rec: Recording) -> list[tuple[float, float]]:
    """``(t_start, t_end)`` of each run of steps where no UAV detected the target."""
    detected = whole_probe(rec, "detected")
    if detected is None:
        return []
    return true_runs(~(detected > 0).any(axis=1), np.asarray(rec.t, dtype=float), rec.dt)



def plot_w20_path(rec: Recording, path: str | Path, every: int = 3) -> Path:
    """W20 Figs. 4.4 / 4.7: the robot's path (green), each UAV's own-model estimate as dots (every ``every``-th
    step) and the fused output each UAV uses as a line."""
    n, names = rec.n_agents, _model_names(rec)
    shown = min(n, MAX_LINES)
    own = whole_probe(rec, "own_estimate")
    fig = new_figure((7.5, 6.5))
    ax = fig.subplots()
    ax.plot(rec.target[:, 0], rec.target[:, 1], color=TARGET_COLOR, lw=2.0, label="true target", zorder=4)
    for i in range(shown):
        c = agent_color(i)
        if own is not None:
            ax.plot(own[::every, i, 0], own[::every, i, 1], ls="none", marker=".", ms=2.5, color=c, alpha=0.5,
                    label=f"UAV {i + 1} own ({names[i]})", zorder=2)
        ax.plot(rec.estimate[:, i, 0], rec.estimate[:, i, 1], color=c, lw=0.9, alpha=0.9,
                label=f"UAV {i + 1} output", zorder=3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.5)
    place_legend(ax, 2 * shown + 1)
    ax.set_title(figure_title(rec, "Target path: own-model estimates (dots), fused outputs (lines)", shown, n, "UAVs"),
                 fontsize=10)
    return save_figure(fig, path)


def plot_w20_xy_time(rec: Recording, path: str | Path, every: int = 3) -> Path:
    """W20 Figs. 4.5 / 4.8: x and y over time; truth, own-model estimates (dots) and fused outputs (lines)."""
    n, names = rec.n_agents, _model_names(rec)
    shown = min(n, MAX_LINES)
    own = whole_probe(rec, "own_estimate")
    t = np.asarray(rec.t, dtype=float)
    fig = new_figure((10.0, 6.5))
    axes = fig.subplots(2, 1, sharex=True)
    for ax, col, comp in ((axes[0], 0, "x"), (axes[1], 1, "y")):
        ax.plot(t, rec.target[:, col], color=TARGET_COLOR, lw=2.0, label="true target", zorder=4)
        for i in range(shown):
            c = agent_color(i)
            if own is not None:
                ax.plot(t[::every], own[::every, i, col], ls="none", marker=".", ms=2.0, color=c, alpha=0.5,
                        label=f"UAV {i + 1} own ({names[i]})", zorder=2)
            ax.plot(t, rec.estimate[:, i, col], color=c, lw=0.9, alpha=0.9, label=f"UAV {i + 1} output", zorder=3)
        maybe_mark_phases(ax, rec)
        time_axis(ax, rec)
        ax.set_ylabel(f"{comp} [m]")
    axes[0].set_xlabel("")
    place_legend(axes[0], 2 * shown + 1, outside=True)
    fig.suptitle(figure_title(rec, "Target position over time: own-model estimates (dots), fused outputs (lines)",
                        shown, n, "UAVs"))
    return save_figure(fig, path)


def plot_model_selection(rec: Recording, path: str | Path) -> Path:
    """W20 Figs. 4.6 / 4.9: whose filter (by model) each UAV's output used over time, and the switch counts."""
    n, names = rec.n_agents, _model_names(rec)
    shown = min(n, MAX_LINES)
    winner = whole_probe(rec, "winner")
    switches = whole_probe(rec, "switches")
    # each UAV's cumulative count at its last sample that came (an absent sample is NaN; NaN: none came)
    last = None if switches is None or not len(switches) else np.fmax.reduce(switches, axis=0)
    t = np.asarray(rec.t, dtype=float)
    fig = new_figure((10.0, 1.2 + 1.4 * shown))
    axes = fig.subplots(shown, 1, sharex=True, squeeze=False)[:, 0]
    for i, ax in enumerate(axes):
        if winner is not None:
            w = np.where(winner[:, i] > 0, winner[:, i], np.nan)
            ax.step(t, w, where="post", color=agent_color(i), lw=1.0)
        ax.set_yticks(range(1, n + 1), [f"{names[j]} (UAV {j + 1})" for j in range(n)], fontsize=7)
        ax.set_ylim(0.5, n + 0.5)
        maybe_mark_phases(ax, rec)
        time_axis(ax, rec)
        count = "" if last is None or np.isnan(last[i]) else f": {int(last[i])} switches"
        ax.set_title(f"UAV {i + 1} ({names[i]}) output{count}", fontsize=8, loc="left")
        if ax is not axes[-1]:
            ax.set_xlabel("")
    total = "" if last is None or np.isnan(last).all() else \
        f"\nmean output-model switches per UAV: {float(np.nanmean(last)):.1f}"
    if winner is None:
        total += "\n(no winner probe recorded)"
    fig.suptitle(figure_title(rec, "Model whose estimate each UAV's output used", shown, n, "UAVs") + total,
                 fontsize=10)
    return save_figure(fig, path)


def plot_model_probabilities(rec: Recording, path: str | Path) -> Path:
    """W20 Fig. 4.11: each UAV's IMM model probabilities over time (the ``probability`` probe)."""
    n, names = rec.n_agents, _model_names(rec)
    shown = min(n, MAX_LINES)
    prob = whole_probe(rec, "probability")
    fig = new_figure((10.0, 1.2 + 1.6 * shown))
    axes = fig.subplots(shown, 1, sharex=True, squeeze=False)[:, 0]
    for i, ax in enumerate(axes):
        if prob is not None:
            for j in range(prob.shape[2]):
                ax.plot(rec.t, prob[:, i, j], color=agent_color(j), lw=0.9, label=names[j] if j < n else str(j))
        else:
            ax.text(0.5, 0.5, "no probability probe: not an IMM run", transform=ax.transAxes, ha="center")
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel("probability")
        ax.set_title(f"UAV {i + 1}", fontsize=8, loc="left")
        maybe_mark_phases(ax, rec)
        time_axis(ax, rec)
        if ax is not axes[-1]:
            ax.set_xlabel("")
    if prob is not None:
        place_legend(axes[0], prob.shape[2], outside=True)
    fig.suptitle(figure_title(rec, "IMM model probabilities", shown, n, "UAVs"))
    return save_figure(fig, path)


def plot_covariance_trace(rec: Recording, path: str | Path) -> Path:
    """W20 Fig. 4.10: trace of the position covariance over time per UAV: of each UAV's own filter when an
    ``own_covariance`` probe was recorded, else of the output each UAV uses (the title says which)."""
    n, names = rec.n_agents, _model_names(rec)
    shown = min(n, MAX_LINES)
    own = whole_probe(rec, "own_covariance")
    cov = own[..., :4, :4] if own is not None else rec.covariance
    trace = cov[..., 0, 0] + cov[..., 1, 1]
    fig = new_figure((9.0, 4.8))
    ax = fig.subplots()
    for i in range(shown):
        label = f"UAV {i + 1} ({names[i]} filter)" if own is not None else f"UAV {i + 1} output"
        ax.plot(rec.t, trace[:, i], color=agent_color(i), lw=0.9, label=label)
    ax.set_yscale("log")
    maybe_mark_phases(ax, rec)
    time_axis(ax, rec)
    ax.set_ylabel(r"tr $P_{pos}$ [m$^2$]")
    place_legend(ax, shown, outside=True)
    what = ("Position covariance trace of each UAV's own filter" if own is not None else
            "Position covariance trace of each UAV's fused output\n(no per-UAV own-filter covariance is recorded)")
    ax.set_title(figure_title(rec, what, shown, n, "UAVs"), fontsize=10)
    return save_figure(fig, path)


def plot_occlusion_errors(results: Mapping[str, Recording], path: str | Path) -> Path:
    """W20 Table 4.5 as a figure: each policy's position error (mean over UAVs) over time on one axes, the
    intervals where no UAV detected the target shaded (those of the first recording)."""
    if not results:
        raise ValueError("plot_occlusion_errors needs at least one recording")
    names = list(results)
    first = results[names[0]]
    fig = new_figure((10.0, 4.8))
    ax = fig.subplots()
    blind = _blind_intervals(first)
    for n, (t0, t1) in enumerate(blind):
        ax.axvspan(t0, t1, color="0.85", lw=0, zorder=0, label="no UAV detects the target" if n == 0 else None)
    for k, name in enumerate(names):
        rec = results[name]
        err = np.hypot(rec.estimate[..., 0] - rec.target[:, None, 0], rec.estimate[..., 1] - rec.target[:, None, 1])
        ax.plot(rec.t, err.mean(axis=1), color=agent_color(k), lw=1.0, label=name, zorder=3)
    cs = first.chase_start
    if len(first.t) and first.t[0] < cs <= first.t[-1]:
        ax.axvline(cs, color=PHASE_LINE, lw=0.8, ls=":", zorder=1)
    time_axis(ax, first)
    ax.set_yscale("log")
    ax.set_ylabel("position error, mean over UAVs [m]")
    place_legend(ax, len(names) + 1, outside=True)
    same = all(_blind_intervals(results[n]) == blind for n in names[1:])
    note = "" if same else f"\n(shaded: {names[0]}'s occlusions; the others' differ)"
    ax.set_title(figure_title(first, "Position error by occlusion policy", None, None) + note, fontsize=10)
    return save_figure(fig, path)

