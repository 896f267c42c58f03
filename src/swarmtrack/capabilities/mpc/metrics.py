"""What the analysis reads of the formation MPC's runs (W20 Ch. 5): the ``formation`` section (tracking error to
each UAV's slot, the solver's statistics, the bounds the MPC planned within and how far its model erred in flight)
with its warnings (solver fallbacks, collisions, a bound the vehicle cannot fly, a separation constraint softened, a
model error beyond the separation margin's), the time series ``tracking_error`` and the formation figures
(:mod:`.figures`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from swarmtrack.analysis.coverage import at_last_came, came
from swarmtrack.analysis.metrics import SERIES, min_separations, phase_groups
from swarmtrack.control.identification import NAMED_MODELS
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


def uav_model(ctrl: dict) -> tuple[np.ndarray, np.ndarray] | None:
    """``(A, B)`` of the controller spec's model (a name or ``{T, A, B}``), None when it has none."""
    model = ctrl.get("model")
    if isinstance(model, str):
        return (NAMED_MODELS[model].A, NAMED_MODELS[model].B) if model in NAMED_MODELS else None
    if isinstance(model, dict) and "A" in model and "B" in model:
        return np.asarray(model["A"], dtype=float), np.asarray(model["B"], dtype=float)
    return None


def slot_offsets(rec: Recording, truth: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(k, N, 2) each UAV's true position minus its formation slot (the target's true position plus the UAV's offset
    r_r, W20 eq. 5.22) at the steps of ``truth`` (k, objects, 4)."""
    return truth[:, rec.uav_slice, :2] - (truth[:, rec.tracked, None, :2] + offsets)


class _Formation:
    """W20 Ch. 5's tracking error (Tables 5.6, 5.8, 5.11, 5.12): each UAV's true distance to its formation place
    (the target's true position plus its offset r_r) from the MPC's start on, mean per UAV, per axis and (mean over
    the UAVs) per target phase; the MPC's solver statistics (cumulative probes: plans solved, fallbacks, wall time,
    OSQP iterations, plans whose separation constraint was softened and, of those, relaxed on the flown first
    step); the ``bounds`` it planned within (the recording's
    ``meta["mpc"]``, :meth:`~swarmtrack.capabilities.mpc.settings.MPCSpec.recording_meta`); and ``model_error``, the
    largest one-step error of its model in flight, ``|x(k+1) − A x(k) − B s(k)|`` on the true states and the setpoint
    held from step k (position m, velocity m/s, any UAV and axis, from the MPC's start on; None unless the recording's
    step is the MPC's period)."""

    def __init__(self, rec: Recording):
        n = rec.n_agents
        self.rec = rec
        self.offsets, self.start, ctrl = formation_spec(rec)
        self.sum, self.sum_axes, self.n = np.zeros(n), np.zeros((n, 2)), 0
        self.names, self.group = phase_groups(rec)
        self.phase_sum, self.phase_n = np.zeros(len(self.names)), np.zeros(len(self.names))
        self.last = {k: np.zeros(n) for k in ("solves", "fallbacks", "solve_time", "iterations")}
        for name in ("softened", "relaxed"):
            if name in rec.meta["probes"]:
                self.last[name] = np.zeros(n)
        self.closest = np.inf  # the smallest distance of any two UAVs at any step (for the collision warning)
        self.bounds = dict((rec.meta or {}).get("mpc") or {})
        period, dt = ctrl.get("period"), (rec.meta or {}).get("dt")
        self.model = uav_model(ctrl) if period and dt and abs(period - dt) < 1e-9 else None
        self.model_error = np.full(2, -np.inf)  # position, velocity
        self._before: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # the last step of the last chunk

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
        if self.model is not None and len(c.t) and "setpoint" in c.probes:
            self._add_model_error(c)

    def _add_model_error(self, c: Chunk) -> None:
        x, s, t = c.truth[:, self.rec.uav_slice, :4], c.probes["setpoint"], c.t
        if self._before is not None:
            x, s, t = (np.concatenate((a, b)) for a, b in zip(self._before, (x, s, t), strict=True))
        self._before = x[-1:], s[-1:], t[-1:]
        assert self.model is not None  # add() calls this only with a model
        A, B = self.model
        err = np.abs(x[:-1] @ A.T + s[:-1] @ B.T - x[1:])[t[:-1] >= self.start - 1e-9]  # (k, N, 4)
        for q, cols in enumerate((slice(0, 2), slice(2, 4))):
            part = err[..., cols]
            if np.isfinite(part).any():
                self.model_error[q] = max(self.model_error[q], float(np.nanmax(part)))

    def result(self) -> dict:
        n = max(self.n, 1)
        solves = self.last["solves"]
        done = np.maximum(solves, 1)
        flown = None if not np.isfinite(self.model_error).all() else {"position": float(self.model_error[0]),
                                                                       "velocity": float(self.model_error[1])}
        solver = {"solves": int(solves.sum()), "fallbacks": self.last["fallbacks"].astype(int).tolist(),
                  "mean_solve_us": float(1e6 * self.last["solve_time"].sum() / done.sum()),
                  "mean_iterations": float(self.last["iterations"].sum() / done.sum())}
        for name in ("softened", "relaxed"):
            if name in self.last:
                solver[name] = self.last[name].astype(int).tolist()
        return {"tracking_error": (self.sum / n).tolist(), "tracking_error_mean": float(self.sum.mean() / n),
                "tracking_error_xy": (self.sum_axes / n).tolist(),
                "tracking_error_by_phase": {name: float(self.phase_sum[k] / self.phase_n[k])
                                            for k, name in enumerate(self.names) if self.phase_n[k]},
                "solver": solver,
                "bounds": {k: v for k, v in self.bounds.items() if k != "warnings"} or None,
                "model_error": flown}


    def warnings(self) -> list[dict]:
        return _formation_warnings(self.result(), self.closest if self.rec.n_agents >= 2 else None,
                                   self.bounds.get("warnings") or [])


def _formation_warnings(formation: dict, min_distance: float | None, unflyable: Sequence[str] = ()) -> list[dict]:
    """A bound the vehicle cannot fly (``unflyable``: the messages validation made, naming the key and the limit),
    a plan that fell back (the QP was not solved), a plan whose separation constraint was softened, a model error in
    flight beyond what the separation margin assumes, and UAVs that came within :data:`COLLISION_M` of each other."""
    out: list[dict] = [{"kind": "unflyable_bound", "t_start": None, "t_end": None, "message": m} for m in unflyable]
    for i, k in enumerate(formation["solver"]["fallbacks"]):
        if k:
            out.append({"kind": "solver_fallback", "uav": i + 1, "t_start": None, "t_end": None,
                        "message": f"UAV {i + 1}'s MPC was not solved {k} time(s): it flew its last setpoint"})
    for i, k in enumerate(formation["solver"].get("relaxed", [])):
        if k:
            out.append({"kind": "separation_relaxed", "uav": i + 1, "t_start": None, "t_end": None,
                        "message": f"UAV {i + 1}'s plan could not meet its separation constraint on its first step "
                                   f"{k} time(s): it was softened (the separation is not guaranteed at those plans)"})
    bounds, flown = formation.get("bounds") or {}, formation.get("model_error")
    assumed = bounds.get("model_error") if bounds.get("separation") else None
    if assumed and flown and (flown["position"] > assumed[0] or flown["velocity"] > assumed[1]):
        out.append({"kind": "model_error_exceeded", "t_start": None, "t_end": None,
                    "message": f"the MPC's model erred by up to {flown['position']:.3g} m and {flown['velocity']:.3g} "
                               f"m/s in one period in flight, beyond controller.model_error = {assumed} (m, m/s) that "
                               "the separation constraint's margin assumes"})
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
