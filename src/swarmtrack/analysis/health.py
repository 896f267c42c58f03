"""Is a run a success? Warnings for what a table of averages hides (truth side: reads the recording).

* **No detection**: a UAV that did not detect its target for at least :data:`GAP_S` seconds (or never did).
* **Inconsistent filter**: the NEES of ``[x, y, vx, vy]``, averaged over the UAVs and a sliding window of
  :data:`WINDOW_S` seconds, above :data:`FAR` times the upper end of its 95 % χ² band (a windowed average of
  ``n`` χ²(4) samples lies in ``χ²_{4n}(0.025, 0.975) / n`` when the filter is consistent).
* **Lost target**: the median estimation error over the UAVs above :data:`LOST_M` for at least :data:`GAP_S`.

For a guaranteed (set-membership) run, which records ``phi`` instead of a Gaussian estimate (:class:`SetHealth`):

* **Guarantee violated**: a check of the truth-side monitor ``guarantee_violations`` found a true target outside
  the sets that must hold it (IB21 Secs. 3.4-3.5: impossible while the true noise box lies in the assumed one).
* **All sets empty**: every set of a UAV became empty (its ``alarm_all_empty`` count rose): every target lost, the
  paper's sign of an assumed noise bound that is too small (IB21 Sec. 6, Fig. 10).
* **Unexplained detections without decoys**: with no decoys in the world, a detection that meets no set that could
  hold it (``alarm_unexplained``) cannot happen under the assumptions either (with decoys it can: a decoy seen
  again after it was identified as one).

For a run whose filters gate their neighbours or fuse late data (:class:`NetworkHealth`):

* **Suspect neighbour**: the other UAVs' χ²-gates left out more than :data:`SUSPECT` of a UAV's contributions
  that reached them (a faulty or lying member; the gating contained it).
* **Stale data**: measurements or messages arrived later than the window an estimator keeps for late data (the
  information filter's re-filtering, the set-membership replay) and were dropped.

Each warning is a dict ``{kind, message, t_start, t_end[, uav]}`` (times in s, UAV numbers 1-based). The
accumulators are O(N) per UAV plus O(steps) scalars: they stream over the recording's chunks.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.sim.recorder import Recording

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


#: Standard normal quantile of 0.975 (two-sided 95 %).
_Z975 = 1.959963984540054


def chi2_mean_band(dim: int, n: float) -> list[float]:
    """Two-sided 95 % band of the mean of ``n`` independent χ²(``dim``) samples, ``χ²_k⁻¹(0.025, 0.975) / n`` with
    ``k = dim·n``, by the Wilson-Hilferty cube-root normal approximation ``k (1 − 2/(9k) ± z √(2/(9k)))³``
    (relative error below 0.1 % for k ≥ 40, 1 % at k = 4; no scipy import, which costs a run 0.3-0.9 s)."""
    k = dim * n
    c = 2.0 / (9.0 * k)
    return [k * (1.0 - c + s * _Z975 * np.sqrt(c)) ** 3 / n for s in (-1.0, 1.0)]


def _spans(flags: np.ndarray, t: np.ndarray, shortest: float) -> list[tuple[float, float]]:
    """Maximal runs of True in ``flags`` lasting at least ``shortest`` seconds, as ``(t_start, t_end)``."""
    out = []
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    dt = t[1] - t[0] if len(t) > 1 else 0.0
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        if (b - a) * dt >= shortest - 1e-9:
            out.append((float(t[a]), float(t[b - 1])))
    return out


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
        for a, b in _spans(~(error <= LOST_M), t, GAP_S):  # NaN errors count as lost
            warnings.append({"kind": "lost_target", "t_start": a, "t_end": b,
                             "message": f"the swarm lost the target at t = {a:.1f} s (median estimation error "
                                        f"above {LOST_M:g} m until t = {b:.1f} s)"})
        return warnings


#: The fraction of a UAV's delivered contributions gated beyond which it is named a suspect.
SUSPECT = 0.1


class NetworkHealth:
    """Per-UAV totals of the gating probes (``gated``: contributions a UAV left out; ``rejected``: receivers that
    left out a UAV's; ``delivered``: receivers that got a UAV's) with each UAV's first and last rejection, and of
    ``stale`` (late data dropped)."""

    PROBES = ("gated", "rejected", "delivered", "stale")

    def __init__(self, rec: Recording):
        self.rec = rec
        self.names = [p for p in self.PROBES if p in rec.meta["probes"]]
        self.total = {p: np.zeros(rec.n_agents) for p in self.names}
        self.first = np.full(rec.n_agents, np.nan)
        self.last = np.full(rec.n_agents, np.nan)

    def add(self, c, keep=None, err=None) -> None:
        for p in self.names:
            self.total[p] += c.probes[p].sum(axis=0)
        if "rejected" in self.names:
            hit = c.probes["rejected"] > 0
            for j in np.flatnonzero(hit.any(axis=0)):
                at = c.t[hit[:, j]]
                self.first[j] = at[0] if np.isnan(self.first[j]) else self.first[j]
                self.last[j] = at[-1]

    def _rejected_fraction(self) -> np.ndarray:
        """Per UAV, the fraction of its delivered contributions that receivers gated (0 when none was delivered)."""
        delivered = self.total["delivered"]
        return np.divide(self.total["rejected"], delivered, out=np.zeros_like(delivered), where=delivered > 0)

    def counts(self) -> dict:
        out = {f"{p}_per_uav": self.total[p].tolist() for p in self.names}
        if "rejected" in self.names:
            out["rejected_fraction"] = self._rejected_fraction().tolist()
            out["rejected_window"] = [None if np.isnan(a) else [float(a), float(b)]
                                      for a, b in zip(self.first, self.last, strict=True)]
        return out

    def result(self) -> list[dict]:
        warnings = []
        if "rejected" in self.names:
            fraction = self._rejected_fraction()
            for j in np.flatnonzero(fraction > SUSPECT):
                a, b = float(self.first[j]), float(self.last[j])
                warnings.append({"kind": "suspect_neighbour", "uav": int(j) + 1, "t_start": a, "t_end": b,
                                 "message": f"the other UAVs' gates left out {100 * fraction[j]:.0f} % of UAV "
                                            f"{j + 1}'s contributions that reached them, from t = {a:.1f} s to "
                                            f"{b:.1f} s: a faulty or lying member"})
        if "stale" in self.names and self.total["stale"].sum():
            warnings.append({"kind": "stale_data", "t_start": 0.0, "t_end": float(self.rec.t_last),
                             "message": f"{int(self.total['stale'].sum())} measurements or messages arrived later "
                                        "than the window the estimator keeps for late data (re-filtering, replay) "
                                        "and were dropped"})
        return warnings


def networked(rec: Recording) -> bool:
    """The run recorded gating or late-data probes: :class:`NetworkHealth` applies."""
    return any(p in rec.meta["probes"] for p in NetworkHealth.PROBES)


def applies(rec: Recording) -> bool:
    """The checks need a followed target and a Gaussian estimate."""
    return rec.tracked is not None and {"estimate", "covariance"} <= set(rec.meta["probes"])


def guaranteed(rec: Recording) -> bool:
    """The run recorded a set-membership estimator's uncertainty Φ (IB21 eq. 10): :class:`SetHealth` applies."""
    return "phi" in rec.meta["probes"]


def check(rec: Recording) -> list[dict]:
    """The warnings of one run (empty: nothing looked wrong)."""
    accs = [acc(rec) for acc, wanted in ((Health, applies), (SetHealth, guaranteed), (NetworkHealth, networked))
            if wanted(rec)]
    if not accs:
        return []
    for c in rec.chunks():
        for acc in accs:
            acc.add(c)
    return [w for acc in accs for w in acc.result()]


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
            per_step = c.probes["guarantee_violations"].sum(axis=1)
            self.violations += float(per_step.sum())
            self.worst = max(self.worst, float(per_step.max()))
            hit = np.flatnonzero(per_step > 0)
            if len(hit):
                self.first = float(c.t[hit[0]]) if self.first is None else self.first
                self.last = float(c.t[hit[-1]])
        count = c.probes["alarm_all_empty"]
        rose = count > np.concatenate([self.empty_count[None], count[:-1]])  # (k, N): the count went up at k
        new = np.isnan(self.empty_at) & rose.any(axis=0)
        self.empty_at[new] = c.t[rose.argmax(axis=0)[new]]
        self.empty_count = count[-1].copy()
        self.unexplained = c.probes["alarm_unexplained"][-1].copy()

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


def _gaps(seen: np.ndarray, t: np.ndarray) -> list[dict]:
    """``no_detection`` warnings for the UAVs with gaps of at least :data:`GAP_S` (the first :data:`LISTED` named,
    the rest counted in one more warning). Only UAVs missing that many steps in all are examined one by one."""
    dt = t[1] - t[0] if len(t) > 1 else 1.0
    suspects = np.flatnonzero((~seen).sum(axis=0) * dt >= GAP_S - 1e-9)
    out, named = [], 0
    for i in suspects:
        spans = _spans(~seen[:, i], t, GAP_S)
        if spans and named == LISTED:
            out.append({"kind": "no_detection", "uav": None, "t_start": float(t[0]), "t_end": float(t[-1]),
                        "message": f"and up to {len(suspects) - LISTED} more UAVs had gaps of {GAP_S:g} s or more"})
            break
        named += bool(spans)
        never = not seen[:, i].any()
        for a, b in spans:
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
    spans = _spans(bad, t[steps - 1:], 0.0)
    if not spans:
        return []
    a, b = spans[0]
    share = float(np.mean(bad))
    return [{"kind": "inconsistent", "t_start": a, "t_end": b,
             "message": f"the filters became inconsistent at t = {a:.1f} s: the {WINDOW_S:g} s NEES average "
                        f"exceeds {FAR:g}x its 95 % band ({upper:.2f} for 4) during {100 * share:.0f} % of the run "
                        f"(peak {np.nanmax(windowed):.3g})"}]
