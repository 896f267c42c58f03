"""What every figure shares: colours, the figure and its atomic save, titles, phase marks, legends, the time axis,
and small helpers to read a recording's probes over a whole run.

Figures are built on :class:`matplotlib.figure.Figure` with an Agg canvas, so nothing here touches pyplot's global
state or needs a display. To keep files readable, at most :data:`MAX_LINES` agents (or agent pairs) are drawn per
panel; the title says so when lines were left out. The single-run figures of :mod:`swarmtrack.analysis.plots` and
the capabilities' figure modules (``swarmtrack.capabilities.<capability>.figures``) all draw with these.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from swarmtrack.outputs import partial_files
from swarmtrack.sim.recorder import Recording

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
PHASE_SHADE = "0.93"
PHASE_LINE = "0.45"


# --------------------------------------------------------------------------------------------- helpers
def agent_color(i: int) -> str:
    """Colour of agent ``i`` (0-based); green is never used (the true target's colour)."""
    return _AGENT_COLORS[i % len(_AGENT_COLORS)]


def pair_labels(n: int) -> list[str]:
    """1-based labels ``"i-j"`` of the pairs in the order of :func:`~swarmtrack.analysis.metrics.pair_distances`."""
    i, j = np.triu_indices(n, k=1)
    return [f"{a + 1}-{b + 1}" for a, b in zip(i.tolist(), j.tolist(), strict=True)]


def new_figure(figsize: tuple[float, float]) -> Figure:
    fig = Figure(figsize=figsize, dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig: Figure, path: str | Path) -> Path:
    path = Path(path)
    with partial_files([path]) as (partial,):  # an interrupted save leaves no half-written figure
        fig.savefig(partial, dpi=DPI, format="png")
    fig.clear()  # Figure objects are not registered with pyplot: clearing + dropping the reference closes it
    return path


def run_context(rec: Recording) -> str:
    """``"scenario: x, model: CT"`` from ``rec.meta`` (empty if neither is present)."""
    meta = rec.meta or {}
    parts = []
    if meta.get("scenario"):
        parts.append(f"scenario: {meta['scenario']}")
    if meta.get("model"):
        parts.append(f"model: {str(meta['model']).upper()}")
    return ", ".join(parts)


def figure_title(
    rec: Recording, what: str, shown: int | None = None, total: int | None = None, unit: str = ""
) -> str:
    title = what
    ctx = run_context(rec)
    if ctx:
        title += f" ({ctx})"
    if shown is not None and total is not None and shown < total:
        title += f"\nshowing the first {shown} of {total} {unit}"
    return title


def phase_segments(rec: Recording) -> list[tuple[float, float, str]]:
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


def mark_phases(ax: Axes, rec: Recording) -> None:
    """Shade every other phase, draw a vertical line at each phase change and write the phase names."""
    segments = phase_segments(rec)
    for n, (t0, t1, name) in enumerate(segments):
        if n % 2 == 1:
            ax.axvspan(t0, t1, color=PHASE_SHADE, zorder=0, lw=0)
        if n > 0:
            ax.axvline(t0, color=PHASE_LINE, lw=0.8, ls="-", zorder=1)
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
            ax.axvline(cs, color=PHASE_LINE, lw=0.8, ls=":", zorder=1)
            ax.text(cs, 0.02, " chase", transform=ax.get_xaxis_transform(), rotation=90, va="bottom",
                    ha="left", fontsize=7, color="0.3", zorder=5)


def mark_phases_on_path(ax: Axes, rec: Recording) -> None:
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


def time_axis(ax: Axes, rec: Recording) -> None:
    ax.set_xlabel("t [s]")
    if len(rec.t):
        ax.set_xlim(float(rec.t[0]), float(rec.t[-1]))
    ax.grid(True, lw=0.4, alpha=0.5)


def place_legend(ax: Axes, n_entries: int, outside: bool = False) -> None:
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



MAX_PHASE_MARKS = 15  # more phases (the evasive path's random segments) are not marked


def whole_probe(rec: Recording, name: str) -> np.ndarray | None:
    """One probe over the whole run, ``(K, N, *shape)``; None if the run did not record it."""
    if name not in (rec.meta or {}).get("probes", {}):
        return None
    parts = [c.probes[name] for c in rec.chunks()]
    return np.concatenate(parts) if parts else None



def maybe_mark_phases(ax: Axes, rec: Recording) -> None:
    if len(phase_segments(rec)) <= MAX_PHASE_MARKS:
        mark_phases(ax, rec)



def true_runs(mask: np.ndarray, t: np.ndarray, dt: float) -> list[tuple[float, float]]:
    """``(t_start, t_end)`` of each run of True in ``mask`` (K,) over the steps ``t``; a run ends ``dt`` after its
    last step."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(float(t[s]), float(t[e - 1]) + dt) for s, e in zip(starts.tolist(), ends.tolist(), strict=True)]



MAX_POINTS = 5000
"""Points per line the W20 Ch. 5 figures keep by default (``every=None``)."""
DECOY_COLOR = "0.35"


def concat(parts: list[np.ndarray], shape: tuple[int, ...]) -> np.ndarray:
    return np.concatenate(parts) if parts else np.zeros((0, *shape))


def pool_strides(x: np.ndarray, every: int, reduce) -> np.ndarray:
    """``reduce`` over each stride of ``every`` steps of ``x`` (K, ...): one value per kept step."""
    if every == 1 or not len(x):
        return x
    return reduce(x, np.arange(0, len(x), every), axis=0)

