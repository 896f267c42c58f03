"""Is a run a success? Warnings for what a table of averages hides (truth side: reads the recording).

* **No detection**: a UAV that did not detect its target for at least :data:`GAP_S` seconds (or never did).
* **Inconsistent filter**: the NEES of ``[x, y, vx, vy]``, averaged over the UAVs and a sliding window of
  :data:`WINDOW_S` seconds, above :data:`FAR` times the upper end of its 95 % χ² band (a windowed average of
  ``n`` χ²(4) samples lies in ``χ²_{4n}(0.025, 0.975) / n`` when the filter is consistent).
* **Lost target**: the median estimation error over the UAVs above :data:`LOST_M` for at least :data:`GAP_S`.

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


def applies(rec: Recording) -> bool:
    """The checks need a followed target and a Gaussian estimate."""
    return rec.tracked is not None and {"estimate", "covariance"} <= set(rec.meta["probes"])


def check(rec: Recording) -> list[dict]:
    """The warnings of one run (empty: nothing looked wrong)."""
    if not applies(rec):
        return []
    health = Health(rec)
    for c in rec.chunks():
        health.add(c)
    return health.result()


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
