"""What the analysis reads of the set-membership estimator's runs (IB21): the ``set_membership`` section (the
uncertainty Φ̄, its parts, the guarantee and alarm counts, the SM-MPC's solve time), its warnings (:class:`SetHealth`),
the network's (late data: :class:`~swarmtrack.analysis.health.NetworkHealth`), the time series ``phi_bar``, its parts
and ``solve_time``, and the figures of :mod:`.figures` (uncertainty, per UAV, search map).

The ``set_membership`` section: ``phi_bar_final`` and ``phi_bar_mean`` (Φ̄ = the mean over the UAVs of Φ_i, eq. 11,
m², at the last step and averaged over the steps, which are evenly spaced: the time average),
``phi_bar_final_fraction`` (over the area of X0, ``area``), ``parts_final`` (φ(X̄), φ(Xᵁ), φ(X), each the mean over
the UAVs, at the last step), the guarantee and alarm counts of :meth:`SetHealth.counts` (``guarantee_violations``:
the monitor's counts summed over all steps and UAVs, ``max_violations_per_step``, ``empty_set_alarms``: the UAVs
whose all-empty alarm ever rose, ``alarms_unexplained`` …), ``time_unexplored_cleared`` (the first t at which the mean
over the UAVs of φ(X̄) is exactly 0, else None; X̄ never regrows once empty), ``identified_final`` (identified
targets, mean over the UAVs, at the last step) and ``solve_time`` (the MPC's: ``plans`` seen, ``fleet_mean`` and
``fleet_max`` over the plans of the sum over the UAVs, ``per_uav_mean`` and ``per_uav_max`` per UAV; plans are found
from the controller's period, :func:`plan_steps`; None without plans).

Warnings (:class:`SetHealth`):

* **Guarantee violated**: a check of the truth-side monitor ``guarantee_violations`` found a true target outside
  the sets that must hold it (IB21 Secs. 3.4-3.5: impossible while the true noise box lies in the assumed one).
* **All sets empty**: every set of a UAV became empty (its ``alarm_all_empty`` count rose): every target lost, the
  paper's sign of an assumed noise bound that is too small (IB21 Sec. 6, Fig. 10).
* **Unexplained detections without decoys**: with no decoys in the world, a detection that meets no set that could
  hold it (``alarm_unexplained``) cannot happen under the assumptions either (with decoys it can: a decoy seen
  again after it was identified as one).
"""

from __future__ import annotations

import numpy as np

from swarmtrack.analysis.coverage import came, mean_over_uavs
from swarmtrack.analysis.health import NETWORK
from swarmtrack.analysis.metrics import SERIES
from swarmtrack.registry import Figure, Metric
from swarmtrack.sim.recorder import Chunk, Recording

#: How many UAVs whose sets all emptied are named one by one.
LISTED = 10

_FIGURES = "swarmtrack.capabilities.set_membership.figures:"


def guaranteed(rec: Recording) -> bool:
    """The run recorded a set-membership estimator's uncertainty Φ (IB21 eq. 10)."""
    return "phi" in rec.meta["probes"]


#: The parts of Φ (IB21 eq. 10) a set-membership estimator records, by their names in the summary.
PHI_PARTS = {"unexplored": "phi_unexplored", "unidentified": "phi_unidentified", "identified": "phi_identified"}


def plan_steps(t: np.ndarray, dt: float, period: float, start: float = 0.0) -> np.ndarray:
    """(k,) whether the record at each time ``t`` is the first to show a new plan of a controller that plans every
    ``period`` s from ``start`` (IB21's SM-MPC: ``meta["controller"]``'s ``period``, T^c = 0.5 s).

    The engine records a step before its control runs, so a plan made at ``t_p`` first shows in the record of the
    next estimation step: the record at ``t`` holds a new plan iff a plan time ``start + m·period`` (m ≥ 0) lies in
    ``[t − dt, t)``. (With control faster than estimation only the last plan of a step would show; no built-in
    scenario does that.)"""
    def plans_before(x):  # plan times in [start, x), counted
        return np.maximum(np.ceil((x - start) / period - 1e-9), 0.0)

    t = np.asarray(t, dtype=float)
    return plans_before(t) > plans_before(t - dt)


class _SetMembership:
    """IB21's uncertainty, guarantee and SM-MPC cost, streamed (O(N)): see :func:`summary`'s ``set_membership``."""

    def __init__(self, rec: Recording):
        n, probes = rec.n_agents, rec.meta["probes"]
        self.rec, self.health = rec, SetHealth(rec)
        self.phi_sum, self.steps, self.final, self.cleared = 0.0, 0, None, None
        ctrl = rec.meta.get("controller") or {}
        self.period = ctrl.get("period") if "solve_time" in probes else None
        self.start = float(ctrl.get("start") or 0.0)
        self.plans, self.fleet_sum, self.fleet_max = 0, 0.0, 0.0
        self.uav_sum, self.uav_max = np.zeros(n), np.zeros(n)

    def add(self, c: Chunk, keep, err) -> None:
        self.health.add(c)
        if not len(c.t):
            return
        present = came(self.rec, c)
        bar, some = mean_over_uavs(c.probes["phi"], present)  # Φ̄, eq. 11, over the UAVs whose samples came
        if not some.any():
            return
        self.phi_sum += float(bar[some].sum())
        self.steps += int(some.sum())
        last = np.flatnonzero(some)[-1]

        def final(name: str) -> float:
            return float(mean_over_uavs(c.probes[name][last:last + 1], present[last:last + 1])[0][0])

        self.final = {"phi_bar": float(bar[last]), "n_identified": final("n_identified"),
                      **{part: final(p) for part, p in PHI_PARTS.items()}}
        if self.cleared is None:
            clear = np.flatnonzero(some & (mean_over_uavs(c.probes["phi_unexplored"], present)[0] == 0))
            self.cleared = float(c.t[clear[0]]) if len(clear) else None
        if self.period:
            plans = plan_steps(c.t, self.rec.dt, self.period, self.start)
            solve = np.where(present, c.probes["solve_time"], 0.0)[plans]  # (plans, N): an absent UAV's counts 0
            if len(solve):
                fleet = solve.sum(axis=1)
                self.plans += len(solve)
                self.fleet_sum += float(fleet.sum())
                self.fleet_max = max(self.fleet_max, float(fleet.max()))
                self.uav_sum += solve.sum(axis=0)
                self.uav_max = np.maximum(self.uav_max, solve.max(axis=0))

    def warnings(self) -> list[dict]:
        """The guarantee's and the alarms' (:meth:`SetHealth.result`)."""
        return self.health.result()

    def result(self) -> dict:
        area = _area(self.rec)
        final = self.final or dict.fromkeys(["phi_bar", "n_identified", *PHI_PARTS], None)
        solve = None
        if self.plans:
            solve = {"plans": self.plans, "fleet_mean": self.fleet_sum / self.plans, "fleet_max": self.fleet_max,
                     "per_uav_mean": (self.uav_sum / self.plans).tolist(), "per_uav_max": self.uav_max.tolist()}
        return {"phi_bar_final": final["phi_bar"],
                "phi_bar_mean": self.phi_sum / self.steps if self.steps else None,
                "phi_bar_final_fraction": final["phi_bar"] / area if area and self.final else None,
                "area": area,
                "parts_final": {part: final[part] for part in PHI_PARTS},
                **self.health.counts(),
                "time_unexplored_cleared": self.cleared,
                "identified_final": final["n_identified"],
                "solve_time": solve}


def _area(rec: Recording) -> float | None:
    """Area of X0 (m²) from the estimator's ``area`` box ``[x0, y0, x1, y1]`` in the run's meta (None if absent)."""
    box = ((rec.meta or {}).get("estimator") or {}).get("area")
    return None if box is None else float((box[2] - box[0]) * (box[3] - box[1]))


def _group_size(rec: Recording, name: str) -> int:
    start, stop = rec.meta["groups"].get(name, (0, 0))
    return stop - start


class SetHealth:
    """IB21's guarantee and alarms, streamed (O(N) state): the total and the largest per-step sum over the UAVs of
    the ``guarantee_violations`` monitor (true targets outside the sets that must hold them, counted where a UAV's
    sets describe the step's instant; absent when the world has no targets), when the first and last violation were
    seen, the time each UAV's cumulative ``alarm_all_empty`` count first rose (NaN: never) and the last
    ``alarm_unexplained`` counts. :func:`swarmtrack.analysis.metrics.summary` reads :meth:`counts` for its
    ``set_membership`` section and :meth:`result` for its warnings."""

    def __init__(self, rec: Recording):
        n = rec.n_agents
        self.rec = rec
        self.monitored = "guarantee_violations" in rec.meta["probes"]
        self.violations, self.worst, self.first, self.last = 0.0, 0.0, None, None
        self.empty_count = np.zeros(n)  # the cumulative alarm count at the last step seen
        self.empty_at = np.full(n, np.nan)
        self.unexplained = np.zeros(n)

    def add(self, c, keep=None, err=None) -> None:
        """Every step of chunk ``c``."""
        if not len(c.t):
            return
        if self.monitored:
            per_step = np.nansum(c.probes["guarantee_violations"], axis=1)
            self.violations += float(per_step.sum())
            self.worst = max(self.worst, float(per_step.max()))
            hit = np.flatnonzero(per_step > 0)
            if len(hit):
                self.first = float(c.t[hit[0]]) if self.first is None else self.first
                self.last = float(c.t[hit[-1]])
        # cumulative counts: a sample that did not come (NaN) holds the count before it
        count = np.fmax.accumulate(np.concatenate([self.empty_count[None], c.probes["alarm_all_empty"]]), axis=0)[1:]
        rose = count > np.concatenate([self.empty_count[None], count[:-1]])  # (k, N): the count went up at k
        new = np.isnan(self.empty_at) & rose.any(axis=0)
        self.empty_at[new] = c.t[rose.argmax(axis=0)[new]]
        self.empty_count = count[-1].copy()
        self.unexplained = np.fmax(self.unexplained, np.fmax.reduce(c.probes["alarm_unexplained"], axis=0))

    def counts(self) -> dict:
        """``guarantee_violations`` (total over steps and UAVs; None without a monitor), ``max_violations_per_step``,
        ``first_violation_t``, ``empty_set_alarms`` (UAVs whose all-empty alarm ever rose), ``empty_set_alarm_t``
        (per UAV, when it first rose; None: never), ``all_empty_events`` (sum of the final cumulative counts) and
        ``alarms_unexplained`` (sum of the final cumulative counts)."""
        return {"guarantee_violations": int(self.violations) if self.monitored else None,
                "max_violations_per_step": int(self.worst) if self.monitored else None,
                "first_violation_t": self.first,
                "empty_set_alarms": int(np.isfinite(self.empty_at).sum()),
                "empty_set_alarm_t": [None if np.isnan(t) else float(t) for t in self.empty_at],
                "all_empty_events": int(self.empty_count.sum()),
                "alarms_unexplained": int(self.unexplained.sum())}

    def result(self) -> list[dict]:
        out = []
        if self.violations:
            out.append({"kind": "guarantee_violated", "t_start": self.first, "t_end": self.last,
                        "message": f"guarantee violated: {int(self.violations)} checks found a true target outside "
                                   f"its sets (t = {self.first:.2f}-{self.last:.2f} s)"})
        emptied = np.flatnonzero(np.isfinite(self.empty_at))
        for i in emptied[:LISTED]:
            t = float(self.empty_at[i])
            out.append({"kind": "all_sets_empty", "uav": int(i) + 1, "t_start": t, "t_end": None,
                        "message": f"every set of UAV {i + 1} became empty at t = {t:.2f} s: the assumed noise bound "
                                   "may be too small"})
        if len(emptied) > LISTED:
            out.append({"kind": "all_sets_empty", "uav": None, "t_start": float(np.nanmin(self.empty_at)),
                        "t_end": None, "message": f"and {len(emptied) - LISTED} more UAVs lost every set"})
        if self.unexplained.sum() and not _group_size(self.rec, "decoys"):
            out.append({"kind": "unexplained_without_decoys", "t_start": None, "t_end": None,
                        "message": f"{int(self.unexplained.sum())} detections met no set that could hold them although "
                                   "the world has no decoys: the assumed noise bound may be too small"})
        return out


class SetSeries:
    """The time series ``phi_bar`` (Φ̄, IB21 eq. 11), ``phi_unexplored``, ``phi_unidentified``, ``phi_identified``
    (its parts φ(X̄), φ(Xᵁ), φ(X)): each the mean over the UAVs per step, m² (IB21 Figs. 8-11); and ``solve_time``:
    the fleet's total MPC solve time per plan (sum over the UAVs at the steps that show a new plan,
    :func:`plan_steps`), s (runs with ``solve_time`` and a controller ``period``: IB21 Fig. 11 right)."""

    labels = {"phi_bar": "Φ̄, mean over UAVs of Φ_i [m²]", "phi_unexplored": "φ(X̄), mean over UAVs [m²]",
              "phi_unidentified": "φ(Xᵁ), mean over UAVs [m²]", "phi_identified": "φ(X), mean over UAVs [m²]",
              "solve_time": "fleet MPC solve time per plan [s]"}

    def __init__(self, rec: Recording):
        self.rec = rec
        self.quantities = ["phi_bar", *PHI_PARTS.values()]
        ctrl = rec.meta.get("controller") or {}
        self.plan = None
        if "solve_time" in rec.meta["probes"] and ctrl.get("period"):
            self.quantities.append("solve_time")
            self.plan = (ctrl["period"], float(ctrl.get("start") or 0.0))

    def values(self, c: Chunk) -> dict:
        present = came(self.rec, c)
        bar, some = mean_over_uavs(c.probes["phi"], present)
        out = {"phi_bar": (c.t[some], bar[some])}
        for p in PHI_PARTS.values():
            out[p] = (c.t[some], mean_over_uavs(c.probes[p], present)[0][some])
        if self.plan is not None:
            plan = plan_steps(c.t, self.rec.dt, *self.plan)
            out["solve_time"] = (c.t[plan], np.where(present, c.probes["solve_time"], 0.0)[plan].sum(axis=1))
        return out


def _set_scalars(section: dict) -> dict:
    return {k: section.get(k) for k in ("phi_bar_final", "phi_bar_mean", "guarantee_violations", "empty_set_alarms",
                                        "time_unexplored_cleared")}


METRICS = (NETWORK, Metric("set_membership", _SetMembership, guaranteed, _set_scalars),
           Metric(SERIES, SetSeries, guaranteed))
FIGURES = (Figure("uncertainty.png", _FIGURES + "plot_uncertainty", guaranteed),
           Figure("uncertainty_per_uav.png", _FIGURES + "plot_uncertainty_per_uav", guaranteed),
           Figure("search_map.png", _FIGURES + "plot_search_map", guaranteed))
