"""What the analysis reads of a multi-target tracker's runs (issue 40): each UAV's reported tracks (``tracks``,
``track_labels``) against every object its sensor can see (the targets and decoys), step by step.

Sections of ``metrics.json`` (over the judged window: after the estimator's ``settle_steps``; over the samples that
came, :class:`~swarmtrack.sim.recorder.Chunk`'s ``present``):

* ``gospa``: GOSPA (Rahmathullah, García-Fernández and Svensson 2017; :func:`swarmtrack.analysis.gospa.gospa`) with
  cut-off :data:`C` m, order :data:`P`, alpha :data:`ALPHA` (issue 40's benchmark), on the planar positions, and its
  split into localisation, missed and false parts, and OSPA with the same cut-off and order: each the mean over the
  judged steps of each UAV, then over the UAVs (``per_uav`` keeps each UAV's GOSPA), with the mean numbers of missed
  targets and false tracks, and ``position_rmse``, the RMS distance of the tracks GOSPA assigns to their objects
  (each UAV's, then the mean over the UAVs: a single-target filter's position RMSE when there is one object).
* ``continuity``: per UAV, summed over the objects, then the mean over the UAVs: ``label_switches`` (an object's
  assigned track, by GOSPA's assignment, carries another label than the last one assigned to it) and
  ``track_breaks`` (an object assigned a track at one judged step and none at the next).
* ``tracking``: the mean number of reported tracks and of objects, and what a UAV broadcast per step (mean and
  largest ``bytes_shared``).
* ``series``: ``gospa`` and its three parts, and ``ospa``, over time (the mean over the UAVs whose samples came).

Warnings: ``tracks_not_finite`` (a present sample reported a track whose state is not finite: a diverged filter) and
``targets_missed`` (for at least :data:`MISSED_S` s after settling, the UAVs missed more than half the objects on
average).
"""

from __future__ import annotations

import numpy as np

from swarmtrack.analysis.coverage import came
from swarmtrack.analysis.gospa import gospa, ospa
from swarmtrack.analysis.health import spans
from swarmtrack.analysis.metrics import SERIES
from swarmtrack.registry import Figure, Metric
from swarmtrack.sim.recorder import Chunk, Recording

#: GOSPA's cut-off (m), order and alpha: issue 40's benchmark (c = 10 m, p = 1, alpha = 2).
C = 10.0
P = 1.0
ALPHA = 2.0
#: The shortest stretch with most objects missed worth a warning, s.
MISSED_S = 5.0

_FIGURES = "swarmtrack.capabilities.multi_target.figures:"


def applies(rec: Recording) -> bool:
    """A run whose estimators report tracks."""
    return {"tracks", "track_labels"} <= set(rec.meta["probes"])


def objects(rec: Recording) -> np.ndarray:
    """The truth rows a multi-target tracker is judged against: the targets and the decoys."""
    groups = rec.meta["groups"]
    return np.concatenate([np.arange(*groups[g]) for g in ("targets", "decoys") if g in groups]).astype(np.int64)


def per_step(rec: Recording, c: Chunk, shared: dict | None = None) -> dict[str, np.ndarray]:
    """Each step and UAV of ``c``: ``gospa``, ``localisation``, ``missed``, ``false`` (the split), ``ospa``,
    ``n_missed``, ``n_false`` (k, N), NaN where the sample did not come; ``assigned`` (k, N, M) the label of the
    track assigned to each object (NaN: none). Computed once per chunk (kept in ``shared``)."""
    if shared is not None and "mtt.per_step" in shared:
        return shared["mtt.per_step"]
    rows = objects(rec)
    k, n = len(c.t), rec.n_agents
    names = ("gospa", "localisation", "missed", "false", "ospa", "n_missed", "n_false", "assigned_sq", "n_assigned")
    out = {name: np.full((k, n), np.nan) for name in names}
    out["assigned"] = np.full((k, n, len(rows)), np.nan)
    present = came(rec, c)
    tracks, labels = c.probes["tracks"], c.probes["track_labels"]
    for s in range(k):
        truth = c.truth[s, rows, :2]
        truth = truth[np.isfinite(truth).all(axis=1)]
        known = np.flatnonzero(np.isfinite(c.truth[s, rows, :2]).all(axis=1))
        for i in np.flatnonzero(present[s]):
            est = tracks[s, i][~np.isnan(labels[s, i])]
            lab = labels[s, i][~np.isnan(labels[s, i])]
            g = gospa(est[:, :2], truth, C, P, ALPHA)
            out["gospa"][s, i], out["localisation"][s, i] = g.distance, g.localisation
            out["missed"][s, i], out["false"][s, i] = g.missed, g.false
            out["n_missed"][s, i], out["n_false"][s, i] = g.n_missed, g.n_false
            out["ospa"][s, i] = ospa(est[:, :2], truth, C, P)
            hit = g.assignment >= 0
            out["assigned"][s, i, known[g.assignment[hit]]] = lab[hit]
            out["assigned_sq"][s, i] = ((est[hit, :2] - truth[g.assignment[hit]]) ** 2).sum()
            out["n_assigned"][s, i] = hit.sum()
    if shared is not None:
        shared["mtt.per_step"] = out
    return out


class _Gospa:
    """Sums over each UAV's judged steps of GOSPA, its split, OSPA and the counts."""

    keys = ("gospa", "localisation", "missed", "false", "ospa", "n_missed", "n_false", "assigned_sq", "n_assigned")

    def __init__(self, rec: Recording):
        self.rec = rec
        self.sums = {key: np.zeros(rec.n_agents) for key in self.keys}
        self.count = np.zeros(rec.n_agents)

    def add(self, c: Chunk, keep: np.ndarray, shared=None) -> None:
        if not keep.any():
            return
        v = per_step(self.rec, c, shared)
        m = ~np.isnan(v["gospa"][keep])
        for key in self.keys:
            self.sums[key] += np.where(m, v[key][keep], 0.0).sum(axis=0)
        self.count += m.sum(axis=0)

    def samples(self) -> int:
        """The judged samples the means cover (over the UAVs)."""
        return int(self.count.sum())

    def result(self) -> dict:
        some = self.count > 0
        if not some.any():
            return {"samples": 0}
        mean = {key: self.sums[key][some] / self.count[some] for key in self.keys[:-2]}
        out: dict = {key: float(v.mean()) for key, v in mean.items()}
        pairs = self.sums["n_assigned"][some]
        rmse = np.sqrt(self.sums["assigned_sq"][some] / np.maximum(pairs, 1))
        out["position_rmse"] = float(rmse[pairs > 0].mean()) if (pairs > 0).any() else None
        out["per_uav"] = [float(g) if k else None for g, k in
                          zip(np.where(some, self.sums["gospa"] / np.maximum(self.count, 1), np.nan), some,
                              strict=True)]
        out.update(cutoff=C, order=P, alpha=ALPHA, samples=int(self.count.sum()))
        return out


class _Continuity:
    """Label switches and track breaks per UAV (module docstring), over the judged steps in order."""

    def __init__(self, rec: Recording):
        self.rec = rec
        m = len(objects(rec))
        self.last = np.full((rec.n_agents, m), np.nan)  # the last label assigned to each object
        self.held = np.zeros((rec.n_agents, m), dtype=bool)  # assigned at the previous judged step
        self.switches = np.zeros(rec.n_agents)
        self.breaks = np.zeros(rec.n_agents)
        self.judged = np.zeros(rec.n_agents, dtype=bool)

    def add(self, c: Chunk, keep: np.ndarray, shared=None) -> None:
        if not keep.any():
            return
        v = per_step(self.rec, c, shared)
        for s in np.flatnonzero(keep):
            for i in np.flatnonzero(~np.isnan(v["gospa"][s])):
                a = v["assigned"][s, i]
                now = ~np.isnan(a)
                self.switches[i] += (now & ~np.isnan(self.last[i]) & (a != self.last[i])).sum()
                self.breaks[i] += (self.held[i] & ~now).sum()
                self.last[i] = np.where(now, a, self.last[i])
                self.held[i] = now
                self.judged[i] = True

    def result(self) -> dict:
        if not self.judged.any():
            return {}
        return {"label_switches": float(self.switches[self.judged].mean()),
                "track_breaks": float(self.breaks[self.judged].mean()),
                "label_switches_per_uav": [int(x) if j else None for x, j in
                                           zip(self.switches, self.judged, strict=True)]}


class _Tracking:
    """Reported tracks, objects and message sizes over the judged samples."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.tracks = self.objects = self.bytes = self.n = 0.0
        self.largest = 0.0

    def add(self, c: Chunk, keep: np.ndarray, shared=None) -> None:
        m = came(self.rec, c)[keep]
        self.tracks += c.probes["n_tracks"][keep][m].sum()
        rows = objects(self.rec)
        self.objects += (np.isfinite(c.truth[keep][:, rows, :2]).all(axis=-1).sum(axis=1)[:, None] * m).sum()
        b = c.probes["bytes_shared"][keep][m]
        self.bytes += b.sum()
        self.largest = max(self.largest, float(b.max())) if b.size else self.largest
        self.n += m.sum()

    def result(self) -> dict:
        if not self.n:
            return {}
        return {"tracks": self.tracks / self.n, "objects": self.objects / self.n,
                "bytes_per_uav_step": self.bytes / self.n, "bytes_per_uav_step_max": self.largest}


class Series:
    """GOSPA and its split, and OSPA, over time, from t = 0, the mean over the UAVs whose samples came."""

    quantities = ("gospa", "localisation", "missed", "false", "ospa")
    shares = True
    labels = {"gospa": f"GOSPA (c = {C:g} m, p = {P:g}, α = {ALPHA:g}), mean over UAVs [m]",
              "localisation": "GOSPA localisation part [m]", "missed": "GOSPA missed part [m]",
              "false": "GOSPA false part [m]", "ospa": f"OSPA (c = {C:g} m, p = {P:g}), mean over UAVs [m]"}

    def __init__(self, rec: Recording):
        self.rec = rec

    def values(self, c: Chunk, shared: dict | None = None) -> dict:
        v = per_step(self.rec, c, shared)
        some = ~np.isnan(v["gospa"]).all(axis=1)
        out = {}
        for q in self.quantities:
            with np.errstate(invalid="ignore"):
                out[q] = (c.t[some], np.nanmean(v[q][some], axis=1))
        return out


class Health:
    """``tracks_not_finite`` and ``targets_missed`` (module docstring)."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.t: list[np.ndarray] = []
        self.missed: list[np.ndarray] = []
        self.bad_at: float | None = None
        self.n_objects = len(objects(rec))

    def add(self, c: Chunk, keep: np.ndarray, shared=None) -> None:
        present = came(self.rec, c)
        labels, tracks = c.probes["track_labels"], c.probes["tracks"]
        bad = (~np.isnan(labels)[..., None] & ~np.isfinite(tracks)).any(axis=(2, 3)) & present
        if self.bad_at is None and bad.any():
            self.bad_at = float(c.t[np.flatnonzero(bad.any(axis=1))[0]])
        if keep.any():
            v = per_step(self.rec, c, shared)
            with np.errstate(invalid="ignore"):
                self.missed.append(np.nanmean(v["n_missed"][keep], axis=1))
            self.t.append(c.t[keep])

    def result(self) -> list[dict]:
        out = []
        if self.bad_at is not None:
            out.append({"kind": "tracks_not_finite", "t_start": self.bad_at,
                        "message": f"a UAV reported a track whose state is not finite at t = {self.bad_at:.1f} s "
                                   "(its tracker diverged)"})
        if self.t and self.n_objects:
            t, missed = np.concatenate(self.t), np.concatenate(self.missed)
            for a, b in spans(missed > 0.5 * self.n_objects, t, MISSED_S):
                out.append({"kind": "targets_missed", "t_start": a, "t_end": b,
                            "message": f"the UAVs missed more than half the {self.n_objects} objects on average from "
                                       f"t = {a:.1f} s to {b:.1f} s"})
        return out


def _gospa_scalars(section: dict) -> dict:
    return {f"gospa_{k}" if k != "gospa" else "gospa": section.get(k)
            for k in ("gospa", "localisation", "missed", "false", "ospa", "n_missed", "n_false")}


METRICS = (Metric("gospa", _Gospa, applies, _gospa_scalars, ("gospa", "gospa_ospa")),
           Metric("continuity", _Continuity, applies),
           Metric("tracking", _Tracking, applies),
           Metric(SERIES, Series, applies))
HEALTH = (Metric("warnings", Health, applies),)
FIGURES = (Figure("tracks.png", _FIGURES + "plot_tracks", applies),
           Figure("gospa.png", _FIGURES + "plot_gospa", applies))
