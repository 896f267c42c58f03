"""What the analysis reads of a Gaussian estimator's runs: the information filter's, its centralized baseline's,
the IMM bank's (this capability's) and the multi-model EKF's (:mod:`swarmtrack.capabilities.multi_model`), which all
record a point ``estimate`` of the followed target's ``[x, y, vx, vy, ...]`` with its ``covariance`` (and
``detected``, ``nis``). Each of those kinds registers :data:`METRICS`, :data:`HEALTH` and :data:`FIGURES`.

Sections of ``metrics.json`` (judged over the chase window, :func:`swarmtrack.analysis.metrics.chase_window`):
``rmse`` per phase and component (L24 Tables 1-3) with the run-wide ``position_rmse_per_uav``, ``spread`` (L23
Table 1), ``reported_std``, ``consistency`` (NEES and NIS per phase with their 95 % bands) with the run-wide ``nees``,
``mean_error`` (W20 eq. 4.41 and Table 4.5's occlusions), ``network`` (:class:`~swarmtrack.analysis.health.
NetworkHealth`: gating and late data) and the time series ``position_error`` and ``nees``.

Warnings (:class:`Health`, over every step, not only the chase window):

* **No detection**: a UAV that did not detect its target for at least :data:`GAP_S` seconds (or never did).
* **Inconsistent filter**: the NEES of ``[x, y, vx, vy]``, averaged over the UAVs and a sliding window of
  :data:`WINDOW_S` seconds, above :data:`FAR` times the upper end of its 95 % χ² band (a windowed average of
  ``n`` χ²(4) samples lies in ``χ²_{4n}(0.025, 0.975) / n`` when the filter is consistent).
* **Lost target**: the median estimation error over the UAVs above :data:`LOST_M` for at least :data:`GAP_S`.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.analysis.health import NETWORK, chi2_mean_band, spans
from swarmtrack.analysis.metrics import COMPONENTS, SERIES, Moments, phase_groups
from swarmtrack.registry import Figure, Metric
from swarmtrack.sim.recorder import Chunk, Recording

#: Shortest gap without a detection (and shortest loss) worth a warning, s.
GAP_S = 1.0
#: Window of the NEES consistency check, s.
WINDOW_S = 2.0
#: How far above its 95 % band the windowed NEES must be to be called inconsistent.
FAR = 3.0
#: How many UAVs without detections are named one by one.
LISTED = 10
#: Median position error over the UAVs beyond which the swarm has lost its target, m.
LOST_M = 5.0

_FIGURES = "swarmtrack.capabilities.tracking_swarm.figures:"


def applies(rec: Recording) -> bool:
    """The metrics need a followed target and a Gaussian estimate."""
    return rec.tracked is not None and {"estimate", "covariance"} <= set(rec.meta["probes"])


def follows(rec: Recording) -> bool:
    """The run's estimators follow one target (its estimate can be drawn)."""
    return rec.tracked is not None and "estimate" in rec.meta["probes"]


def _errors(rec: Recording, c: Chunk) -> np.ndarray:
    """(k, N, 4) estimate minus truth of the tracked target's [x, y, vx, vy]."""
    return c.probes["estimate"][..., :4] - c.truth[:, rec.tracked, None, :]


def chase_errors(rec: Recording, c: Chunk, keep: np.ndarray) -> np.ndarray:
    """(k', N, 4) the errors of the steps of ``c`` in the chase window ``keep``."""
    return _errors(rec, c)[keep]


class _Rmse:
    """Squared errors per phase, UAV and component (L24 Tables 1-3)."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.names, self.group = phase_groups(rec)
        self.sq = np.zeros((len(self.names) + 1, rec.n_agents, 4))
        self.count = np.zeros(len(self.names) + 1)

    def add(self, c: Chunk, keep: np.ndarray, err=None) -> None:
        err = chase_errors(self.rec, c, keep)
        e2 = err ** 2
        phase = self.group[c.phase[keep, self.rec.tracked]]
        for p in np.unique(phase):
            sel = phase == p
            self.sq[p] += e2[sel].sum(axis=0)
            self.count[p] += sel.sum()
        self.sq[-1] += e2.sum(axis=0)
        self.count[-1] += len(e2)

    def extras(self) -> dict:
        """``position_rmse_per_uav``: :meth:`per_uav_position`."""
        return {"position_rmse_per_uav": self.per_uav_position()}

    def per_uav_position(self) -> list[float]:
        """Each UAV's position RMSE over the whole judged run (m), e.g. to leave a faulty member out."""
        return np.sqrt(self.sq[-1, :, :2].sum(axis=-1) / max(self.count[-1], 1)).tolist()

    def result(self) -> dict[str, dict[str, float]]:
        table = {}
        for p, name in enumerate([*self.names, "total"]):
            if self.count[p]:
                per_uav = np.sqrt(self.sq[p] / self.count[p])  # (N, 4)
                table[name] = dict(zip(COMPONENTS, per_uav.mean(axis=0).tolist(), strict=True))
        return table


class _Spread:
    """Standard deviation over time of each UAV's error, mean over UAVs (L23 Table 1)."""

    def __init__(self, rec: Recording):
        self.rec, self.mom = rec, Moments()

    def add(self, c: Chunk, keep: np.ndarray, err=None) -> None:
        err = chase_errors(self.rec, c, keep)
        self.mom.add(err)

    def result(self) -> dict[str, float]:
        return dict(zip(COMPONENTS, self.mom.std.mean(axis=0).tolist(), strict=True))


class _ReportedStd:
    """The filters' own standard deviation ``sqrt(P_ii)``, mean over time and UAVs."""

    def __init__(self, rec: Recording):
        self.rec, self.total, self.n = rec, 0.0, 0

    def add(self, c: Chunk, keep: np.ndarray, err=None) -> None:
        cov = c.probes["covariance"][keep]
        self.total = self.total + np.sqrt(np.diagonal(cov[..., :4, :4], axis1=-2, axis2=-1)).sum(axis=(0, 1))
        self.n += cov.shape[0] * cov.shape[1]

    def result(self) -> dict[str, float]:
        return dict(zip(COMPONENTS, (self.total / self.n).tolist(), strict=True))


def nees_per_uav(err: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """(k, N) normalised estimation error squared ``eᵀ P⁻¹ e`` of errors (k, N, d) with covariances (k, N, d, d)."""
    return np.sum(err * np.linalg.solve(cov, err[..., None])[..., 0], axis=-1)


class _Consistency:
    """NEES of ``[x, y, vx, vy]`` and of each component per phase, and the NIS of each UAV's own measurement
    (2 dof), with the 95 % band of a consistent filter's average: ``χ²_{d·n}(0.025, 0.975) / n`` for n samples of
    dimension d. The band treats the samples
    as independent; successive steps are correlated, so it is narrower than the truth (a screening test)."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.names, self.group = phase_groups(rec)
        k = len(self.names) + 1
        self.full, self.comp, self.count = np.zeros(k), np.zeros((k, 4)), np.zeros(k)
        self.nis, self.nis_count = np.zeros(k), np.zeros(k)

    def add(self, c: Chunk, keep: np.ndarray, err=None) -> None:
        err = chase_errors(self.rec, c, keep)
        cov = c.probes["covariance"][keep][..., :4, :4]
        full = nees_per_uav(err, cov)  # (k, N)
        comp = err**2 / np.diagonal(cov, axis1=-2, axis2=-1)  # (k, N, 4)
        phase = self.group[c.phase[keep, self.rec.tracked]]
        for p in [*np.unique(phase), -1]:
            sel = phase == p if p >= 0 else slice(None)
            self.full[p] += full[sel].sum()
            self.comp[p] += comp[sel].sum(axis=(0, 1))
            self.count[p] += full[sel].size
            if "nis" in c.probes:  # each UAV's own measurement, where it had one
                nis = c.probes["nis"][keep][sel]
                self.nis[p] += np.nansum(nis)
                self.nis_count[p] += np.isfinite(nis).sum()

    def extras(self) -> dict:
        """``nees``: the run-wide figure (the total's), kept for comparison."""
        return {"nees": self.result()["total"]["nees"]}

    def result(self) -> dict:
        out = {}
        for p, name in enumerate([*self.names, "total"]):
            n = self.count[p]
            if n:
                out[name] = {"nees": self.full[p] / n, "band": chi2_mean_band(4, n),
                             "components": dict(zip(COMPONENTS, (self.comp[p] / n).tolist(), strict=True)),
                             "component_band": chi2_mean_band(1, n)}
                m = self.nis_count[p]
                if m:
                    out[name].update(nis=self.nis[p] / m, nis_band=chi2_mean_band(2, m))
        return out


class _MeanError:
    """W20 eq. 4.41 (with the truth it omits): the mean distance between each UAV's estimate and the target's
    position, mean over UAVs; also over the steps where no UAV detected the target (W20 Table 4.5's occlusions)."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.total, self.n, self.occluded, self.n_occluded, self.steps_occluded = 0.0, 0, 0.0, 0, 0

    def add(self, c: Chunk, keep: np.ndarray, err=None) -> None:
        err = chase_errors(self.rec, c, keep)
        dist = np.hypot(err[..., 0], err[..., 1])  # (k, N)
        self.total += float(dist.sum())
        self.n += dist.size
        if "detected" in c.probes:
            blind = ~(c.probes["detected"][keep] > 0).any(axis=1)
            self.occluded += float(dist[blind].sum())
            self.n_occluded += int(dist[blind].size)
            self.steps_occluded += int(blind.sum())

    def result(self) -> dict:
        return {"all": self.total / self.n if self.n else None,
                "occluded": self.occluded / self.n_occluded if self.n_occluded else None,
                "occluded_steps": self.steps_occluded}


class Health:
    """Accumulator of the per-step series the warnings need (O(steps) scalars plus the (steps, N) detection
    flags), fed chunk by chunk: :func:`swarmtrack.analysis.metrics.summary` feeds it in its own pass over the
    recording, :func:`check` on its own."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.t, self.nees, self.error, self.detected = [], [], [], []

    def add(self, c, keep=None, err=None) -> None:
        """Every step of chunk ``c`` (the warnings look at the whole run, not the chase window)."""
        err = c.probes["estimate"][..., :4] - c.truth[:, self.rec.tracked, None, :4]
        cov = c.probes["covariance"][..., :4, :4]
        with np.errstate(all="ignore"):
            sol = np.linalg.solve(cov, err[..., None])[..., 0]
        self.t.append(c.t)
        self.nees.append(np.sum(err * sol, axis=-1).mean(axis=1))
        self.error.append(np.median(np.linalg.norm(err[..., :2], axis=-1), axis=1))
        if "detected" in c.probes:
            self.detected.append(c.probes["detected"] > 0.5)

    def result(self) -> list[dict]:
        if not self.t:
            return []
        t, nees, error = np.concatenate(self.t), np.concatenate(self.nees), np.concatenate(self.error)
        warnings = []
        if self.detected:
            seen = np.concatenate(self.detected)  # (K, N): O(steps × N) booleans, one byte each
            if not seen.any():
                warnings.append({"kind": "never_detected", "message": "no UAV ever detected the target",
                                 "t_start": float(t[0]), "t_end": float(t[-1])})
            else:
                warnings += _gaps(seen, t)
        warnings += _inconsistent(self.rec, t, nees)
        for a, b in spans(~(error <= LOST_M), t, GAP_S):  # NaN errors count as lost
            warnings.append({"kind": "lost_target", "t_start": a, "t_end": b,
                             "message": f"the swarm lost the target at t = {a:.1f} s (median estimation error "
                                        f"above {LOST_M:g} m until t = {b:.1f} s)"})
        return warnings


def _gaps(seen: np.ndarray, t: np.ndarray) -> list[dict]:
    """``no_detection`` warnings for the UAVs with gaps of at least :data:`GAP_S` (the first :data:`LISTED` named,
    the rest counted in one more warning). Only UAVs missing that many steps in all are examined one by one."""
    dt = t[1] - t[0] if len(t) > 1 else 1.0
    suspects = np.flatnonzero((~seen).sum(axis=0) * dt >= GAP_S - 1e-9)
    out, named = [], 0
    for i in suspects:
        gaps = spans(~seen[:, i], t, GAP_S)
        if gaps and named == LISTED:
            out.append({"kind": "no_detection", "uav": None, "t_start": float(t[0]), "t_end": float(t[-1]),
                        "message": f"and up to {len(suspects) - LISTED} more UAVs had gaps of {GAP_S:g} s or more"})
            break
        named += bool(gaps)
        never = not seen[:, i].any()
        for a, b in gaps:
            out.append({"kind": "no_detection", "uav": int(i) + 1, "t_start": a, "t_end": b,
                        "message": f"UAV {i + 1} never detected the target" if never else
                        f"UAV {i + 1} had no detection of the target for {b - a:.1f} s (t = {a:.1f}-{b:.1f} s)"})
    return out


def _inconsistent(rec: Recording, t: np.ndarray, nees: np.ndarray) -> list[dict]:
    steps = max(1, int(round(WINDOW_S / rec.dt))) if rec.dt > 0 else 1
    if len(nees) < steps:
        return []
    windowed = np.convolve(nees, np.ones(steps) / steps, mode="valid")  # mean of the window ending at k
    samples = steps * rec.n_agents
    upper = chi2_mean_band(4, samples)[1]
    bad = ~(windowed <= FAR * upper)  # NaN (a diverged filter) is inconsistent too
    found = spans(bad, t[steps - 1:], 0.0)
    if not found:
        return []
    a, b = found[0]
    share = float(np.mean(bad))
    return [{"kind": "inconsistent", "t_start": a, "t_end": b,
             "message": f"the filters became inconsistent at t = {a:.1f} s: the {WINDOW_S:g} s NEES average "
                        f"exceeds {FAR:g}x its 95 % band ({upper:.2f} for 4) during {100 * share:.0f} % of the run "
                        f"(peak {np.nanmax(windowed):.3g})"}]


class GaussianSeries:
    """The time series of a Gaussian estimate, from t = 0 on: ``position_error``, the RMS over the UAVs of each
    UAV's estimated target position error, ``sqrt(mean_i |p̂_i − p|²)`` per step, and ``nees``, the NEES of
    ``[x, y, vx, vy]``, mean over the UAVs per step."""

    quantities = ("position_error", "nees")
    labels = {"position_error": "position error, RMS over UAVs [m]", "nees": "NEES [x, y, vx, vy], mean over UAVs"}

    def __init__(self, rec: Recording):
        self.rec = rec

    def values(self, c: Chunk) -> dict:
        e = _errors(self.rec, c)  # every step, not only the chase window
        return {"position_error": (c.t, np.sqrt(np.mean(e[..., 0] ** 2 + e[..., 1] ** 2, axis=1))),
                "nees": (c.t, nees_per_uav(e, c.probes["covariance"][..., :4, :4]).mean(axis=1))}


#: The sections a Gaussian estimator's runs get (and the network's, when they gate or fuse late data).
def _rmse_scalars(rmse: dict) -> dict:
    return {f"rmse_total_{c}": v for c, v in rmse.get("total", {}).items()}


def _nees_scalar(consistency: dict) -> dict:
    return {"nees": consistency.get("total", {}).get("nees")}


def _mean_error_scalars(mean_error: dict) -> dict:
    return {f"mean_error_{k}": mean_error.get(k) for k in ("all", "occluded")}


METRICS = (Metric("rmse", _Rmse, applies, _rmse_scalars, tuple(f"rmse_total_{c}" for c in COMPONENTS)),
           Metric("spread", _Spread, applies, lambda section: {}),
           Metric("reported_std", _ReportedStd, applies, lambda section: {}),
           Metric("consistency", _Consistency, applies, _nees_scalar, ("nees",)),
           Metric("mean_error", _MeanError, applies, _mean_error_scalars, ("mean_error_all",)), NETWORK,
           Metric(SERIES, GaussianSeries, applies))
#: The health checks of a Gaussian estimator's runs.
HEALTH = (Metric("warnings", Health, applies),)
#: The figures of a run whose estimators follow one target (drawn by :mod:`.figures`).
FIGURES = (Figure("estimates.png", _FIGURES + "plot_estimates", follows),
           Figure("errors.png", _FIGURES + "plot_errors", follows))
#: The IMM model probabilities' figure (the IMM bank's and the multi-model IMM kinds', drawn by
#: :func:`swarmtrack.capabilities.multi_model.figures.plot_model_probabilities`).
PROBABILITIES = Figure("model_probabilities.png",
                       "swarmtrack.capabilities.multi_model.figures:plot_model_probabilities",
                       lambda rec: "probability" in rec.meta["probes"])
