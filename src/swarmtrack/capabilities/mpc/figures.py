"""The distributed MPC's formation-tracking figures (W20 Figs. 5.6-5.14), from the truth, the controller's spec in
``meta["controller"]`` (``offsets``: each UAV's slot r_r relative to the target, ``start``, ``r_s``, ``bound``)
and its per-UAV probes ``setpoint`` (absolute), ``avoiding`` and the cumulative ``solves``, ``fallbacks``,
``solve_time``, ``iterations``. They stream the recording chunk by chunk and keep every ``every``-th step of the
(K, N, 2) series (by default at most :data:`~swarmtrack.analysis.figure_style.MAX_POINTS` per line); what a
stride could hide is pooled over each stride instead: the minimum separation (its minimum), the avoidance count
(its maximum)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.axes import Axes

from swarmtrack.analysis.figure_style import (
    MAX_LINES,
    MAX_POINTS,
    TARGET_COLOR,
    agent_color,
    concat,
    figure_title,
    maybe_mark_phases,
    new_figure,
    place_legend,
    pool_strides,
    save_figure,
    time_axis,
    true_runs,
)
from swarmtrack.analysis.metrics import min_separations
from swarmtrack.capabilities.mpc.metrics import COLLISION_M, formation_spec, slot_offsets
from swarmtrack.sim.recorder import Recording


def slot_distances(rec: Recording) -> np.ndarray:
    """(K, N) true distance of every UAV to its formation slot ``q_t + r_r`` (W20 Ch. 5's tracking error before
    it is averaged: :func:`~swarmtrack.analysis.metrics.summary`'s ``formation.tracking_error`` is its mean over
    the steps from the MPC's start on). Whole run in memory: for plots and tests of small runs."""
    offsets, _, _ = formation_spec(rec)
    parts = [np.linalg.norm(slot_offsets(rec, c.truth, offsets), axis=-1)
             for c in rec.chunks(probes_wanted=False)]
    return np.concatenate(parts) if parts else np.zeros((0, rec.n_agents))



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
        self.offsets, self.start, self.ctrl = formation_spec(rec)
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
            dist.append(np.linalg.norm(slot_offsets(rec, c.truth[keep], self.offsets), axis=-1))
            u.append((setpoint - at_plan)[keep])
            sep.append(min_separations(q))
            avoiding.append(c.probes["avoiding"] if "avoiding" in c.probes else np.zeros((k, n)))
            blind.append(c.probes["detected"] <= 0 if "detected" in c.probes else np.zeros((k, n), dtype=bool))
            solver = {name: c.probes[name][-1] for name in ("solves", "fallbacks", "solve_time") if name in c.probes}
        self.t, self.target, self.uav = concat(keep_t, ()), concat(target, (2,)), concat(uav, (n, 2))
        self.slot = self.target[:, None, :] + self.offsets
        self.distance, self.u = concat(dist, (n,)), concat(u, (n, 2))
        self.separation = pool_strides(concat(sep, ()), every, np.minimum.reduceat)
        self.avoiding = pool_strides(concat(avoiding, (n,)), every, np.maximum.reduceat)
        full_t, blind = concat(full_t, ()), concat(blind, (n,))
        self.blind = [true_runs(blind[:, i], full_t, rec.dt) for i in range(n)]
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
    fig = new_figure((8.0, 7.0))
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
    place_legend(ax, 2 * shown + 1 + blind_shown)
    marks = "o start, \u25a1 end, \u00d7 slot at the end"
    if s.started():
        marks += f", \u25c6 MPC start (t = {s.start:g} s)"
    ax.set_title(figure_title(rec, "Formation tracking paths", shown, n, "UAVs")
                 + f"\nsolid: UAVs, dashed: their slots (target + offset)\n{marks}", fontsize=10)
    return save_figure(fig, path)


def plot_formation_xy_time(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """W20 Figs. 5.9, 5.12, 5.14: x(t) and y(t) of every UAV (solid) and of its slot (dashed, same colour), the
    target in green; the MPC's start a dashed vertical line, the target's phases marked."""
    s = _FormationSeries(rec, every)
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    fig = new_figure((10.0, 6.5))
    axes = fig.subplots(2, 1, sharex=True)
    for ax, col, comp in ((axes[0], 0, "x"), (axes[1], 1, "y")):
        ax.plot(s.t, s.target[:, col], color=TARGET_COLOR, lw=1.6, label="target", zorder=2.5)
        for i in range(shown):
            c = agent_color(i)
            ax.plot(s.t, s.uav[:, i, col], color=c, lw=1.1, label=f"UAV {i + 1}", zorder=3)
            ax.plot(s.t, s.slot[:, i, col], color=c, lw=0.9, ls="--", alpha=0.8, label=f"UAV {i + 1} slot",
                    zorder=3)
        maybe_mark_phases(ax, rec)
        _mark_mpc_start(ax, s)
        time_axis(ax, rec)
        ax.set_ylabel(f"{comp} [m]")
    axes[0].set_xlabel("")
    place_legend(axes[0], 2 * shown + 1, outside=True)
    fig.suptitle(figure_title(rec, "UAV positions (solid) and their formation slots (dashed) over time", shown, n,
                        "UAVs"))
    return save_figure(fig, path)


def plot_slot_distance(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """Each UAV's true distance to its slot over time (:func:`slot_distances`; its mean from the MPC's start on,
    W20 Tables 5.6-5.12's tracking error, in the legend); the MPC's start marked, blind intervals shaded."""
    s = _FormationSeries(rec, every)
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    fig = new_figure((10.0, 4.8))
    ax = fig.subplots()
    after = s.t >= s.start - 1e-9
    for i in range(shown):
        mean = f", mean {s.distance[after, i].mean():.2f} m from the start" if after.any() else ""
        ax.plot(s.t, s.distance[:, i], color=agent_color(i), lw=1.0, label=f"UAV {i + 1}{mean}", zorder=3)
    blind = _shade_blind(ax, s, shown)
    maybe_mark_phases(ax, rec)
    _mark_mpc_start(ax, s)
    time_axis(ax, rec)
    ax.set_ylabel(r"$\|q_i - (q_t + r_{r,i})\|$ [m]")
    ax.set_ylim(bottom=0.0)
    place_legend(ax, shown + blind, outside=True)
    note = "" if s.every == 1 else f"\n(every {s.every}th step drawn; means over those)"
    ax.set_title(figure_title(rec, "Distance of each UAV to its formation slot", shown, n, "UAVs") + note, fontsize=10)
    return save_figure(fig, path)


def plot_mpc_inputs(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """W20 Fig. 5.7 (top): each UAV's relative input ``u = setpoint − p`` per axis over time with the bounds
    ``±bound`` (see :class:`_FormationSeries` for the position taken) and, when the bound is more than the vehicle
    flies, the bound it flies (``meta["mpc"]["vehicle_bound"]``, dotted red); and below, the number of active
    collision-avoidance terms (neighbours closer than r_s when the plan was made; maximum per drawn step)."""
    s = _FormationSeries(rec, every)
    n = rec.n_agents
    shown = min(n, MAX_LINES)
    bound = s.ctrl.get("bound")
    flyable = ((rec.meta or {}).get("mpc") or {}).get("vehicle_bound")
    fig = new_figure((10.0, 7.5))
    axes = fig.subplots(3, 1, sharex=True, height_ratios=(3, 3, 1.4))
    for ax, col, comp in ((axes[0], 0, "x"), (axes[1], 1, "y")):
        for i in range(shown):
            ax.step(s.t, s.u[:, i, col], where="post", color=agent_color(i), lw=0.9, label=f"UAV {i + 1}", zorder=3)
        if bound is not None:
            for sign in (1, -1):
                ax.axhline(sign * float(bound), color="black", lw=1.0, ls="--", zorder=2,
                           label=f"\u00b1bound = {float(bound):g} m" if sign > 0 else None)
        if flyable is not None and bound is not None and flyable < float(bound):  # a bound the vehicle cannot fly
            for sign in (1, -1):
                ax.axhline(sign * flyable, color="tab:red", lw=1.0, ls=":", zorder=2,
                           label=f"\u00b1{flyable:g} m: what the vehicle flies" if sign > 0 else None)
        ax.set_ylabel(f"$u_{comp}$ [m]")
    ax = axes[2]
    for i in range(shown):
        ax.step(s.t, s.avoiding[:, i], where="post", color=agent_color(i), lw=0.9, label=f"UAV {i + 1}")
    top = int(np.nanmax(s.avoiding[:, :shown])) if s.avoiding.size else 0
    ax.set_yticks(range(0, max(top, 1) + 1))
    ax.set_ylim(-0.2, max(top, 1) + 0.2)
    ax.set_ylabel("avoiding", fontsize=8)
    for ax in axes:
        maybe_mark_phases(ax, rec)
        _mark_mpc_start(ax, s)
        time_axis(ax, rec)
        if ax is not axes[-1]:
            ax.set_xlabel("")
    place_legend(axes[0], shown + 1 + (flyable is not None and bound is not None and flyable < float(bound)),
                 outside=True)
    stats = ""
    if "solves" in s.solver:
        solves = s.solver["solves"]
        mean_us = 1e6 * float(s.solver.get("solve_time", np.zeros(1)).sum()) / max(float(solves.sum()), 1.0)
        fallbacks = int(s.solver.get("fallbacks", np.zeros(1)).sum())
        stats = (f"\n{int(solves.sum())} plans solved, {fallbacks} fallbacks, mean solve {mean_us:.0f} \u00b5s; "
                 "bottom: active avoidance terms")
    fig.suptitle(figure_title(rec, "MPC inputs: setpoint relative to the UAV's position at the plan", shown, n, "UAVs")
                 + stats)
    return save_figure(fig, path)


def plot_min_separation(rec: Recording, path: str | Path, every: int | None = None) -> Path:
    """W20 Sec. 5.4.3 (Table 5.9's test): the smallest true distance between any two UAVs over time (the minimum
    over each drawn stride, so no close pass is hidden), ``r_s`` dashed, the separation constraint's distance
    (``meta["mpc"]["separation"]``, when on) dash-dotted and the collision distance
    :data:`~swarmtrack.analysis.COLLISION_M` dotted; the closest approach annotated."""
    s = _FormationSeries(rec, every)
    fig = new_figure((9.0, 4.5))
    ax = fig.subplots()
    r_s = s.ctrl.get("r_s")
    kept = ((rec.meta or {}).get("mpc") or {}).get("separation")
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
        if kept is not None:
            ax.axhline(float(kept), color="tab:green", lw=1.0, ls="-.", zorder=2,
                       label=f"separation constraint ({float(kept):g} m)")
        ax.axhline(COLLISION_M, color="tab:red", lw=1.0, ls=":", label=f"collision ({COLLISION_M:g} m)",
                   zorder=2)
        place_legend(ax, 3 + (kept is not None))
    maybe_mark_phases(ax, rec)
    _mark_mpc_start(ax, s)
    time_axis(ax, rec)
    ax.set_ylabel("min inter-UAV distance [m]")
    ax.set_ylim(bottom=0.0)
    ax.set_title(figure_title(rec, "Minimum separation between UAVs"), fontsize=10)
    return save_figure(fig, path)

