"""What the analysis reads of the formation MPC's runs (W20 Ch. 5): the ``formation`` section (tracking error to
each UAV's slot and the solver's statistics) with its warnings (solver fallbacks, collisions), the time series
``tracking_error`` and the formation figures (:mod:`.figures`)."""

from __future__ import annotations

import numpy as np

from swarmtrack.analysis.coverage import at_last_came, came
from swarmtrack.analysis.metrics import SERIES, min_separations, phase_groups
from swarmtrack.registry import Figure, Metric
from swarmtrack.sim.recorder import Chunk, Recording

#: Two UAVs closer than this (m) have collided: an Iris-sized quadrotor spans about 0.55 m.
COLLISION_M = 0.5

_FIGURES = "swarmtrack.capabilities.mpc.figures:"


def applies(rec: Recording) -> bool:
    """The formation metrics need a followed target (the slots move with it) and the MPC's ``setpoint``."""
    return rec.tracked is not None and "setpoint" in rec.meta["probes"]


def _planned(rec: Recording) -> bool:
    """The figures draw the MPC's ``setpoint`` and the formation's slots around the followed target (a run of an
    estimator that follows none, a multi-target tracker's, has no slots to draw)."""
    return applies(rec)


def _pairs(rec: Recording) -> bool:
    return _planned(rec) and rec.n_agents >= 2


def formation_spec(rec: Recording) -> tuple[np.ndarray, float, dict]:
    """``(offsets (N, 2), MPC start s, controller spec)`` from ``meta["controller"]`` (zero offsets, start 0 if
    absent)."""
    ctrl = (rec.meta or {}).get("controller") or {}
    offsets = ctrl.get("offsets") or [(0.0, 0.0)] * rec.n_agents
    return np.asarray(offsets, dtype=float).reshape(rec.n_agents, 2), float(ctrl.get("start") or 0.0), ctrl


def slot_offsets(rec: Recording, truth: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(k, N, 2) each UAV's true position minus its formation slot (the target's true position plus the UAV's offset
    r_r, W20 eq. 5.22) at the steps of ``truth`` (k, objects, 4)."""
    return truth[:, rec.uav_slice, :2] - (truth[:, rec.tracked, None, :2] + offsets)


class _Formation:
    """W20 Ch. 5's tracking error (Tables 5.6, 5.8, 5.11, 5.12): each UAV's true distance to its formation place
    (the target's true position plus its offset r_r) from the MPC's start on, mean per UAV, per axis and (mean over
    the UAVs) per target phase; and the
    MPC's solver statistics (cumulative probes: plans solved, fallbacks, wall time, OSQP iterations)."""

    def __init__(self, rec: Recording):
        n = rec.n_agents
        self.rec = rec
        self.offsets, self.start, _ = formation_spec(rec)
        self.sum, self.sum_axes, self.n = np.zeros(n), np.zeros((n, 2)), 0
        self.names, self.group = phase_groups(rec)
        self.phase_sum, self.phase_n = np.zeros(len(self.names)), np.zeros(len(self.names))
        self.last = {k: np.zeros(n) for k in ("solves", "fallbacks", "solve_time", "iterations")}
        self.closest = np.inf  # the smallest distance of any two UAVs at any step (for the collision warning)

    def add(self, c: Chunk, keep, err) -> None:
        if len(c.t) and self.rec.n_agents >= 2:
            self.closest = min(self.closest, float(min_separations(c.truth[:, self.rec.uav_slice, :2]).min()))
        after = c.t >= self.start - 1e-9
        off = slot_offsets(self.rec, c.truth[after], self.offsets)  # (k, N, 2)
        dist = np.linalg.norm(off, axis=-1)
        self.sum += dist.sum(axis=0)
        self.sum_axes += np.abs(off).sum(axis=0)
        self.n += int(after.sum())
        if self.names:  # a target without profile phases (a walker) has no per-phase rows
            phase = self.group[c.phase[after, self.rec.tracked]]
            np.add.at(self.phase_sum, phase, dist.mean(axis=1))
            np.add.at(self.phase_n, phase, 1)
        if len(c.t):  # the cumulative solver probes at each UAV's last sample that came
            for k, before in self.last.items():
                self.last[k] = at_last_came(came(self.rec, c), c.probes[k], before)

    def result(self) -> dict:
        n = max(self.n, 1)
        solves = self.last["solves"]
        done = np.maximum(solves, 1)
        return {"tracking_error": (self.sum / n).tolist(), "tracking_error_mean": float(self.sum.mean() / n),
                "tracking_error_xy": (self.sum_axes / n).tolist(),
                "tracking_error_by_phase": {name: float(self.phase_sum[k] / self.phase_n[k])
                                            for k, name in enumerate(self.names) if self.phase_n[k]},
                "solver": {"solves": int(solves.sum()), "fallbacks": self.last["fallbacks"].astype(int).tolist(),
                           "mean_solve_us": float(1e6 * self.last["solve_time"].sum() / done.sum()),
                           "mean_iterations": float(self.last["iterations"].sum() / done.sum())}}


    def warnings(self) -> list[dict]:
        return _formation_warnings(self.result(), self.closest if self.rec.n_agents >= 2 else None)


def _formation_warnings(formation: dict, min_distance: float | None) -> list[dict]:
    """A plan that fell back (the QP was not solved) and UAVs that came within :data:`COLLISION_M` of each other."""
    out = []
    for i, k in enumerate(formation["solver"]["fallbacks"]):
        if k:
            out.append({"kind": "solver_fallback", "uav": i + 1, "t_start": None, "t_end": None,
                        "message": f"UAV {i + 1}'s MPC was not solved {k} time(s): it flew its last setpoint"})
    if min_distance is not None and min_distance < COLLISION_M:
        out.append({"kind": "collision", "t_start": None, "t_end": None,
                    "message": f"two UAVs came {min_distance:.2f} m apart (below {COLLISION_M:g} m: a collision)"})
    return out


class FormationSeries:
    """The time series ``tracking_error``: each UAV's true distance to its formation slot, mean over the UAVs per
    step, from the MPC's start on (W20 Ch. 5's tracking error over time)."""

    quantities = ("tracking_error",)
    labels = {"tracking_error": "distance to formation slot, mean over UAVs [m]"}

    def __init__(self, rec: Recording):
        self.rec = rec
        self.offsets, self.start, _ = formation_spec(rec)

    def values(self, c: Chunk) -> dict:
        after = c.t >= self.start - 1e-9
        dist = np.linalg.norm(slot_offsets(self.rec, c.truth[after], self.offsets), axis=-1)  # (k, N)
        return {"tracking_error": (c.t[after], dist.mean(axis=1))}


METRICS = (Metric("formation", _Formation, applies, lambda section: {}), Metric(SERIES, FormationSeries, applies))
FIGURES = (Figure("formation_paths.png", _FIGURES + "plot_formation_paths", _planned),
           Figure("formation_xy.png", _FIGURES + "plot_formation_xy_time", _planned),
           Figure("slot_distances.png", _FIGURES + "plot_slot_distance", _planned),
           Figure("mpc_inputs.png", _FIGURES + "plot_mpc_inputs", _planned),
           Figure("min_separation.png", _FIGURES + "plot_min_separation", _pairs))
