"""Guaranteed search and track (IB21 Figs. 8-11): from the set-membership estimator's probes ``phi`` (Φ_i, eq. 10)
and its parts ``phi_unexplored``, ``phi_unidentified``, ``phi_identified``, the truth-side monitor
``guarantee_violations``, the alarms, and the truth of the ``targets``, ``decoys`` and ``uavs`` groups. One
streamed pass keeps every ``every``-th step (by default at most :data:`~swarmtrack.analysis.figure_style.
MAX_POINTS` per line): Φ changes only at the set updates (every sharing period and at identification frames), so a
stride hides nothing a line could show; the guarantee and alarm counts are taken over every step
(:class:`~swarmtrack.capabilities.set_membership.metrics.SetHealth`). The multi-run bands (IB21 Figs. 8-11 over
seeds) are drawn from the runs' summaries (their ``series``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes

from swarmtrack.analysis import metrics
from swarmtrack.analysis.coverage import came, mean_over_uavs
from swarmtrack.analysis.figure_style import (
    DECOY_COLOR,
    MAX_LINES,
    MAX_POINTS,
    TARGET_COLOR,
    agent_color,
    concat,
    figure_title,
    new_figure,
    place_legend,
    plot_band,
    save_figure,
)
from swarmtrack.analysis.sweep import series_band
from swarmtrack.capabilities.set_membership.metrics import PHI_PARTS, SetHealth
from swarmtrack.sim.recorder import Recording

PHI_LABELS = {"phi_bar": r"$\bar\Phi$ (eq. 11)", "phi_unexplored": r"$\varphi(\bar X)$ unexplored",
              "phi_unidentified": r"$\varphi(X^U)$ unidentified", "phi_identified": r"$\varphi(X)$ identified",
              "solve_time": "fleet MPC solve time per plan [s]"}
"""Legend labels of the IB21 time series (:func:`plot_uncertainty`, :func:`plot_phi_bands`)."""
_PART_COLORS = {"phi_unexplored": "tab:blue", "phi_unidentified": "tab:orange", "phi_identified": "tab:red"}
_QUANTITY_STYLES = ("-", "--", ":", "-.")


class _SetSeries:
    """One streamed pass over a set-membership recording: every ``every``-th step of ``t``, each UAV's Φ_i
    ``phi`` (K', N), the parts' means over the UAVs ``parts`` (name → (K',)), the true positions of every group
    ``paths`` (name → (K', members, 2)), the first t at which the mean of φ(X̄) is 0 (``cleared``) and the
    guarantee and alarm counts (``health``)."""

    def __init__(self, rec: Recording, every: int | None = None):
        steps = int((rec.meta or {}).get("n_steps") or 0)
        self.every = every = max(1, int(every)) if every is not None else max(1, -(-steps // MAX_POINTS))
        self.health = SetHealth(rec)
        groups = {name: slice(*span) for name, span in rec.meta["groups"].items() if span[1] > span[0]}
        t, phi, bar, parts, paths = [], [], [], {q: [] for q in PHI_PARTS.values()}, {g: [] for g in groups}
        self.cleared = None
        for c in rec.chunks():
            self.health.add(c)
            if not len(c.t):
                continue
            keep = (c.k0 + np.arange(len(c.t))) % every == 0
            present = came(rec, c)[keep]  # the means over the UAVs whose samples came
            t.append(c.t[keep])
            phi.append(c.probes["phi"][keep])
            bar.append(mean_over_uavs(c.probes["phi"][keep], present)[0])
            for q in parts:
                parts[q].append(mean_over_uavs(c.probes[q][keep], present)[0])
            for g, sl in groups.items():
                paths[g].append(c.truth[keep, sl, :2])
            if self.cleared is None:
                clear = np.flatnonzero(mean_over_uavs(c.probes["phi_unexplored"], came(rec, c))[0] == 0)
                self.cleared = float(c.t[clear[0]]) if len(clear) else None
        n = rec.n_agents
        self.t, self.phi, self.bar = concat(t, ()), concat(phi, (n,)), concat(bar, ())
        self.parts = {q: concat(v, ()) for q, v in parts.items()}
        self.paths = {g: concat(v, (groups[g].stop - groups[g].start, 2)) for g, v in paths.items()}
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
    fig = new_figure((9.0, 4.8))
    ax = fig.subplots()
    ax.plot(s.t, s.bar, color="black", lw=1.8, label=PHI_LABELS["phi_bar"], zorder=4)
    for q, values in s.parts.items():
        ax.plot(s.t, values, color=_PART_COLORS[q], lw=1.1, label=PHI_LABELS[q], zorder=3)
    _mark_set_events(ax, s)
    _set_time_axis(ax, s)
    ax.set_ylabel(r"area, mean over UAVs [m$^2$]")
    place_legend(ax, 4)
    ax.set_title(figure_title(rec, "Uncertainty and its parts") + "\n" + s.note(), fontsize=10)
    return save_figure(fig, path)


def plot_uncertainty_per_uav(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """Each UAV's uncertainty Φ_i (IB21 eq. 10) over time, Φ̄ (their mean, eq. 11) dashed: how far apart the
    UAVs' beliefs are (they agree only where the links carried their sets)."""
    s = _SetSeries(rec, every)
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    fig = new_figure((9.0, 4.8))
    ax = fig.subplots()
    for i in range(shown):
        ax.plot(s.t, s.phi[:, i], color=agent_color(i), lw=1.0, label=f"UAV {i + 1}", zorder=3)
    if len(s.t):
        ax.plot(s.t, s.bar, color="black", lw=1.4, ls="--", label=PHI_LABELS["phi_bar"], zorder=4)
    _mark_set_events(ax, s)
    _set_time_axis(ax, s)
    ax.set_ylabel(r"$\Phi_i$ [m$^2$]")
    place_legend(ax, shown + 1, outside=True)
    ax.set_title(figure_title(rec, "Uncertainty of each UAV", shown, n, "UAVs") + "\n" + s.note(), fontsize=10)
    return save_figure(fig, path)


def plot_search_map(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """The search area X0 with every UAV's true path and the true paths of the targets (green) and decoys (grey,
    dashed); o start, □ end. No sets are drawn (they exist only onboard, at each instant: see the animation)."""
    s = _SetSeries(rec, every)
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    fig = new_figure((7.5, 7.0))
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
    place_legend(ax, shown + 3, outside=True)
    span = f"t = 0-{rec.t_last:g} s"
    ax.set_title(figure_title(rec, "Search map: true paths", shown, n, "UAVs") + f"\n{span} (o start, \u25a1 end)",
                 fontsize=10)
    return save_figure(fig, path)


def _run_series(run) -> Mapping:
    """A run's time series: of a :class:`Recording` (computed), of a summary (its ``series``) or the series."""
    if isinstance(run, Recording):
        return metrics.series(run)
    return run["series"] if "series" in run else run


def phi_bands(runs, quantity: str) -> dict | None:
    """Mean and ±1 std over ``runs`` (Recordings, summaries or their ``series``) of one time series per bin:
    :func:`swarmtrack.analysis.sweep.series_band`'s alignment (runs of different lengths, bins merged into the
    coarsest run's). None: no run recorded ``quantity``."""
    import pandas as pd  # deferred: pandas costs an import of a second

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


def _mark_times(ax: Axes, marks: Sequence[tuple[float, str]] = (), window: tuple[float, float] | None = None) -> None:
    """Dotted verticals at the times a statement names (``marks``: (t, text), e.g. IB21 Fig. 10's t = 100 s) and a
    grey span over ``window`` (t0, t1) (e.g. Fig. 8 right's initial growth)."""
    for t, text in marks:
        ax.axvline(t, color="black", lw=0.9, ls=":", zorder=2)
        ax.text(t, 0.98, f" {text}", transform=ax.get_xaxis_transform(), rotation=90, va="top", ha="left",
                fontsize=7, zorder=5)
    if window is not None:
        ax.axvspan(*window, color="0.85", alpha=0.5, lw=0, zorder=0)


def _band_axes(ax: Axes, quantities: Sequence[str], entries: int) -> None:
    """Axis labels, grid and legend of a panel of bands (:func:`_draw_phi_bands`)."""
    ax.set_xlabel("t [s]")
    ax.set_ylabel(PHI_LABELS["solve_time"] if tuple(quantities) == ("solve_time",)
                  else r"area, mean over UAVs [m$^2$]")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, lw=0.4, alpha=0.5)
    if entries:
        place_legend(ax, entries, outside=entries > 6)
    else:
        ax.text(0.5, 0.5, f"no run recorded {', '.join(quantities)}", transform=ax.transAxes, ha="center")


def plot_phi_bands(results: Mapping[str, Sequence], path: str | Path, quantities: Sequence[str] = ("phi_bar",),
                   title: str | None = None, marks: Sequence[tuple[float, str]] = ()) -> Path:
    """IB21 Figs. 8-11: per setting (``results``: label → runs, each a :class:`Recording`, its summary or its
    ``series``) the mean line and a ±1 std band over the runs (:func:`plot_band`) of each quantity of
    :func:`~swarmtrack.analysis.metrics.series`: ``phi_bar`` (Figs. 8 left, 9, 10 left, 11 left), the parts
    ``phi_unexplored``, ``phi_unidentified``, ``phi_identified`` (Figs. 8 right, 10 right) or ``solve_time``
    (Fig. 11 right). One colour per setting, one line style per quantity; ``marks``: (t, text) verticals (Fig. 10:
    t = 100 s)."""
    if not results:
        raise ValueError("plot_phi_bands needs at least one setting")
    fig = new_figure((9.0, 5.0))
    ax = fig.subplots()
    entries = _draw_phi_bands(ax, results, quantities)
    _band_axes(ax, quantities, entries)
    _mark_times(ax, marks)
    what = ", ".join(PHI_LABELS.get(q, q) for q in quantities)
    ax.set_title(title or f"{what}: mean, \u00b11 std over runs", fontsize=10)
    return save_figure(fig, path)


def plot_phi_parts_bands(results: Mapping[str, Sequence], path: str | Path, title: str | None = None,
                         window: tuple[float, float] | None = None) -> Path:
    """IB21 Fig. 8 right / Fig. 10 right as bands: one panel per part of Φ̄, φ(X̄) (unexplored), φ(Xᵁ)
    (unidentified) and φ(X) (identified), each the mean over the UAVs (m²), with per setting (``results``: label →
    runs, as :func:`plot_phi_bands`) the mean line and ±1 std band over the runs; each panel has its own y scale
    (φ(Xᵁ) and φ(X) are often a hundredth of φ(X̄)). ``window``: a grey span (t0, t1), e.g. the initial growth of
    IB21 Fig. 8 right's statement."""
    if not results:
        raise ValueError("plot_phi_parts_bands needs at least one setting")
    parts = tuple(PHI_PARTS.values())
    fig = new_figure((15.0, 4.8))
    axes = fig.subplots(1, len(parts))
    for ax, q in zip(axes, parts, strict=True):
        entries = _draw_phi_bands(ax, results, (q,))
        _band_axes(ax, (q,), entries)
        _mark_times(ax, (), window)
        ax.set_title(PHI_LABELS[q], fontsize=10)
    fig.suptitle(title or "Parts of the uncertainty: mean, \u00b11 std over runs", fontsize=10)
    return save_figure(fig, path)



def plot_phi_spread(results: Mapping[str, Sequence], path: str | Path, title: str | None = None) -> Path:
    """IB21 Fig. 8 left's shaded area on its own: per setting (``results``: label → runs, as :func:`plot_phi_bands`)
    the std over the runs of Φ̄_k per time bin (the band's half width), the statement "the variance of Φ̄_k is the
    largest for 4 UAVs" made visible; the legend gives each setting's time-mean std."""
    if not results:
        raise ValueError("plot_phi_spread needs at least one setting")
    fig = new_figure((9.0, 5.0))
    ax = fig.subplots()
    entries = 0
    for k, (label, runs) in enumerate(results.items()):
        band = phi_bands(list(runs), "phi_bar")
        if band is None:
            continue
        std = np.array([np.nan if v is None else v for v in band["std"]], dtype=float)
        ok = np.array(band["n"]) >= 2
        shown = np.where(ok, std, np.nan)
        note = f"time-mean {float(np.nanmean(shown)):,.0f} m$^2$" if ok.any() else "no spread with one run"
        ax.plot(band["t"], shown, color=agent_color(k), lw=1.3, label=f"{label} ({band['runs']} runs; {note})")
        entries += 1
    ax.set_xlabel("t [s]")
    ax.set_ylabel(r"std of $\bar\Phi$ over the runs [m$^2$]")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, lw=0.4, alpha=0.5)
    if entries:
        place_legend(ax, entries)
    else:
        ax.text(0.5, 0.5, "no setting has 2 runs", transform=ax.transAxes, ha="center")
    ax.set_title(title or r"std of $\bar\Phi$ over runs", fontsize=10)
    return save_figure(fig, path)


def _per_uav_times(runs: Sequence) -> np.ndarray | None:
    """(runs, N) each run's mean control time per plan of each UAV, in decision order (s), from the runs'
    summaries (``set_membership.solve_time.per_uav_mean``); None: no run has it."""
    solves = [((r.get("set_membership") or {}).get("solve_time") or {}) for r in runs if isinstance(r, Mapping)]
    rows = [s["per_uav_mean"] for s in solves if s.get("per_uav_mean")]
    return np.array(rows, dtype=float) if rows else None


def plot_compute_time(results: Mapping[str, Sequence], path: str | Path, title: str | None = None,
                      paper_ratios: Mapping[int, float] | None = None) -> Path:
    """IB21 Fig. 11 right: left, per setting (``results``: label → the runs' summaries) the mean line and ±1 std
    band over the runs of the fleet's control time per plan (the sum over the UAVs, ms) against time; right, each
    UAV's mean time per plan in decision order (bars: mean over the runs, whiskers: their std), where the paper's
    explanation (each UAV evaluates the inputs of those before it) would show a rise with the index. The legend
    gives each fleet's time and its ratio to the first setting's, beside ``paper_ratios`` (fleet size → ratio to
    one UAV's; shown when the first setting has one UAV)."""
    if not results:
        raise ValueError("plot_compute_time needs at least one setting")
    fig = new_figure((14.0, 5.0))
    left, right = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.6, 1.0]})
    per_uav = {label: _per_uav_times(runs) for label, runs in results.items()}
    fleet = {label: None if v is None else float(v.sum(axis=1).mean()) for label, v in per_uav.items()}
    first = next((label for label, v in fleet.items() if v), None)
    base = None if first is None else fleet[first]
    one = first is not None and per_uav[first].shape[1] == 1  # the paper's ratios are to one UAV's time
    entries = 0
    for k, (label, runs) in enumerate(results.items()):
        band = phi_bands(list(runs), "solve_time")
        if band is None:
            continue
        mean = 1000 * np.array([np.nan if v is None else v for v in band["mean"]], dtype=float)
        std = 1000 * np.array([np.nan if v is None else v for v in band["std"]], dtype=float)
        text = f"{label} ({band['runs']} runs"
        if fleet[label] is not None and base:
            n = per_uav[label].shape[1]
            paper = (paper_ratios or {}).get(n) if one else None
            text += f"; {1000 * fleet[label]:.2f} ms, {fleet[label] / base:.2f}x"
            text += f", paper {paper:g}x" if paper else ""
        plot_band(left, band["t"], mean, std, text + ")", color=agent_color(k))
        entries += 1
    left.set_xlabel("t [s]")
    left.set_ylabel("fleet control time per plan, sum over the UAVs [ms]")
    left.set_ylim(bottom=0.0)
    left.grid(True, lw=0.4, alpha=0.5)
    if entries:
        place_legend(left, entries)
    shown = [(label, v) for label, v in per_uav.items() if v is not None]
    width = 0.8 / max(1, len(shown))
    for k, (label, v) in enumerate(shown):
        x = np.arange(1, v.shape[1] + 1) + (k - (len(shown) - 1) / 2) * width
        right.bar(x, 1000 * v.mean(axis=0), width, yerr=1000 * v.std(axis=0), color=agent_color(k), alpha=0.8,
                  capsize=2, label=label)
    right.set_xlabel("UAV, in decision order")
    right.set_ylabel("control time per plan [ms]")
    right.set_xticks(np.arange(1, max((v.shape[1] for _, v in shown), default=1) + 1))
    right.grid(True, axis="y", lw=0.4, alpha=0.5)
    if shown:
        place_legend(right, len(shown))
    right.set_title("each UAV's time (mean, std over runs)", fontsize=10)
    fig.suptitle(title or "Control time per plan: mean, \u00b11 std over runs", fontsize=10)
    return save_figure(fig, path)
