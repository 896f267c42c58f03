"""What the analysis reads of a Gaussian estimator's runs: the information filter's, its centralized baseline's,
the IMM bank's (this capability's) and the multi-model EKF's (:mod:`swarmtrack.capabilities.multi_model`), which all
record a point ``estimate`` of the followed target's ``[x, y, vx, vy, ...]`` with its ``covariance`` (and
``detected``, ``nis``). Each of those kinds registers :data:`METRICS`, :data:`HEALTH` and :data:`FIGURES`.

Sections of ``metrics.json`` (judged over the chase window, :func:`swarmtrack.analysis.metrics.chase_window`):
``rmse`` per phase and component (L24 Tables 1-3) with the run-wide ``position_rmse_per_uav``, ``spread`` (L23
Table 1), ``reported_std``, ``consistency`` (NEES and NIS per phase with their 95 % bands) with the run-wide ``nees``,
``mean_error`` (W20 eq. 4.41 and Table 4.5's occlusions), ``altitude`` (a 3-D run's z and vz RMSE and the NEES of
``[x, y, vx, vy, z, vz]``, docs/three-d.md), ``network`` (:class:`~swarmtrack.analysis.health.
NetworkHealth`: gating and late data) and the time series ``position_error`` and ``nees``.

Every section is over the judged samples (:func:`swarmtrack.analysis.coverage.judged`: the UAV's sample came and
the target's truth is known), per UAV then averaged over the UAVs that have any, and says how many it covers
(``samples``; the RMSE's in ``rmse_samples``). A judged sample whose estimate is NaN or infinite (a diverged filter)
makes its sections NaN or infinite.

Warnings (:class:`Health`, over every step, not only the chase window; each UAV's samples from its filter's first
finite estimate on):

* **No detection**: a UAV that did not detect its target for at least :data:`GAP_S` seconds (or never did).
* **Inconsistent filter**: the NEES of ``[x, y, vx, vy]``, averaged over the UAVs and a sliding window of
  :data:`WINDOW_S` seconds, above :data:`FAR` times the upper end of its 95 % χ² band (a windowed average of
  ``n`` χ²(4) samples lies in ``χ²_{4n}(0.025, 0.975) / n`` when the filter is consistent).
* **Lost target**: the median estimation error over the UAVs above :data:`LOST_M` for at least :data:`GAP_S`.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.analysis.coverage import came, judged, masked, mean_over_uavs
from swarmtrack.analysis.health import NETWORK, chi2_mean_band, spans
from swarmtrack.analysis.metrics import COMPONENTS, SERIES, Moments, phase_groups
from swarmtrack.analysis.nees import nees_per_uav
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


def _shared(shared: dict | None, key: str, compute):
    """``compute()``, kept in ``shared`` (the scan's dict for the chunk, None: not kept) so that the accumulators
    that need it compute it once per chunk."""
    if shared is None:
        return compute()
    if key not in shared:
        shared[key] = compute()
    return shared[key]


def _errors(rec: Recording, c: Chunk, shared: dict | None = None) -> np.ndarray:
    """(k, N, 4) estimate minus truth of the tracked target's [x, y, vx, vy]."""
    return _shared(shared, "gaussian.errors", lambda: c.probes["estimate"][..., :4] - c.truth[:, rec.tracked, None, :])


def _nees(rec: Recording, c: Chunk, shared: dict | None = None) -> np.ndarray:
    """(k, N) NEES of [x, y, vx, vy] of every step and UAV (:func:`nees_per_uav`)."""
    return _shared(shared, "gaussian.nees",
                   lambda: nees_per_uav(_errors(rec, c, shared), c.probes["covariance"][..., :4, :4]))


def _position_sq(rec: Recording, c: Chunk, shared: dict | None = None) -> np.ndarray:
    """(k, N) squared distance of each UAV's estimated target position from the truth, ``ex² + ey²`` (the square
    of ``np.linalg.norm(err[..., :2], axis=-1)``, bit for bit)."""
    def compute():
        e = _errors(rec, c, shared)
        return e[..., 0] ** 2 + e[..., 1] ** 2

    return _shared(shared, "gaussian.position_sq", compute)


def _kept(x: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """The rows ``keep`` of ``x`` (``x`` itself, not a copy, when all are kept)."""
    return x if keep.all() else x[keep]


def chase_errors(rec: Recording, c: Chunk, keep: np.ndarray, shared: dict | None = None) -> np.ndarray:
    """(k', N, 4) the errors of the steps of ``c`` in the chase window ``keep``."""
    return _kept(_errors(rec, c, shared), keep)


class _Rmse:
    """Squared errors per phase, UAV and component (L24 Tables 1-3)."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.names, self.group = phase_groups(rec)
        self.sq = np.zeros((len(self.names) + 1, rec.n_agents, 4))
        self.count = np.zeros((len(self.names) + 1, rec.n_agents))  # judged samples per phase and UAV

    def add(self, c: Chunk, keep: np.ndarray, shared=None) -> None:
        m = _kept(judged(self.rec, c, shared), keep)
        e2 = masked(chase_errors(self.rec, c, keep, shared) ** 2, m)
        phase = self.group[c.phase[keep, self.rec.tracked]]
        for p in np.unique(phase):
            sel = phase == p
            self.sq[p] += _kept(e2, sel).sum(axis=0)
            self.count[p] += _kept(m, sel).sum(axis=0)
        self.sq[-1] += e2.sum(axis=0)
        self.count[-1] += m.sum(axis=0)

    def extras(self) -> dict:
        """``position_rmse_per_uav``: :meth:`per_uav_position`."""
        return {"position_rmse_per_uav": self.per_uav_position()}

    def samples(self) -> int:
        """The judged samples the total covers (over the UAVs)."""
        return int(self.count[-1].sum())

    def per_uav_position(self) -> list[float | None]:
        """Each UAV's position RMSE over its judged samples of the judged window (m; None: it has none), e.g. to
        leave a faulty member out."""
        n = self.count[-1]
        rmse = np.sqrt(self.sq[-1, :, :2].sum(axis=-1) / np.maximum(n, 1))
        return [float(v) if k else None for v, k in zip(rmse, n, strict=True)]

    def result(self) -> dict[str, dict[str, float]]:
        table = {}
        for p, name in enumerate([*self.names, "total"]):
            some = self.count[p] > 0  # the UAVs with samples in this phase
            if some.any():
                per_uav = np.sqrt(self.sq[p][some] / self.count[p][some, None])  # (N', 4)
                table[name] = dict(zip(COMPONENTS, per_uav.mean(axis=0).tolist(), strict=True))
        return table


class _Spread:
    """Standard deviation over time of each UAV's error, mean over UAVs (L23 Table 1)."""

    def __init__(self, rec: Recording):
        self.rec, self.mom = rec, Moments()

    def add(self, c: Chunk, keep: np.ndarray, shared=None) -> None:
        self.mom.add(chase_errors(self.rec, c, keep, shared), _kept(judged(self.rec, c, shared), keep))

    def result(self) -> dict[str, float]:
        n = np.broadcast_to(np.asarray(self.mom.n, dtype=float), (self.rec.n_agents, 4))[:, 0]
        std = np.broadcast_to(self.mom.std, (self.rec.n_agents, 4))[n > 0]  # the UAVs with samples
        return dict(zip(COMPONENTS, std.mean(axis=0).tolist() if len(std) else [None] * 4, strict=True))

    def samples(self) -> int:
        return int(np.broadcast_to(np.asarray(self.mom.n), (self.rec.n_agents, 4))[:, 0].sum())


class _ReportedStd:
    """The filters' own standard deviation ``sqrt(P_ii)``, mean over time and UAVs."""

    def __init__(self, rec: Recording):
        self.rec, self.total, self.n = rec, 0.0, 0

    def add(self, c: Chunk, keep: np.ndarray, shared=None) -> None:
        m = _kept(came(self.rec, c), keep)  # the filters' own figure: no truth needed
        cov = _kept(c.probes["covariance"], keep)
        std = masked(np.sqrt(np.diagonal(cov[..., :4, :4], axis1=-2, axis2=-1)), m)
        self.total = self.total + std.sum(axis=(0, 1))
        self.n += int(m.sum())

    def result(self) -> dict[str, float]:
        return dict(zip(COMPONENTS, (self.total / self.n).tolist() if self.n else [None] * 4, strict=True))

    def samples(self) -> int:
        return self.n


def _nees_mean(rec: Recording, c: Chunk, shared: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(k,) NEES of every step, mean over the judged UAVs, and (k,) the steps with any."""
    return _shared(shared, "gaussian.nees_mean", lambda: mean_over_uavs(_nees(rec, c, shared), judged(rec, c, shared)))


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

    def add(self, c: Chunk, keep: np.ndarray, shared=None) -> None:
        m = _kept(judged(self.rec, c, shared), keep)
        err = chase_errors(self.rec, c, keep, shared)
        cov = _kept(c.probes["covariance"], keep)[..., :4, :4]
        full = masked(_kept(_nees(self.rec, c, shared), keep), m)  # (k, N)
        comp = masked(err**2 / np.diagonal(cov, axis1=-2, axis2=-1), m)  # (k, N, 4)
        nis_all = None
        if "nis" in c.probes:  # each UAV's own measurement, where it had one (NaN: none), where its sample came
            nis_all = _kept(c.probes["nis"], keep)
            nis_all = np.where(_kept(came(self.rec, c), keep), nis_all, np.nan)
        phase = self.group[c.phase[keep, self.rec.tracked]]
        for p in [*np.unique(phase), -1]:
            sel = phase == p if p >= 0 else np.ones(len(phase), dtype=bool)
            self.full[p] += _kept(full, sel).sum()
            self.comp[p] += _kept(comp, sel).sum(axis=(0, 1))
            self.count[p] += int(_kept(m, sel).sum())
            if nis_all is not None:
                nis = _kept(nis_all, sel)
                self.nis[p] += np.nansum(nis)
                self.nis_count[p] += np.isfinite(nis).sum()

    def samples(self) -> int:
        return int(self.count[-1])

    def extras(self) -> dict:
        """``nees``: the run-wide figure (the total's), kept for comparison."""
        return {"nees": self.result().get("total", {}).get("nees")}

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


def three_d(rec: Recording) -> bool:
    """A 3-D run (the world's altitude recorded) whose estimate holds ``[x, y, vx, vy, z, vz]`` (3-D models)."""
    return applies(rec) and bool(rec.meta.get("altitude")) and rec.meta["probes"]["estimate"][0] >= 6


class _Altitude:
    """A 3-D run's altitude (docs/three-d.md): per phase, the RMSE of ``z`` and ``vz`` (mean over UAVs, as
    :class:`_Rmse`) and the NEES of the common block ``[x, y, vx, vy, z, vz]`` with its 95 % band (6 dof)."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.names, self.group = phase_groups(rec)
        k = len(self.names) + 1
        self.sq, self.count = np.zeros((k, rec.n_agents, 2)), np.zeros((k, rec.n_agents))
        self.nees, self.nees_count = np.zeros(k), np.zeros(k)

    def add(self, c: Chunk, keep: np.ndarray, shared=None) -> None:
        tracked = self.rec.tracked
        m = judged(self.rec, c)[keep]
        truth = np.concatenate([c.truth[keep, tracked], c.altitude[keep, tracked]], axis=-1)  # (k, 6)
        err = c.probes["estimate"][keep][..., :6] - truth[:, None, :]  # (k, N, 6)
        nees = masked(nees_per_uav(err, c.probes["covariance"][keep][..., :6, :6]), m)
        sq = masked(err[..., 4:6] ** 2, m)
        phase = self.group[c.phase[keep, tracked]]
        for p in [*np.unique(phase), -1]:
            sel = phase == p if p >= 0 else np.ones(len(phase), dtype=bool)
            self.sq[p] += sq[sel].sum(axis=0)
            self.count[p] += m[sel].sum(axis=0)
            self.nees[p] += nees[sel].sum()
            self.nees_count[p] += int(m[sel].sum())

    def samples(self) -> int:
        return int(self.nees_count[-1])

    def result(self) -> dict:
        out = {}
        for p, name in enumerate([*self.names, "total"]):
            some = self.count[p] > 0
            if some.any():
                z, vz = np.sqrt(self.sq[p][some] / self.count[p][some, None]).mean(axis=0)
                n = self.nees_count[p]
                out[name] = {"z": float(z), "vz": float(vz), "nees": self.nees[p] / n, "band": chi2_mean_band(6, n)}
        return out


def _altitude_scalars(altitude: dict) -> dict:
    total = altitude.get("total", {})
    return {"altitude_rmse_z": total.get("z"), "altitude_rmse_vz": total.get("vz"), "nees_3d": total.get("nees")}


class _MeanError:
    """W20 eq. 4.41 (with the truth it omits): the mean distance between each UAV's estimate and the target's
    position, mean over UAVs; also over the steps where no UAV detected the target (W20 Table 4.5's occlusions)."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.total, self.n, self.occluded, self.n_occluded, self.steps_occluded = 0.0, 0, 0.0, 0, 0

    def add(self, c: Chunk, keep: np.ndarray, shared=None) -> None:
        m = _kept(judged(self.rec, c, shared), keep)
        err = chase_errors(self.rec, c, keep, shared)
        dist = masked(np.hypot(err[..., 0], err[..., 1]), m)  # (k, N)
        self.total += float(dist.sum())
        self.n += int(m.sum())
        if "detected" in c.probes:
            seen = (c.probes["detected"][keep] > 0) & _kept(came(self.rec, c), keep)
            blind = ~seen.any(axis=1) & m.any(axis=1)  # steps judged where no UAV whose sample came detected it
            self.occluded += float(dist[blind].sum())
            self.n_occluded += int(m[blind].sum())
            self.steps_occluded += int(blind.sum())

    def result(self) -> dict:
        return {"all": self.total / self.n if self.n else None,
                "occluded": self.occluded / self.n_occluded if self.n_occluded else None,
                "occluded_steps": self.steps_occluded}

    def samples(self) -> int:
        return self.n


class Health:
    """Accumulator of the per-step series the warnings need (O(steps) scalars plus the (steps, N) detection
    flags), fed chunk by chunk: :func:`swarmtrack.analysis.metrics.summary` feeds it in its own pass over the
    recording, :func:`check` on its own.

    A UAV's samples are judged from its filter's first finite estimate on (the NEES of its first judged sample
    that has one): before it, a filter that has not detected anything has no estimate to judge. After it, a judged
    sample whose NEES or error is not finite is a diverged filter: inconsistent and lost. Steps where no sample is
    judged (every UAV absent, or no truth) count as neither consistent nor inconsistent, found nor lost."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.t, self.nees_sum, self.nees_n, self.error, self.detected = [], [], [], [], []
        self.started = np.zeros(rec.n_agents, dtype=bool)  # each UAV's filter has had a finite estimate

    def add(self, c, keep=None, shared=None) -> None:
        """Every step of chunk ``c`` (the warnings look at the whole run, not the chase window)."""
        m = judged(self.rec, c, shared)
        nees = _nees(self.rec, c, shared)
        started = self.started[None] | np.logical_or.accumulate(m & np.isfinite(nees), axis=0)
        if len(started):
            self.started = started[-1]
        use = m & started
        self.t.append(c.t)
        self.nees_sum.append(masked(np.where(np.isfinite(nees), nees, np.inf), use).sum(axis=1))
        self.nees_n.append(use.sum(axis=1))
        error = np.sqrt(_position_sq(self.rec, c, shared))
        if use.all():
            median = np.median(error, axis=1)
        else:  # the median over the judged UAVs; NaN (not judged) where there is none
            some = use.any(axis=1)
            median = np.full(len(c.t), np.nan)
            if some.any():
                rows = np.where(use, np.where(np.isnan(error), np.inf, error), np.nan)[some]
                median[some] = np.nanmedian(rows, axis=1)
        self.error.append(median)
        if "detected" in c.probes:  # a sample that did not come is no gap in the detections
            self.detected.append((c.probes["detected"] > 0.5) | ~came(self.rec, c))

    def result(self) -> list[dict]:
        if not self.t:
            return []
        t, error = np.concatenate(self.t), np.concatenate(self.error)
        warnings = []
        if self.detected:
            seen = np.concatenate(self.detected)  # (K, N): O(steps × N) booleans, one byte each
            if not seen.any():
                warnings.append({"kind": "never_detected", "message": "no UAV ever detected the target",
                                 "t_start": float(t[0]), "t_end": float(t[-1])})
            else:
                warnings += _gaps(seen, t)
        warnings += _inconsistent(self.rec, t, np.concatenate(self.nees_sum), np.concatenate(self.nees_n))
        for a, b in spans(error > LOST_M, t, GAP_S):  # a diverged filter's error is infinite: lost
            warnings.append({"kind": "lost_target", "t_start": a, "t_end": b,
                             "message": f"the swarm lost the target at t = {a:.1f} s (median estimation error over "
                                        f"the UAVs whose samples came above {LOST_M:g} m until t = {b:.1f} s)"})
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


def _inconsistent(rec: Recording, t: np.ndarray, total: np.ndarray, count: np.ndarray) -> list[dict]:
    """The ``inconsistent`` warning: the NEES averaged over the judged samples of a sliding window of
    :data:`WINDOW_S` s (``total`` and ``count`` per step: the sum of the judged UAVs' NEES and their number) above
    :data:`FAR` times the upper end of the 95 % band of that many samples. Windows without samples are not judged;
    an infinite sum (a diverged filter) is inconsistent."""
    steps = max(1, int(round(WINDOW_S / rec.dt))) if rec.dt > 0 else 1
    if len(total) < steps:
        return []
    ones = np.ones(steps)
    n = np.convolve(count.astype(float), ones, mode="valid")  # samples of the window ending at k
    some = n > 0
    if not some.any():
        return []
    with np.errstate(invalid="ignore"):  # inf - inf in the running sum: still a diverged window
        summed = np.convolve(np.where(np.isinf(total), 0.0, total), ones, mode="valid")
    diverged = np.convolve(np.isinf(total).astype(float), ones, mode="valid") > 0
    windowed = np.where(diverged, np.inf, np.divide(summed, n, out=np.zeros_like(summed), where=some))
    upper = np.full(len(n), np.inf)
    upper[some] = chi2_mean_band(4, n[some])[1]
    bad = some & ~(windowed <= FAR * upper)
    found = spans(bad, t[steps - 1:], 0.0)
    if not found:
        return []
    a, b = found[0]
    share = float(bad.sum() / some.sum())
    full = chi2_mean_band(4, steps * rec.n_agents)[1]
    peak = float(windowed[bad].max())
    return [{"kind": "inconsistent", "t_start": a, "t_end": b,
             "message": f"the filters became inconsistent at t = {a:.1f} s: the {WINDOW_S:g} s NEES average "
                        f"exceeds {FAR:g}x its 95 % band ({full:.2f} for 4 with every UAV's samples) during "
                        f"{100 * share:.0f} % of the windows judged (peak {peak:.3g}"
                        + (": a filter diverged)" if np.isinf(peak) else ")")}]


class GaussianSeries:
    """The time series of a Gaussian estimate, from t = 0 on: ``position_error``, the RMS over the UAVs of each
    UAV's estimated target position error, ``sqrt(mean_i |p̂_i − p|²)`` per step, and ``nees``, the NEES of
    ``[x, y, vx, vy]``, mean over the UAVs per step; both over the judged samples (a step with none has none)."""

    quantities = ("position_error", "nees")
    shares = True  # values(chunk, shared): the errors and NEES computed once per chunk with the accumulators
    labels = {"position_error": "position error, RMS over UAVs [m]", "nees": "NEES [x, y, vx, vy], mean over UAVs"}

    def __init__(self, rec: Recording):
        self.rec = rec

    def values(self, c: Chunk, shared: dict | None = None) -> dict:
        # every step, not only the chase window; the steps with a judged sample, the mean over their judged UAVs
        error, some = mean_over_uavs(_position_sq(self.rec, c, shared), judged(self.rec, c, shared))
        nees, _ = _nees_mean(self.rec, c, shared)
        return {"position_error": (c.t[some], np.sqrt(error[some])), "nees": (c.t[some], nees[some])}


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
           Metric("mean_error", _MeanError, applies, _mean_error_scalars, ("mean_error_all",)),
           Metric("altitude", _Altitude, three_d, _altitude_scalars, ("altitude_rmse_z",)), NETWORK,
           Metric(SERIES, GaussianSeries, applies))
#: The health checks of a Gaussian estimator's runs.
HEALTH = (Metric("warnings", Health, applies),)
#: The figures of a run whose estimators follow one target (drawn by :mod:`.figures`).
FIGURES = (Figure("estimates.png", _FIGURES + "plot_estimates", follows),
           Figure("errors.png", _FIGURES + "plot_errors", follows),
           Figure("altitude.png", _FIGURES + "plot_altitude", three_d))
#: The IMM model probabilities' figure (the IMM bank's and the multi-model IMM kinds', drawn by
#: :func:`swarmtrack.capabilities.multi_model.figures.plot_model_probabilities`).
PROBABILITIES = Figure("model_probabilities.png",
                       "swarmtrack.capabilities.multi_model.figures:plot_model_probabilities",
                       lambda rec: "probability" in rec.meta["probes"])
#: The IMM's figures: the estimates', and its models' probabilities.
IMM_FIGURES = (*FIGURES, PROBABILITIES)
