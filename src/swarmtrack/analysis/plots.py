"""Figures of one run (L24 Figs. 2-7) and of flocking-protocol comparisons (L23 Fig. 1).

Every ``plot_*`` function takes a :class:`~swarmtrack.sim.recorder.Recording`, writes one PNG and returns its
:class:`~pathlib.Path`. Figures are built on :class:`matplotlib.figure.Figure` with an Agg canvas, so nothing
here touches pyplot's global state or needs a display.

To keep files readable, at most :data:`MAX_LINES` agents (or agent pairs) are drawn per panel; the title says
so when lines were left out. For pairs, the min-max envelope over *all* pairs is still shaded in grey.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from swarmtrack.analysis import health, metrics
from swarmtrack.outputs import partial_files
from swarmtrack.sim.recorder import Recording

__all__ = [
    "MAX_LINES",
    "DPI",
    "TARGET_COLOR",
    "agent_color",
    "pair_labels",
    "plot_band",
    "plot_estimates",
    "plot_trajectories",
    "plot_target_distances",
    "plot_inter_agent_distances",
    "plot_errors",
    "plot_flocking_comparison",
    "save_run_figures",
]

MAX_LINES = 10
"""Most agents / pairs drawn as individual lines in one panel."""
DPI = 120
TARGET_COLOR = "tab:green"
# tab10 without its green (reserved for the true target), then navy: 10 distinct colours. Black is kept
# for reference lines (d, r_comm, phase markers).
_AGENT_COLORS = (
    "tab:blue", "tab:orange", "tab:red", "tab:purple", "tab:brown",
    "tab:pink", "tab:gray", "tab:olive", "tab:cyan", "navy",
)
_PHASE_SHADE = "0.93"
_PHASE_LINE = "0.45"


# --------------------------------------------------------------------------------------------- helpers
def agent_color(i: int) -> str:
    """Colour of agent ``i`` (0-based); green is never used (the true target's colour)."""
    return _AGENT_COLORS[i % len(_AGENT_COLORS)]


def pair_labels(n: int) -> list[str]:
    """1-based labels ``"i-j"`` of the pairs in the order of :func:`~swarmtrack.analysis.metrics.pair_distances`."""
    i, j = np.triu_indices(n, k=1)
    return [f"{a + 1}-{b + 1}" for a, b in zip(i.tolist(), j.tolist(), strict=True)]


def _new_figure(figsize: tuple[float, float]) -> Figure:
    fig = Figure(figsize=figsize, dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Figure, path: str | Path) -> Path:
    path = Path(path)
    with partial_files([path]) as (partial,):  # an interrupted save leaves no half-written figure
        fig.savefig(partial, dpi=DPI, format="png")
    fig.clear()  # Figure objects are not registered with pyplot: clearing + dropping the reference closes it
    return path


def _context(rec: Recording) -> str:
    """``"scenario: x, model: CT"`` from ``rec.meta`` (empty if neither is present)."""
    meta = rec.meta or {}
    parts = []
    if meta.get("scenario"):
        parts.append(f"scenario: {meta['scenario']}")
    if meta.get("model"):
        parts.append(f"model: {str(meta['model']).upper()}")
    return ", ".join(parts)


def _title(
    rec: Recording, what: str, shown: int | None = None, total: int | None = None, unit: str = ""
) -> str:
    title = what
    ctx = _context(rec)
    if ctx:
        title += f" ({ctx})"
    if shown is not None and total is not None and shown < total:
        title += f"\nshowing the first {shown} of {total} {unit}"
    return title


def _phase_segments(rec: Recording) -> list[tuple[float, float, str]]:
    """``(t_start, t_end, name)`` of each run of equal consecutive ``phase`` values."""
    t = np.asarray(rec.t, dtype=float)
    phase = np.asarray(rec.phase)
    if t.size == 0:
        return []
    starts = np.concatenate(([0], np.flatnonzero(np.diff(phase) != 0) + 1))
    ends = np.concatenate((starts[1:], [t.size]))
    segments = []
    for s, e in zip(starts.tolist(), ends.tolist(), strict=True):
        k = int(phase[s])
        name = rec.phase_names[k] if 0 <= k < len(rec.phase_names) else f"phase {k}"
        t_end = float(t[e]) if e < t.size else float(t[-1])
        segments.append((float(t[s]), t_end, name))
    return segments


def _mark_phases(ax: Axes, rec: Recording) -> None:
    """Shade every other phase, draw a vertical line at each phase change and write the phase names."""
    segments = _phase_segments(rec)
    for n, (t0, t1, name) in enumerate(segments):
        if n % 2 == 1:
            ax.axvspan(t0, t1, color=_PHASE_SHADE, zorder=0, lw=0)
        if n > 0:
            ax.axvline(t0, color=_PHASE_LINE, lw=0.8, ls="-", zorder=1)
        ax.text(
            t0, 0.98, f" {name}", transform=ax.get_xaxis_transform(), rotation=90, va="top", ha="left",
            fontsize=7, color="0.3", zorder=5, clip_on=True,
        )
    cs = float(rec.chase_start)
    t = np.asarray(rec.t, dtype=float)
    if t.size and t[0] < cs <= t[-1]:
        # only when the chase start is not already a phase boundary
        dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
        if all(abs(cs - t0) > dt for t0, _, _ in segments):
            ax.axvline(cs, color=_PHASE_LINE, lw=0.8, ls=":", zorder=1)
            ax.text(cs, 0.02, " chase", transform=ax.get_xaxis_transform(), rotation=90, va="bottom",
                    ha="left", fontsize=7, color="0.3", zorder=5)


def _mark_phases_on_path(ax: Axes, rec: Recording) -> None:
    """On a y-vs-x plot: a black marker and the phase name where the target enters each phase."""
    phase = np.asarray(rec.phase)
    if phase.size == 0:
        return
    starts = np.concatenate(([0], np.flatnonzero(np.diff(phase) != 0) + 1))
    for s in starts.tolist():
        k = int(phase[s])
        name = rec.phase_names[k] if 0 <= k < len(rec.phase_names) else f"phase {k}"
        x, y = rec.target[s, 0], rec.target[s, 1]
        ax.plot([x], [y], marker="o", ms=4, color="black", zorder=6, ls="none")
        ax.annotate(name, (x, y), xytext=(4, 4), textcoords="offset points", fontsize=7, color="0.2")


def _time_axis(ax: Axes, rec: Recording) -> None:
    ax.set_xlabel("t [s]")
    if len(rec.t):
        ax.set_xlim(float(rec.t[0]), float(rec.t[-1]))
    ax.grid(True, lw=0.4, alpha=0.5)


def _legend(ax: Axes, n_entries: int, outside: bool = False) -> None:
    """Outside on the right (kept in the figure by the constrained layout) when asked or for many entries,
    else inside where it hides least."""
    if outside or n_entries > 6:
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    else:
        ax.legend(fontsize=7, loc="best", framealpha=0.8)


def plot_band(ax: Axes, t, mean, std, label: str, color=None, alpha: float = 0.25) -> Line2D:
    """Draw ``mean`` as a line and ``mean +- std`` as a shaded band on ``ax``; return the line."""
    t = np.asarray(t, dtype=float)
    mean = np.asarray(mean, dtype=float)
    std = np.asarray(std, dtype=float)
    (line,) = ax.plot(t, mean, label=label, color=color, lw=1.3)
    ax.fill_between(t, mean - std, mean + std, color=line.get_color(), alpha=alpha, lw=0)
    return line


# --------------------------------------------------------------------------------------------- figures
def plot_estimates(rec: Recording, path: str | Path) -> Path:
    """L24 Figs. 2-4: x-velocity, y-velocity and trajectory; true target in green, each UAV's estimate."""
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    fig = _new_figure((15.0, 4.8))
    axes = fig.subplots(1, 3)
    t = rec.t
    for ax, col, comp in ((axes[0], 2, "x"), (axes[1], 3, "y")):
        ax.plot(t, rec.target[:, col], color=TARGET_COLOR, lw=2.0, label="true target", zorder=4)
        for i in range(shown):
            ax.plot(t, rec.estimate[:, i, col], color=agent_color(i), lw=0.9, alpha=0.85,
                    label=f"UAV {i + 1} estimate", zorder=3)
        _mark_phases(ax, rec)
        _time_axis(ax, rec)
        ax.set_ylabel(f"$v_{comp}$ [m/s]")
        ax.set_title(f"target {comp}-velocity")
    ax = axes[2]
    ax.plot(rec.target[:, 0], rec.target[:, 1], color=TARGET_COLOR, lw=2.0, label="true target", zorder=4)
    for i in range(shown):
        ax.plot(rec.estimate[:, i, 0], rec.estimate[:, i, 1], color=agent_color(i), lw=0.9, alpha=0.85,
                label=f"UAV {i + 1} estimate", zorder=3)
    _mark_phases_on_path(ax, rec)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("target trajectory")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.5)
    _legend(ax, shown + 1)
    fig.suptitle(_title(rec, "Estimated and true target state", shown, n, "UAVs"))
    return _save(fig, path)


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
    fig = _new_figure((7.5, 6.5))
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
    _legend(ax, len(agents) + 1)
    shown = len(agents) if agent is None else None
    title = _title(rec, what, shown, n, "agents") + "\n(o start, \u25a1 end)"
    ax.set_title(title, fontsize=10)
    return _save(fig, path)


def plot_target_distances(rec: Recording, path: str | Path) -> Path:
    """L24 Fig. 6: ``||q_i - q_t||`` per UAV vs time."""
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    dist = metrics.target_distances(rec)
    fig = _new_figure((9.0, 4.8))
    ax = fig.subplots()
    for i in range(shown):
        ax.plot(rec.t, dist[:, i], color=agent_color(i), lw=1.0, label=f"UAV {i + 1}")
    _mark_phases(ax, rec)
    _time_axis(ax, rec)
    ax.set_ylabel(r"$\|q_i - q_t\|$ [m]")
    ax.set_ylim(bottom=0.0)
    _legend(ax, shown, outside=True)
    ax.set_title(_title(rec, "Relative distance between target and UAVs", shown, n, "UAVs"), fontsize=10)
    return _save(fig, path)


def _draw_pair_distances(ax: Axes, rec: Recording, legend: bool = True) -> tuple[int, int]:
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
    _time_axis(ax, rec)
    ax.set_ylabel("inter-agent distance [m]")
    ax.set_ylim(bottom=0.0)
    if legend:
        _legend(ax, shown + 2, outside=True)
    return shown, total


def plot_inter_agent_distances(rec: Recording, path: str | Path) -> Path:
    """L24 Fig. 7 / L23 Fig. 1: each agent pair's distance vs time; ``d`` solid, ``r_comm`` dashed."""
    fig = _new_figure((9.0, 4.8))
    ax = fig.subplots()
    shown, total = _draw_pair_distances(ax, rec)
    _mark_phases(ax, rec)
    ax.set_title(_title(rec, "Inter-agent distances and communication range", shown, total, "pairs"),
                 fontsize=10)
    return _save(fig, path)


def plot_errors(rec: Recording, path: str | Path) -> Path:
    """Estimation error norms per UAV vs time: ``||q_hat_i - q_t||`` [m] and ``||p_hat_i - p_t||`` [m/s]."""
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    err = metrics.errors(rec)
    pos_err = np.linalg.norm(err[:, :, :2], axis=-1)
    vel_err = np.linalg.norm(err[:, :, 2:4], axis=-1)
    fig = _new_figure((9.0, 6.5))
    axes = fig.subplots(2, 1, sharex=True)
    panels = ((axes[0], pos_err, "position error [m]"), (axes[1], vel_err, "velocity error [m/s]"))
    for ax, e, ylabel in panels:
        for i in range(shown):
            ax.plot(rec.t, e[:, i], color=agent_color(i), lw=0.9, label=f"UAV {i + 1}")
        _mark_phases(ax, rec)
        _time_axis(ax, rec)
        ax.set_ylabel(ylabel)
        ax.set_ylim(bottom=0.0)
    axes[0].set_xlabel("")
    _legend(axes[0], shown, outside=True)
    fig.suptitle(_title(rec, "Target estimation error", shown, n, "UAVs"))
    return _save(fig, path)


def plot_flocking_comparison(results: Mapping[str, Recording], path: str | Path) -> Path:
    """L23 Fig. 1: inter-agent distances, one panel per variant (e.g. standard / integral / tailored)."""
    if not results:
        raise ValueError("plot_flocking_comparison needs at least one recording")
    names = list(results)
    fig = _new_figure((5.0 * len(names), 4.5))
    axes = fig.subplots(1, len(names), sharey=True, squeeze=False)[0]
    notes = []
    for ax, name in zip(axes, names, strict=True):
        rec = results[name]
        shown, total = _draw_pair_distances(ax, rec, legend=ax is axes[-1])
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
    return _save(fig, path)


RUN_FIGURES = (
    ("estimates.png", plot_estimates),
    ("trajectories.png", plot_trajectories),
    ("target_distances.png", plot_target_distances),
    ("inter_agent_distances.png", plot_inter_agent_distances),
    ("errors.png", plot_errors),
)


def save_run_figures(rec: Recording, out_dir: str | Path) -> list[Path]:
    """Write the single-run figures into ``out_dir`` (created if needed): :data:`RUN_FIGURES` for a run whose
    estimators follow one target (they draw its estimate), and the figures of the probes the run recorded
    (:data:`PROBE_FIGURES`); return their paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    follows = rec.tracked is not None and "estimate" in rec.meta["probes"]
    figures = [*(RUN_FIGURES if follows else ()), *((name, fn) for probe, name, fn in PROBE_FIGURES
                               if probe in rec.meta["probes"] and _FIGURE_APPLIES.get(fn, bool)(rec))]
    return [fn(rec, out_dir / name) for name, fn in figures]


# --------------------------------------------------------------------------------------------- W20 Ch. 4
# The multi-model distributed EKF's figures (W20 Figs. 4.4-4.11), from its per-UAV probes: ``own_estimate``
# (each UAV's own model's posterior), ``detected``, ``winner`` (1-based UAV whose filter the output used),
# ``switches`` and, for the IMM kinds, ``probability``.
_MAX_PHASE_MARKS = 15  # more phases (the evasive path's random segments) are not marked


def _probe(rec: Recording, name: str) -> np.ndarray | None:
    """One probe over the whole run, ``(K, N, *shape)``; None if the run did not record it."""
    if name not in (rec.meta or {}).get("probes", {}):
        return None
    parts = [c.probes[name] for c in rec.chunks()]
    return np.concatenate(parts) if parts else None


def _model_names(rec: Recording) -> list[str]:
    """Upper-case model name of each UAV's filter (``estimator.models``), else ``"UAV i"``."""
    models = ((rec.meta or {}).get("estimator") or {}).get("models") or []
    return [str(models[i]).upper() if i < len(models) else f"UAV {i + 1}" for i in range(rec.n_agents)]


def _maybe_phases(ax: Axes, rec: Recording) -> None:
    if len(_phase_segments(rec)) <= _MAX_PHASE_MARKS:
        _mark_phases(ax, rec)


def _blind_intervals(rec: Recording) -> list[tuple[float, float]]:
    """``(t_start, t_end)`` of each run of steps where no UAV detected the target."""
    detected = _probe(rec, "detected")
    if detected is None:
        return []
    return _runs(~(detected > 0).any(axis=1), np.asarray(rec.t, dtype=float), rec.dt)


def _runs(mask: np.ndarray, t: np.ndarray, dt: float) -> list[tuple[float, float]]:
    """``(t_start, t_end)`` of each run of True in ``mask`` (K,) over the steps ``t``; a run ends ``dt`` after its
    last step."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(float(t[s]), float(t[e - 1]) + dt) for s, e in zip(starts.tolist(), ends.tolist(), strict=True)]


def plot_w20_path(rec: Recording, path: str | Path, every: int = 3) -> Path:
    """W20 Figs. 4.4 / 4.7: the robot's path (green), each UAV's own-model estimate as dots (every ``every``-th
    step) and the fused output each UAV uses as a line."""
    n, names = rec.n_agents, _model_names(rec)
    shown = min(n, MAX_LINES)
    own = _probe(rec, "own_estimate")
    fig = _new_figure((7.5, 6.5))
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
    _legend(ax, 2 * shown + 1)
    ax.set_title(_title(rec, "Target path: own-model estimates (dots), fused outputs (lines)", shown, n, "UAVs"),
                 fontsize=10)
    return _save(fig, path)


def plot_w20_xy_time(rec: Recording, path: str | Path, every: int = 3) -> Path:
    """W20 Figs. 4.5 / 4.8: x and y over time; truth, own-model estimates (dots) and fused outputs (lines)."""
    n, names = rec.n_agents, _model_names(rec)
    shown = min(n, MAX_LINES)
    own = _probe(rec, "own_estimate")
    t = np.asarray(rec.t, dtype=float)
    fig = _new_figure((10.0, 6.5))
    axes = fig.subplots(2, 1, sharex=True)
    for ax, col, comp in ((axes[0], 0, "x"), (axes[1], 1, "y")):
        ax.plot(t, rec.target[:, col], color=TARGET_COLOR, lw=2.0, label="true target", zorder=4)
        for i in range(shown):
            c = agent_color(i)
            if own is not None:
                ax.plot(t[::every], own[::every, i, col], ls="none", marker=".", ms=2.0, color=c, alpha=0.5,
                        label=f"UAV {i + 1} own ({names[i]})", zorder=2)
            ax.plot(t, rec.estimate[:, i, col], color=c, lw=0.9, alpha=0.9, label=f"UAV {i + 1} output", zorder=3)
        _maybe_phases(ax, rec)
        _time_axis(ax, rec)
        ax.set_ylabel(f"{comp} [m]")
    axes[0].set_xlabel("")
    _legend(axes[0], 2 * shown + 1, outside=True)
    fig.suptitle(_title(rec, "Target position over time: own-model estimates (dots), fused outputs (lines)",
                        shown, n, "UAVs"))
    return _save(fig, path)


def plot_model_selection(rec: Recording, path: str | Path) -> Path:
    """W20 Figs. 4.6 / 4.9: whose filter (by model) each UAV's output used over time, and the switch counts."""
    n, names = rec.n_agents, _model_names(rec)
    shown = min(n, MAX_LINES)
    winner = _probe(rec, "winner")
    switches = _probe(rec, "switches")
    t = np.asarray(rec.t, dtype=float)
    fig = _new_figure((10.0, 1.2 + 1.4 * shown))
    axes = fig.subplots(shown, 1, sharex=True, squeeze=False)[:, 0]
    for i, ax in enumerate(axes):
        if winner is not None:
            w = np.where(winner[:, i] > 0, winner[:, i], np.nan)
            ax.step(t, w, where="post", color=agent_color(i), lw=1.0)
        ax.set_yticks(range(1, n + 1), [f"{names[j]} (UAV {j + 1})" for j in range(n)], fontsize=7)
        ax.set_ylim(0.5, n + 0.5)
        _maybe_phases(ax, rec)
        _time_axis(ax, rec)
        count = "" if switches is None or not len(switches) else f": {int(switches[-1, i])} switches"
        ax.set_title(f"UAV {i + 1} ({names[i]}) output{count}", fontsize=8, loc="left")
        if ax is not axes[-1]:
            ax.set_xlabel("")
    total = "" if switches is None or not len(switches) else \
        f"\nmean output-model switches per UAV: {float(switches[-1].mean()):.1f}"
    if winner is None:
        total += "\n(no winner probe recorded)"
    fig.suptitle(_title(rec, "Model whose estimate each UAV's output used", shown, n, "UAVs") + total,
                 fontsize=10)
    return _save(fig, path)


def plot_model_probabilities(rec: Recording, path: str | Path) -> Path:
    """W20 Fig. 4.11: each UAV's IMM model probabilities over time (the ``probability`` probe)."""
    n, names = rec.n_agents, _model_names(rec)
    shown = min(n, MAX_LINES)
    prob = _probe(rec, "probability")
    fig = _new_figure((10.0, 1.2 + 1.6 * shown))
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
        _maybe_phases(ax, rec)
        _time_axis(ax, rec)
        if ax is not axes[-1]:
            ax.set_xlabel("")
    if prob is not None:
        _legend(axes[0], prob.shape[2], outside=True)
    fig.suptitle(_title(rec, "IMM model probabilities", shown, n, "UAVs"))
    return _save(fig, path)


def plot_covariance_trace(rec: Recording, path: str | Path) -> Path:
    """W20 Fig. 4.10: trace of the position covariance over time per UAV: of each UAV's own filter when an
    ``own_covariance`` probe was recorded, else of the output each UAV uses (the title says which)."""
    n, names = rec.n_agents, _model_names(rec)
    shown = min(n, MAX_LINES)
    own = _probe(rec, "own_covariance")
    cov = own[..., :4, :4] if own is not None else rec.covariance
    trace = cov[..., 0, 0] + cov[..., 1, 1]
    fig = _new_figure((9.0, 4.8))
    ax = fig.subplots()
    for i in range(shown):
        label = f"UAV {i + 1} ({names[i]} filter)" if own is not None else f"UAV {i + 1} output"
        ax.plot(rec.t, trace[:, i], color=agent_color(i), lw=0.9, label=label)
    ax.set_yscale("log")
    _maybe_phases(ax, rec)
    _time_axis(ax, rec)
    ax.set_ylabel(r"tr $P_{pos}$ [m$^2$]")
    _legend(ax, shown, outside=True)
    what = ("Position covariance trace of each UAV's own filter" if own is not None else
            "Position covariance trace of each UAV's fused output\n(no per-UAV own-filter covariance is recorded)")
    ax.set_title(_title(rec, what, shown, n, "UAVs"), fontsize=10)
    return _save(fig, path)


def plot_occlusion_errors(results: Mapping[str, Recording], path: str | Path) -> Path:
    """W20 Table 4.5 as a figure: each policy's position error (mean over UAVs) over time on one axes, the
    intervals where no UAV detected the target shaded (those of the first recording)."""
    if not results:
        raise ValueError("plot_occlusion_errors needs at least one recording")
    names = list(results)
    first = results[names[0]]
    fig = _new_figure((10.0, 4.8))
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
        ax.axvline(cs, color=_PHASE_LINE, lw=0.8, ls=":", zorder=1)
    _time_axis(ax, first)
    ax.set_yscale("log")
    ax.set_ylabel("position error, mean over UAVs [m]")
    _legend(ax, len(names) + 1, outside=True)
    same = all(_blind_intervals(results[n]) == blind for n in names[1:])
    note = "" if same else f"\n(shaded: {names[0]}'s occlusions; the others' differ)"
    ax.set_title(_title(first, "Position error by occlusion policy", None, None) + note, fontsize=10)
    return _save(fig, path)


__all__ += ["plot_w20_path", "plot_w20_xy_time", "plot_model_selection", "plot_model_probabilities",
            "plot_covariance_trace", "plot_occlusion_errors"]


# --------------------------------------------------------------------------------------------- W20 Ch. 5
# The distributed MPC's formation-tracking figures (W20 Figs. 5.6-5.14), from the truth, the controller's spec in
# ``meta["controller"]`` (``offsets``: each UAV's slot r_r relative to the target, ``start``, ``r_s``, ``bound``) and
# its per-UAV probes ``setpoint`` (absolute), ``avoiding`` and the cumulative ``solves``, ``fallbacks``,
# ``solve_time``, ``iterations``. They stream the recording chunk by chunk and keep every ``every``-th step of the
# (K, N, 2) series (by default at most :data:`MAX_POINTS` per line); what a stride could hide is pooled over each
# stride instead: the minimum separation (its minimum), the avoidance count (its maximum).
MAX_POINTS = 5000
"""Points per line the W20 Ch. 5 figures keep by default (``every=None``)."""


def slot_distances(rec: Recording) -> np.ndarray:
    """(K, N) true distance of every UAV to its formation slot ``q_t + r_r`` (W20 Ch. 5's tracking error before
    it is averaged: :func:`~swarmtrack.analysis.metrics.summary`'s ``formation.tracking_error`` is its mean over
    the steps from the MPC's start on). Whole run in memory: for plots and tests of small runs."""
    offsets, _, _ = metrics.formation_spec(rec)
    parts = [np.linalg.norm(metrics.slot_offsets(rec, c.truth, offsets), axis=-1)
             for c in rec.chunks(probes_wanted=False)]
    return np.concatenate(parts) if parts else np.zeros((0, rec.n_agents))


def _min_separation(q: np.ndarray) -> np.ndarray:
    """(k,) smallest distance between any two of the N positions ``q`` (k, N, 2) at each step (inf for N < 2): all
    pairs, a block of steps at a time, up to :data:`~swarmtrack.analysis.metrics.ALL_PAIRS_UP_TO` UAVs, else each
    step's nearest neighbours from a KD-tree."""
    k, n = q.shape[:2]
    if n < 2:
        return np.full(k, np.inf)
    if n > metrics.ALL_PAIRS_UP_TO:
        from scipy.spatial import cKDTree

        return np.array([cKDTree(step).query(step, k=2)[0][:, 1].min() for step in q])
    block = max(1, (1 << 20) // (n * (n - 1) // 2))
    return np.concatenate([metrics._pairs_of(q[s:s + block]).min(axis=1) for s in range(0, k, block)])


def _cat(parts: list[np.ndarray], shape: tuple[int, ...]) -> np.ndarray:
    return np.concatenate(parts) if parts else np.zeros((0, *shape))


def _pool(x: np.ndarray, every: int, reduce) -> np.ndarray:
    """``reduce`` over each stride of ``every`` steps of ``x`` (K, ...): one value per kept step."""
    if every == 1 or not len(x):
        return x
    return reduce(x, np.arange(0, len(x), every), axis=0)


class _FormationSeries:
    """One streamed pass over an MPC recording: every ``every``-th step of ``t``, the target's and UAVs' true
    positions, each UAV's slot, its distance to it, its relative input; per step, pooled per stride, the
    minimum separation and the number of active avoidance terms; and each UAV's blind intervals.

    The relative input ``u = setpoint − p`` is taken against the UAV's true position at the last recorded step
    before the plan that set the setpoint (the step before ``solves`` went up): the plan's own position when plans
    fall on estimation steps (the built-in scenarios: T = 0.2 s, 10 Hz), up to one step's motion off otherwise; the
    plan itself used the UAV's navigation solution, so ``|u|`` can exceed the bound by the navigation noise."""

    def __init__(self, rec: Recording, every: int | None = None):
        n = rec.n_agents
        self.offsets, self.start, self.ctrl = metrics.formation_spec(rec)
        steps = int((rec.meta or {}).get("n_steps") or len(rec.t))
        self.every = every = max(1, int(every)) if every is not None else max(1, -(-steps // MAX_POINTS))
        keep_t, full_t, target, uav, dist, u, sep, avoiding, blind = [], [], [], [], [], [], [], [], []
        plan_pos, last_solves, last_pos = np.full((n, 2), np.nan), np.zeros(n), np.full((n, 2), np.nan)
        solver = None
        for c in rec.chunks():
            k = len(c.t)
            if not k:
                continue
            keep = (c.k0 + np.arange(k)) % every == 0
            q = c.truth[:, rec.uav_slice, :2]
            # input: position at the plan = the step before each rise of the cumulative solve count
            solves = c.probes["solves"] if "solves" in c.probes else np.zeros((k, n))
            prev_pos = np.concatenate((last_pos[None], q[:-1]))  # (k, N, 2): the step before each step
            rise = solves > np.concatenate((last_solves[None], solves[:-1]))  # (k, N)
            idx = np.maximum.accumulate(np.where(rise, np.arange(k)[:, None], -1), axis=0)  # last rise so far
            at_plan = np.where((idx >= 0)[..., None], prev_pos[np.maximum(idx, 0), np.arange(n)], plan_pos)
            plan_pos, last_solves, last_pos = at_plan[-1], solves[-1], q[-1]
            setpoint = c.probes["setpoint"] if "setpoint" in c.probes else np.full((k, n, 2), np.nan)
            keep_t.append(c.t[keep])
            full_t.append(c.t)
            target.append(c.truth[keep, rec.tracked, :2])
            uav.append(q[keep])
            dist.append(np.linalg.norm(metrics.slot_offsets(rec, c.truth[keep], self.offsets), axis=-1))
            u.append((setpoint - at_plan)[keep])
            sep.append(_min_separation(q))
            avoiding.append(c.probes["avoiding"] if "avoiding" in c.probes else np.zeros((k, n)))
            blind.append(c.probes["detected"] <= 0 if "detected" in c.probes else np.zeros((k, n), dtype=bool))
            solver = {name: c.probes[name][-1] for name in ("solves", "fallbacks", "solve_time") if name in c.probes}
        self.t, self.target, self.uav = _cat(keep_t, ()), _cat(target, (2,)), _cat(uav, (n, 2))
        self.slot = self.target[:, None, :] + self.offsets
        self.distance, self.u = _cat(dist, (n,)), _cat(u, (n, 2))
        self.separation = _pool(_cat(sep, ()), every, np.minimum.reduceat)
        self.avoiding = _pool(_cat(avoiding, (n,)), every, np.maximum.reduceat)
        full_t, blind = _cat(full_t, ()), _cat(blind, (n,))
        self.blind = [_runs(blind[:, i], full_t, rec.dt) for i in range(n)]
        self.solver = solver or {}
        self.i_start = int(np.searchsorted(self.t, self.start - 1e-9))  # first kept step of the MPC

    def started(self) -> bool:
        """Whether the MPC starts after the first step (else there is nothing to mark)."""
        return len(self.t) > 0 and self.t[0] < self.start <= self.t[-1]


def _mark_mpc_start(ax: Axes, s: _FormationSeries) -> None:
    if s.started():
        ax.axvline(s.start, color="black", lw=1.0, ls="--", zorder=2)
        ax.text(s.start, 0.02, " MPC start", transform=ax.get_xaxis_transform(), rotation=90, va="bottom",
                ha="left", fontsize=7, color="0.2", zorder=5)


def _shade_blind(ax: Axes, s: _FormationSeries, shown: int) -> int:
    """Shade each shown UAV's blind intervals (no detection) in its colour; return how many were shaded."""
    count = 0
    for i in range(shown):
        for n, (t0, t1) in enumerate(s.blind[i]):
            ax.axvspan(t0, t1, color=agent_color(i), alpha=0.15, lw=0, zorder=0.5,  # over the phase shading
                       label=f"UAV {i + 1} blind (no detection)" if n == 0 else None)
            count += n == 0
    return count


def plot_formation_paths(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """W20 Figs. 5.6, 5.10, 5.11, 5.13: the target's and every UAV's path in the plane, each UAV's slot (target +
    offset) dashed in its colour; o start, □ end, × each slot at the end, ◆ where the MPC starts; a UAV's blind
    stretches (no detection, e.g. W20 Sec. 5.4.4.3's occlusions) drawn thick and pale under its path."""
    s = _FormationSeries(rec, every)
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    fig = _new_figure((8.0, 7.0))
    ax = fig.subplots()
    # the target under the UAVs: a UAV whose slot is the target itself stays visible
    ax.plot(s.target[:, 0], s.target[:, 1], color=TARGET_COLOR, lw=2.0, label="target", zorder=2.5)
    paths = [(s.target, TARGET_COLOR)]
    blind_shown = False
    for i in range(shown):
        c = agent_color(i)
        ax.plot(s.uav[:, i, 0], s.uav[:, i, 1], color=c, lw=1.1, label=f"UAV {i + 1}", zorder=3)
        ax.plot(s.slot[:, i, 0], s.slot[:, i, 1], color=c, lw=0.9, ls="--", alpha=0.8,
                label=f"UAV {i + 1} slot {tuple(float(v) for v in s.offsets[i])}", zorder=2)
        for t0, t1 in s.blind[i]:
            stretch = (s.t >= t0 - 1e-9) & (s.t < t1 - 1e-9)
            ax.plot(s.uav[stretch, i, 0], s.uav[stretch, i, 1], color=c, lw=7, alpha=0.25, solid_capstyle="round",
                    zorder=1, label=None if blind_shown else "blind (no detection)")
            blind_shown = True
        paths.append((s.uav[:, i], c))
        if len(s.t):  # the slot at the end: visible also when the target rests (a slot path of one point)
            ax.plot(s.slot[-1, i, 0], s.slot[-1, i, 1], marker="x", color=c, ms=8, mew=1.8, ls="none", zorder=6)
    if len(s.t):
        for xy, c in paths:
            ax.plot(xy[0, 0], xy[0, 1], marker="o", color=c, ms=5, ls="none", zorder=5)
            ax.plot(xy[-1, 0], xy[-1, 1], marker="s", color=c, ms=5, ls="none", zorder=5)
            if s.started():
                ax.plot(xy[s.i_start, 0], xy[s.i_start, 1], marker="D", color=c, mec="black", ms=6, ls="none",
                        zorder=6)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.5)
    _legend(ax, 2 * shown + 1 + blind_shown)
    marks = "o start, \u25a1 end, \u00d7 slot at the end"
    if s.started():
        marks += f", \u25c6 MPC start (t = {s.start:g} s)"
    ax.set_title(_title(rec, "Formation tracking paths", shown, n, "UAVs")
                 + f"\nsolid: UAVs, dashed: their slots (target + offset)\n{marks}", fontsize=10)
    return _save(fig, path)


def plot_formation_xy_time(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """W20 Figs. 5.9, 5.12, 5.14: x(t) and y(t) of every UAV (solid) and of its slot (dashed, same colour), the
    target in green; the MPC's start a dashed vertical line, the target's phases marked."""
    s = _FormationSeries(rec, every)
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    fig = _new_figure((10.0, 6.5))
    axes = fig.subplots(2, 1, sharex=True)
    for ax, col, comp in ((axes[0], 0, "x"), (axes[1], 1, "y")):
        ax.plot(s.t, s.target[:, col], color=TARGET_COLOR, lw=1.6, label="target", zorder=2.5)
        for i in range(shown):
            c = agent_color(i)
            ax.plot(s.t, s.uav[:, i, col], color=c, lw=1.1, label=f"UAV {i + 1}", zorder=3)
            ax.plot(s.t, s.slot[:, i, col], color=c, lw=0.9, ls="--", alpha=0.8, label=f"UAV {i + 1} slot",
                    zorder=3)
        _maybe_phases(ax, rec)
        _mark_mpc_start(ax, s)
        _time_axis(ax, rec)
        ax.set_ylabel(f"{comp} [m]")
    axes[0].set_xlabel("")
    _legend(axes[0], 2 * shown + 1, outside=True)
    fig.suptitle(_title(rec, "UAV positions (solid) and their formation slots (dashed) over time", shown, n,
                        "UAVs"))
    return _save(fig, path)


def plot_slot_distance(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """Each UAV's true distance to its slot over time (:func:`slot_distances`; its mean from the MPC's start on,
    W20 Tables 5.6-5.12's tracking error, in the legend); the MPC's start marked, blind intervals shaded."""
    s = _FormationSeries(rec, every)
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    fig = _new_figure((10.0, 4.8))
    ax = fig.subplots()
    after = s.t >= s.start - 1e-9
    for i in range(shown):
        mean = f", mean {s.distance[after, i].mean():.2f} m from the start" if after.any() else ""
        ax.plot(s.t, s.distance[:, i], color=agent_color(i), lw=1.0, label=f"UAV {i + 1}{mean}", zorder=3)
    blind = _shade_blind(ax, s, shown)
    _maybe_phases(ax, rec)
    _mark_mpc_start(ax, s)
    _time_axis(ax, rec)
    ax.set_ylabel(r"$\|q_i - (q_t + r_{r,i})\|$ [m]")
    ax.set_ylim(bottom=0.0)
    _legend(ax, shown + blind, outside=True)
    note = "" if s.every == 1 else f"\n(every {s.every}th step drawn; means over those)"
    ax.set_title(_title(rec, "Distance of each UAV to its formation slot", shown, n, "UAVs") + note, fontsize=10)
    return _save(fig, path)


def plot_mpc_inputs(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """W20 Fig. 5.7 (top): each UAV's relative input ``u = setpoint − p`` per axis over time with the bounds
    ``±bound`` (see :class:`_FormationSeries` for the position taken), and below, the number of active
    collision-avoidance terms (neighbours closer than r_s when the plan was made; maximum per drawn step)."""
    s = _FormationSeries(rec, every)
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    bound = s.ctrl.get("bound")
    fig = _new_figure((10.0, 7.5))
    axes = fig.subplots(3, 1, sharex=True, height_ratios=(3, 3, 1.4))
    for ax, col, comp in ((axes[0], 0, "x"), (axes[1], 1, "y")):
        for i in range(shown):
            ax.step(s.t, s.u[:, i, col], where="post", color=agent_color(i), lw=0.9, label=f"UAV {i + 1}", zorder=3)
        if bound is not None:
            for sign in (1, -1):
                ax.axhline(sign * float(bound), color="black", lw=1.0, ls="--", zorder=2,
                           label=f"\u00b1bound = {float(bound):g} m" if sign > 0 else None)
        ax.set_ylabel(f"$u_{comp}$ [m]")
    ax = axes[2]
    for i in range(shown):
        ax.step(s.t, s.avoiding[:, i], where="post", color=agent_color(i), lw=0.9, label=f"UAV {i + 1}")
    top = int(np.nanmax(s.avoiding[:, :shown])) if s.avoiding.size else 0
    ax.set_yticks(range(0, max(top, 1) + 1))
    ax.set_ylim(-0.2, max(top, 1) + 0.2)
    ax.set_ylabel("avoiding", fontsize=8)
    for ax in axes:
        _maybe_phases(ax, rec)
        _mark_mpc_start(ax, s)
        _time_axis(ax, rec)
        if ax is not axes[-1]:
            ax.set_xlabel("")
    _legend(axes[0], shown + 1, outside=True)
    stats = ""
    if "solves" in s.solver:
        solves = s.solver["solves"]
        mean_us = 1e6 * float(s.solver.get("solve_time", np.zeros(1)).sum()) / max(float(solves.sum()), 1.0)
        fallbacks = int(s.solver.get("fallbacks", np.zeros(1)).sum())
        stats = (f"\n{int(solves.sum())} plans solved, {fallbacks} fallbacks, mean solve {mean_us:.0f} \u00b5s; "
                 "bottom: active avoidance terms")
    fig.suptitle(_title(rec, "MPC inputs: setpoint relative to the UAV's position at the plan", shown, n, "UAVs")
                 + stats)
    return _save(fig, path)


def plot_min_separation(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """W20 Sec. 5.4.3 (Table 5.9's test): the smallest true distance between any two UAVs over time (the minimum
    over each drawn stride, so no close pass is hidden), ``r_s`` dashed and the collision distance
    :data:`~swarmtrack.analysis.metrics.COLLISION_M` dotted; the closest approach annotated."""
    s = _FormationSeries(rec, every)
    fig = _new_figure((9.0, 4.5))
    ax = fig.subplots()
    r_s = s.ctrl.get("r_s")
    if rec.n_agents < 2 or not len(s.t):
        ax.text(0.5, 0.5, "fewer than 2 UAVs: no separation", transform=ax.transAxes, ha="center", va="center")
    else:
        ax.plot(s.t, s.separation, color="black", lw=1.2, label="minimum inter-UAV distance", zorder=3)
        k = int(np.argmin(s.separation))
        ax.plot(s.t[k], s.separation[k], marker="o", color="tab:red", ms=5, ls="none", zorder=5)
        ax.annotate(f"{s.separation[k]:.2f} m at t = {s.t[k]:.1f} s", (s.t[k], s.separation[k]), xytext=(6, -12),
                    textcoords="offset points", fontsize=8, color="tab:red")
        if r_s is not None:
            ax.axhline(float(r_s), color=agent_color(0), lw=1.0, ls="--", label=f"$r_s$ = {float(r_s):g} m", zorder=2)
        ax.axhline(metrics.COLLISION_M, color="tab:red", lw=1.0, ls=":", label=f"collision ({metrics.COLLISION_M:g} m)",
                   zorder=2)
        _legend(ax, 3)
    _maybe_phases(ax, rec)
    _mark_mpc_start(ax, s)
    _time_axis(ax, rec)
    ax.set_ylabel("min inter-UAV distance [m]")
    ax.set_ylim(bottom=0.0)
    ax.set_title(_title(rec, "Minimum separation between UAVs"), fontsize=10)
    return _save(fig, path)


# --------------------------------------------------------------------------------------------- IB21
# Guaranteed search and track (IB21 Figs. 8-11): from the set-membership estimator's probes ``phi`` (Φ_i, eq. 10)
# and its parts ``phi_unexplored``, ``phi_unidentified``, ``phi_identified``, the truth-side monitor
# ``guarantee_violations``, the alarms, and the truth of the ``targets``, ``decoys`` and ``uavs`` groups. One
# streamed pass keeps every ``every``-th step (by default at most :data:`MAX_POINTS` per line): Φ changes only at
# the set updates (every sharing period and at identification frames), so a stride hides nothing a line could show;
# the guarantee and alarm counts are taken over every step (:class:`~swarmtrack.analysis.health.SetHealth`).
PHI_LABELS = {"phi_bar": r"$\bar\Phi$ (eq. 11)", "phi_unexplored": r"$\varphi(\bar X)$ unexplored",
              "phi_unidentified": r"$\varphi(X^U)$ unidentified", "phi_identified": r"$\varphi(X)$ identified",
              "solve_time": "fleet MPC solve time per plan [s]"}
"""Legend labels of the IB21 time series (:func:`plot_uncertainty`, :func:`plot_phi_bands`)."""
_PART_COLORS = {"phi_unexplored": "tab:blue", "phi_unidentified": "tab:orange", "phi_identified": "tab:red"}
DECOY_COLOR = "0.35"
_QUANTITY_STYLES = ("-", "--", ":", "-.")


class _SetSeries:
    """One streamed pass over a set-membership recording: every ``every``-th step of ``t``, each UAV's Φ_i
    ``phi`` (K', N), the parts' means over the UAVs ``parts`` (name → (K',)), the true positions of every group
    ``paths`` (name → (K', members, 2)), the first t at which the mean of φ(X̄) is 0 (``cleared``) and the
    guarantee and alarm counts (``health``)."""

    def __init__(self, rec: Recording, every: int | None = None):
        steps = int((rec.meta or {}).get("n_steps") or 0)
        self.every = every = max(1, int(every)) if every is not None else max(1, -(-steps // MAX_POINTS))
        self.health = health.SetHealth(rec)
        groups = {name: slice(*span) for name, span in rec.meta["groups"].items() if span[1] > span[0]}
        t, phi, parts, paths = [], [], {q: [] for q in metrics.PHI_PARTS.values()}, {g: [] for g in groups}
        self.cleared = None
        for c in rec.chunks():
            self.health.add(c)
            if not len(c.t):
                continue
            keep = (c.k0 + np.arange(len(c.t))) % every == 0
            t.append(c.t[keep])
            phi.append(c.probes["phi"][keep])
            for q in parts:
                parts[q].append(c.probes[q][keep].mean(axis=1))
            for g, sl in groups.items():
                paths[g].append(c.truth[keep, sl, :2])
            if self.cleared is None:
                clear = np.flatnonzero(c.probes["phi_unexplored"].mean(axis=1) == 0)
                self.cleared = float(c.t[clear[0]]) if len(clear) else None
        n = rec.n_agents
        self.t, self.phi = _cat(t, ()), _cat(phi, (n,))
        self.parts = {q: _cat(v, ()) for q, v in parts.items()}
        self.paths = {g: _cat(v, (groups[g].stop - groups[g].start, 2)) for g, v in paths.items()}
        box = ((rec.meta or {}).get("estimator") or {}).get("area")
        self.area = None if box is None else tuple(float(v) for v in box)

    def note(self) -> str:
        """The guarantee and alarm counts, for a title."""
        c = self.health.counts()
        violations = "not monitored" if c["guarantee_violations"] is None else str(c["guarantee_violations"])
        return (f"guarantee violations: {violations}; UAVs whose sets all emptied: {c['empty_set_alarms']}"
                + ("" if self.every == 1 else f"; every {self.every}th step drawn"))


def _mark_set_events(ax: Axes, s: _SetSeries) -> None:
    """Dotted verticals where X̄ cleared (mean over the UAVs 0), the first guarantee violation and each first
    all-empty alarm."""
    counts = s.health.counts()
    marks = [(s.cleared, "tab:blue", r"$\bar X$ cleared"), (counts["first_violation_t"], "tab:red", "violation")]
    marks += [(t, "black", f"UAV {i + 1} empty") for i, t in enumerate(counts["empty_set_alarm_t"][:MAX_LINES])]
    for t, color, text in marks:
        if t is not None:
            ax.axvline(t, color=color, lw=0.9, ls=":", zorder=2)
            ax.text(t, 0.98, f" {text}", transform=ax.get_xaxis_transform(), rotation=90, va="top", ha="left",
                    fontsize=7, color=color, zorder=5)


def _set_time_axis(ax: Axes, s: _SetSeries) -> None:
    ax.set_xlabel("t [s]")
    if len(s.t):
        ax.set_xlim(float(s.t[0]), float(s.t[-1]))
    ax.set_ylim(bottom=0.0)
    ax.grid(True, lw=0.4, alpha=0.5)


def plot_uncertainty(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """IB21 Fig. 8 right / Fig. 10 right for one run: Φ̄ (eq. 11, the mean over the UAVs of Φ_i, eq. 10) and its
    parts φ(X̄) (unexplored), φ(Xᵁ) (unidentified) and φ(X) (identified), each the mean over the UAVs, in m²;
    where X̄ cleared, the first guarantee violation and the all-empty alarms are marked."""
    s = _SetSeries(rec, every)
    fig = _new_figure((9.0, 4.8))
    ax = fig.subplots()
    bar = s.phi.mean(axis=1) if len(s.t) else np.zeros(0)
    ax.plot(s.t, bar, color="black", lw=1.8, label=PHI_LABELS["phi_bar"], zorder=4)
    for q, values in s.parts.items():
        ax.plot(s.t, values, color=_PART_COLORS[q], lw=1.1, label=PHI_LABELS[q], zorder=3)
    _mark_set_events(ax, s)
    _set_time_axis(ax, s)
    ax.set_ylabel(r"area, mean over UAVs [m$^2$]")
    _legend(ax, 4)
    ax.set_title(_title(rec, "Uncertainty and its parts") + "\n" + s.note(), fontsize=10)
    return _save(fig, path)


def plot_uncertainty_per_uav(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """Each UAV's uncertainty Φ_i (IB21 eq. 10) over time, Φ̄ (their mean, eq. 11) dashed: how far apart the
    UAVs' beliefs are (they agree only where the links carried their sets)."""
    s = _SetSeries(rec, every)
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    fig = _new_figure((9.0, 4.8))
    ax = fig.subplots()
    for i in range(shown):
        ax.plot(s.t, s.phi[:, i], color=agent_color(i), lw=1.0, label=f"UAV {i + 1}", zorder=3)
    if len(s.t):
        ax.plot(s.t, s.phi.mean(axis=1), color="black", lw=1.4, ls="--", label=PHI_LABELS["phi_bar"], zorder=4)
    _mark_set_events(ax, s)
    _set_time_axis(ax, s)
    ax.set_ylabel(r"$\Phi_i$ [m$^2$]")
    _legend(ax, shown + 1, outside=True)
    ax.set_title(_title(rec, "Uncertainty of each UAV", shown, n, "UAVs") + "\n" + s.note(), fontsize=10)
    return _save(fig, path)


def plot_search_map(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """The search area X0 with every UAV's true path and the true paths of the targets (green) and decoys (grey,
    dashed); o start, □ end. No sets are drawn (they exist only onboard, at each instant: see the animation)."""
    s = _SetSeries(rec, every)
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    fig = _new_figure((7.5, 7.0))
    ax = fig.subplots()
    if s.area is not None:
        x0, y0, x1, y1 = s.area
        ax.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], color="black", lw=1.0, label=r"area $X_0$", zorder=1)
    drawn = []
    for group, color, ls, name in (("targets", TARGET_COLOR, "-", "target"), ("decoys", DECOY_COLOR, "--", "decoy")):
        xy = s.paths.get(group)
        for j in range(0 if xy is None else xy.shape[1]):
            ax.plot(xy[:, j, 0], xy[:, j, 1], color=color, lw=1.8, ls=ls, zorder=4,
                    label=f"{name}s (true)" if j == 0 else None)
            drawn.append((xy[:, j], color))
    uavs = s.paths.get("uavs")
    for i in range(shown if uavs is not None else 0):
        ax.plot(uavs[:, i, 0], uavs[:, i, 1], color=agent_color(i), lw=0.8, alpha=0.85, label=f"UAV {i + 1}",
                zorder=3)
        drawn.append((uavs[:, i], agent_color(i)))
    for xy, color in drawn if len(s.t) else ():
        ax.plot(xy[0, 0], xy[0, 1], marker="o", color=color, ms=4, ls="none", zorder=5)
        ax.plot(xy[-1, 0], xy[-1, 1], marker="s", color=color, ms=4, ls="none", zorder=5)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.5)
    _legend(ax, shown + 3, outside=True)
    span = f"t = 0-{rec.t_last:g} s"
    ax.set_title(_title(rec, "Search map: true paths", shown, n, "UAVs") + f"\n{span} (o start, \u25a1 end)",
                 fontsize=10)
    return _save(fig, path)


def _run_series(run) -> Mapping:
    """A run's time series: of a :class:`Recording` (computed), of a summary (its ``series``) or the series."""
    if isinstance(run, Recording):
        return metrics.series(run)
    return run["series"] if "series" in run else run


def phi_bands(runs, quantity: str) -> dict | None:
    """Mean and ±1 std over ``runs`` (Recordings, summaries or their ``series``) of one time series per bin:
    :func:`swarmtrack.analysis.sweep.series_band`'s alignment (runs of different lengths, bins merged into the
    coarsest run's). None: no run recorded ``quantity``."""
    import pandas as pd

    from swarmtrack.analysis.sweep import series_band

    series = [_run_series(r) for r in runs]
    table = pd.DataFrame({"status": ["ok"] * len(series), "series.bin_s": [s["bin_s"] for s in series],
                          f"series.{quantity}": [s.get(quantity) for s in series]})
    return series_band(table, quantity)


def _draw_phi_bands(ax: Axes, results: Mapping[str, Sequence], quantities: Sequence[str]) -> int:
    """Per setting of ``results`` (label → runs) and quantity, the mean line and ±1 std band over the runs
    (:func:`phi_bands`, :func:`plot_band`) on ``ax``: one colour per setting, one line style per quantity. Returns
    the bands drawn (a setting whose runs recorded none of ``quantities`` draws none)."""
    entries = 0
    for k, (label, runs) in enumerate(results.items()):
        for j, q in enumerate(quantities):
            band = phi_bands(list(runs), q)
            if band is None:
                continue
            mean = np.array([np.nan if v is None else v for v in band["mean"]], dtype=float)
            std = np.array([np.nan if v is None else v for v in band["std"]], dtype=float)
            name = label if len(quantities) == 1 else f"{label}: {PHI_LABELS.get(q, q)}"
            line = plot_band(ax, band["t"], mean, std, f"{name} ({band['runs']} runs)", color=agent_color(k))
            line.set_linestyle(_QUANTITY_STYLES[j % len(_QUANTITY_STYLES)])
            entries += 1
    return entries


def _band_axes(ax: Axes, quantities: Sequence[str], entries: int) -> None:
    """Axis labels, grid and legend of a panel of bands (:func:`_draw_phi_bands`)."""
    ax.set_xlabel("t [s]")
    ax.set_ylabel(PHI_LABELS["solve_time"] if tuple(quantities) == ("solve_time",)
                  else r"area, mean over UAVs [m$^2$]")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, lw=0.4, alpha=0.5)
    if entries:
        _legend(ax, entries, outside=entries > 6)
    else:
        ax.text(0.5, 0.5, f"no run recorded {', '.join(quantities)}", transform=ax.transAxes, ha="center")


def plot_phi_bands(results: Mapping[str, Sequence], path: str | Path, quantities: Sequence[str] = ("phi_bar",),
                   title: str | None = None) -> Path:
    """IB21 Figs. 8-11: per setting (``results``: label → runs, each a :class:`Recording`, its summary or its
    ``series``) the mean line and a ±1 std band over the runs (:func:`plot_band`) of each quantity of
    :func:`~swarmtrack.analysis.metrics.series`: ``phi_bar`` (Figs. 8 left, 9, 10 left, 11 left), the parts
    ``phi_unexplored``, ``phi_unidentified``, ``phi_identified`` (Figs. 8 right, 10 right) or ``solve_time``
    (Fig. 11 right). One colour per setting, one line style per quantity."""
    if not results:
        raise ValueError("plot_phi_bands needs at least one setting")
    fig = _new_figure((9.0, 5.0))
    ax = fig.subplots()
    entries = _draw_phi_bands(ax, results, quantities)
    _band_axes(ax, quantities, entries)
    what = ", ".join(PHI_LABELS.get(q, q) for q in quantities)
    ax.set_title(title or f"{what}: mean, \u00b11 std over runs", fontsize=10)
    return _save(fig, path)


def plot_phi_parts_bands(results: Mapping[str, Sequence], path: str | Path, title: str | None = None) -> Path:
    """IB21 Fig. 8 right / Fig. 10 right as bands: one panel per part of Φ̄, φ(X̄) (unexplored), φ(Xᵁ)
    (unidentified) and φ(X) (identified), each the mean over the UAVs (m²), with per setting (``results``: label →
    runs, as :func:`plot_phi_bands`) the mean line and ±1 std band over the runs; each panel has its own y scale
    (φ(Xᵁ) and φ(X) are often a hundredth of φ(X̄))."""
    if not results:
        raise ValueError("plot_phi_parts_bands needs at least one setting")
    parts = tuple(metrics.PHI_PARTS.values())
    fig = _new_figure((15.0, 4.8))
    axes = fig.subplots(1, len(parts))
    for ax, q in zip(axes, parts, strict=True):
        entries = _draw_phi_bands(ax, results, (q,))
        _band_axes(ax, (q,), entries)
        ax.set_title(PHI_LABELS[q], fontsize=10)
    fig.suptitle(title or "Parts of the uncertainty: mean, \u00b11 std over runs", fontsize=10)
    return _save(fig, path)


__all__ += ["PHI_LABELS", "plot_uncertainty", "plot_uncertainty_per_uav", "plot_search_map", "phi_bands",
            "plot_phi_bands", "plot_phi_parts_bands"]


__all__ += ["MAX_POINTS", "slot_distances", "plot_formation_paths", "plot_formation_xy_time", "plot_slot_distance",
            "plot_mpc_inputs", "plot_min_separation", "PROBE_FIGURES"]


#: Figures a single run gets when it recorded the probe they read: ``(probe, file name, function)``.
PROBE_FIGURES = (("own_estimate", "model_estimates_path.png", plot_w20_path),
                 ("own_estimate", "model_estimates.png", plot_w20_xy_time),
                 ("winner", "model_selection.png", plot_model_selection),
                 ("probability", "model_probabilities.png", plot_model_probabilities),
                 ("setpoint", "formation_paths.png", plot_formation_paths),
                 ("setpoint", "formation_xy.png", plot_formation_xy_time),
                 ("setpoint", "slot_distances.png", plot_slot_distance),
                 ("setpoint", "mpc_inputs.png", plot_mpc_inputs),
                 ("setpoint", "min_separation.png", plot_min_separation),
                 ("phi", "uncertainty.png", plot_uncertainty),
                 ("phi", "uncertainty_per_uav.png", plot_uncertainty_per_uav),
                 ("phi", "search_map.png", plot_search_map))
#: Figures of :data:`PROBE_FIGURES` that need more than their probe: the test a recording must pass.
_FIGURE_APPLIES = {plot_min_separation: lambda rec: rec.n_agents >= 2}


def plot_degradation(curves: Mapping[str, Mapping[str, tuple]], xlabel: str, path: str | Path,
                     ticks: Sequence[str] | None = None) -> Path:
    """Degradation curves (issue 11's robustness study): one panel per metric, per setting (``curves``: label →
    metric → ``(x, mean, std)`` over runs) the mean with ±1 std error bars (NEES on a log scale); ``ticks``: names
    of a categorical x."""
    metrics_ = list(dict.fromkeys(m for per in curves.values() for m in per))
    fig = _new_figure((5.5 * len(metrics_), 4.2))
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
    return _save(fig, path)


__all__ += ["plot_degradation"]
