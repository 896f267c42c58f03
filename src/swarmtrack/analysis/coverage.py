"""Which samples a run's numbers cover: the present mask of a recording and the ``coverage`` section.

A UAV's sample that did not come (a lost UAV, a sample late to a real-time world, a UAV under its operator's
control: :class:`~swarmtrack.sim.recorder.Chunk`'s ``present``) and a step without ground truth of the followed
target (a replayed log whose truth does not reach that time: the truth is not finite) are *absent*: every metric is
computed over the samples that are judged (:func:`judged`), per UAV and for the swarm, and says how many it covers.
Absence is never an error of infinite size; a *present* sample whose numbers are NaN or infinite is a diverged filter,
and the metrics keep it (its RMSE and NEES become NaN or infinite, the health checks call it lost or inconsistent).

:class:`Presence` is the accumulator every run gets (:func:`swarmtrack.analysis.metrics.summary`): the ``coverage``
section and a warning for each UAV absent for at least :data:`GAP_S` seconds.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.sim.recorder import Chunk, Recording

#: The shortest absence of a UAV's samples worth a warning, s.
GAP_S = 1.0
#: How many absent UAVs are named one by one.
LISTED = 10


def came(rec: Recording, c: Chunk) -> np.ndarray:
    """(k, N) bool: the UAVs' samples that came (all, for a recording without a present mask)."""
    if c.present is None:
        return np.ones((len(c.t), rec.n_agents), dtype=bool)
    return c.present


def truth_known(rec: Recording, c: Chunk) -> np.ndarray:
    """(k,) bool: the steps with the followed target's ground truth (finite ``[x, y, vx, vy]``)."""
    return np.isfinite(c.truth[:, rec.tracked]).all(axis=-1)


def judged(rec: Recording, c: Chunk, shared: dict | None = None) -> np.ndarray:
    """(k, N) bool: the samples an estimate is judged on: the UAV's sample came and the followed target's truth is
    known (kept in the scan's ``shared`` dict, computed once per chunk)."""
    if shared is not None and "coverage.judged" in shared:
        return shared["coverage.judged"]
    out = came(rec, c) & truth_known(rec, c)[:, None]
    if shared is not None:
        shared["coverage.judged"] = out
    return out


def masked(x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``x`` (k, N, ...) with the samples outside ``mask`` (k, N) set to 0, for sums over the judged samples (``x``
    itself when every sample is judged, so a run without absences gives its numbers bit for bit)."""
    if mask.all():
        return x
    return np.where(mask.reshape(mask.shape + (1,) * (x.ndim - mask.ndim)), x, 0.0)


def mean_over_uavs(x: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per step, the mean of ``x`` (k, N) over the UAVs in ``mask`` (k, N), and the steps with any (k,) bool (their
    mean; the others' value is NaN). A judged sample that is NaN makes its step's mean NaN (a diverged filter)."""
    count = mask.sum(axis=1)
    some = count > 0
    if mask.all():
        return x.mean(axis=1), some
    total = masked(x, mask).sum(axis=1)
    return np.divide(total, count, out=np.full(len(x), np.nan), where=some), some


def at_last_came(present: np.ndarray, x: np.ndarray, before: np.ndarray) -> np.ndarray:
    """(N, ...) each UAV's row of ``x`` (k, N, ...) at its last sample that came (``present`` (k, N)), ``before``
    for a UAV none of whose samples came (e.g. a cumulative count carried across chunks)."""
    row, got = len(present) - 1 - np.argmax(present[::-1], axis=0), present.any(axis=0)
    got = got.reshape(got.shape + (1,) * (x.ndim - 2))
    return np.where(got, x[row, np.arange(present.shape[1])], before)


def runs(flags: np.ndarray, t: np.ndarray, shortest: float) -> list[tuple[int, int]]:
    """Maximal runs of True in ``flags`` (k,) lasting at least ``shortest`` s, as index pairs ``[a, b)``."""
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    dt = t[1] - t[0] if len(t) > 1 else 0.0
    return [(int(a), int(b)) for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True)
            if (b - a) * dt >= shortest - 1e-9]


class Presence:
    """Which samples came, streamed: per UAV the count of its samples that came, the steps with the followed
    target's truth, and (for the warnings) each step's present row, O(steps × N) booleans as the detection
    check's, kept only for a recording with a present mask."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.came = np.zeros(rec.n_agents, dtype=np.int64)
        self.steps = self.truth_steps = 0
        self.rows, self.t = [], []

    def add(self, c: Chunk, keep=None, shared=None) -> None:
        k = len(c.t)
        self.steps += k
        if self.rec.tracked is not None:
            self.truth_steps += int(truth_known(self.rec, c).sum())
        if c.present is None:
            self.came += k
            return
        self.came += c.present.sum(axis=0)
        self.rows.append(c.present)
        self.t.append(c.t)

    def result(self) -> dict:
        """The ``coverage`` section: ``samples`` (UAV samples that came), ``of`` (steps × UAVs), ``fraction``,
        ``per_uav`` (each UAV's fraction), ``steps``, and with a followed target ``truth_steps`` and
        ``truth_fraction`` (the steps with its ground truth). :func:`~swarmtrack.analysis.metrics.summary` adds
        ``sections``: the samples each section covers (those with a ``samples()`` count)."""
        n, steps = self.rec.n_agents, self.steps
        of = steps * n
        out = {"samples": int(self.came.sum()), "of": of, "fraction": float(self.came.sum() / of) if of else None,
               "per_uav": (self.came / steps).tolist() if steps else [None] * n, "steps": steps}
        if self.rec.tracked is not None:
            out.update(truth_steps=self.truth_steps, truth_fraction=self.truth_steps / steps if steps else None)
        return out

    def warnings(self, summary: dict | None = None) -> list[dict]:
        """A warning per UAV whose samples were absent for at least :data:`GAP_S` s (the first :data:`LISTED`
        named), saying what the run's numbers cover; with the run's ``position_rmse_per_uav`` (``summary``, a
        Gaussian estimator's), the others' position RMSE over their samples."""
        out = []
        if self.steps and self.rec.tracked is not None and self.truth_steps < self.steps:
            share = self.truth_steps / self.steps
            out.append({"kind": "partial_truth", "t_start": None, "t_end": None,
                        "message": f"ground truth of the target covers {100 * share:.0f} % of the steps "
                                   f"({self.truth_steps} of {self.steps}): the errors are over those steps only"})
        if not self.rows:
            return out
        present, t = np.concatenate(self.rows), np.concatenate(self.t)
        absent = [i for i in range(self.rec.n_agents) if runs(~present[:, i], t, GAP_S)]
        rmse = (summary or {}).get("position_rmse_per_uav")
        for i in absent[:LISTED]:
            gaps = runs(~present[:, i], t, GAP_S)
            when = "; ".join(f"from t = {t[a]:.1f} s " + ("to the end" if b == len(t) else f"to {t[b - 1]:.1f} s")
                             for a, b in gaps)
            others = [j for j in range(self.rec.n_agents) if j != i and self.came[j]]
            tracked = ""
            if rmse is not None and others and all(rmse[j] is not None for j in others):
                tracked = (f"; the others tracked: position RMSE {np.mean([rmse[j] for j in others]):.2f} m "
                           "over their samples")
            missing = 100 * (1 - self.came[i] / self.steps)
            out.append({"kind": "absent_samples", "uav": i + 1, "t_start": float(t[gaps[0][0]]),
                        "t_end": float(t[gaps[-1][1] - 1]),
                        "message": f"UAV {i + 1}'s samples did not come {when} ({missing:.0f} % of its steps: lost, "
                                   f"late or under its operator's control); the run's numbers are over the samples "
                                   f"that came{tracked}"})
        if len(absent) > LISTED:
            out.append({"kind": "absent_samples", "uav": None, "t_start": None, "t_end": None,
                        "message": f"and {len(absent) - LISTED} more UAVs whose samples did not come for "
                                   f"{GAP_S:g} s or more"})
        return out
