"""Many targets in clutter, one tracker per UAV: each UAV's labelled multi-Bernoulli filter
(:mod:`swarmtrack.estimation.lmb`) over its own unlabelled detections and those its neighbours share (issue 40).

Per estimation step, for each UAV (row) on its own:

* :meth:`MultiTargetEstimator.share`: predict its tracks to ``t`` (the nearly-constant-velocity model, survival P_S, 0
  outside the surveillance region); turn
  its own detections into world positions with their covariances (the sensor's ``position_rule``) and broadcast at
  most ``max_shared`` of them (the closest to it), with where it was when it took them: the message is bounded.
* :meth:`MultiTargetEstimator.fuse`: correct its tracks with each batch of detections it has (its own and every
  neighbour's delivered this step), one batch at a time in the order of the UAVs that took them (the iterated
  corrector of multi-sensor LMB filters: every UAV that has the same batches computes the same tracks, labels
  included). A batch's detection probability is the sensor's for a track its taker could see (its field of view
  around the taker's position) and 0 for one it could not, so a track outside a UAV's view is not weakened by that
  UAV's silence (with the sensor's falloff, the probability at the track's distance). Each batch's unexplained
  detections give birth to tracks the next batches can confirm.

A message that is lost is a batch that does not come: the tracks are corrected with fewer detections, never with a
stale one. A batch delayed past its step (``network.delay``) is dropped and counted (``late_batches``): an LMB
correction is at its step's time, and a late batch would need a retrodiction this filter does not make.

What is recorded (per UAV, ``K = max_tracks`` rows, NaN past the reported ones): the reported tracks' states
``tracks`` ``[x, y, vx, vy]``, their ``track_labels``, ``existence`` and position covariances, how many it reports
(``n_tracks``), the expected number of targets (``cardinality``, Σ r over every track kept), and what it broadcast
(``detections_shared`` and ``bytes_shared``, the payload's size at 8 bytes a number), and the neighbours'
batches that came after their step (``late_batches``, dropped).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from swarmtrack.estimation.base import Probe, TargetView
from swarmtrack.estimation.lmb import LMBFilter, Tracks
from swarmtrack.estimation.track_fusion import ga_bernoulli, match
from swarmtrack.network.messages import Inbox, Outbox
from swarmtrack.network.rows import Rows
from swarmtrack.sensors.detections import Detections

#: The clutter intensity a filter assumes when its sensor reports none, per m²: one false detection per 1000 km²
#: (a detection no track explains is then a new target's).
KAPPA_FLOOR = 1e-9
#: Two of a UAV's tracks this close (squared Mahalanobis distance of their positions) are one object's: the twin is
#: dropped (:func:`~swarmtrack.estimation.lmb.merge_twins`).
TWINS = 1.0
#: A track's label names the detection that began it: ``((k·N + j)·BIRTHS + m)`` for detection m of UAV j's batch at
#: step k (N UAVs), so that two UAVs that begin a track from the same detection give it the same label.
BIRTHS = 1 << 16
#: Numbers in one shared detection: its position (2) and covariance (3: xx, xy, yy).
PER_DETECTION = 5
#: Numbers in one shared track: its label, existence, mean (4) and covariance (10: the upper triangle).
PER_TRACK = 16
#: The least existence of a track a UAV shares (below it, the track says little either way).
SHARED_FROM = 0.1


@dataclass(frozen=True)
class TrackerSettings:
    """What every UAV's filter runs with: the motion model ``F``, ``Q`` over one estimation step, the survival
    probability, the clutter intensity ``kappa`` (per m²), the gate (a χ²(2) quantile), the adaptive birth
    (``birth_rate`` λ_B, ``birth_existence`` r_B,max, ``birth_velocity_std``), the reporting and pruning thresholds,
    ``max_tracks``, the estimation step ``dt``, and the surveillance ``region`` ``(x0, y0, x1, y1)`` outside which a
    predicted track ends (None: none)."""

    F: np.ndarray
    Q: np.ndarray
    survival: float
    kappa: float
    gate: float
    birth_rate: float
    birth_existence: float
    birth_velocity_std: float
    existence_threshold: float
    prune_threshold: float
    max_tracks: int
    dt: float
    region: tuple[float, float, float, float] | None = None


def _likeliest(tracks: Tracks, above: float, most: int, strictly: bool = False) -> np.ndarray:
    """The rows of ``tracks`` whose existence is at least ``above`` (above it, ``strictly``), likeliest first, at
    most ``most`` of them."""
    r = tracks.r
    rows = np.flatnonzero(r > above if strictly else r >= above)
    return rows[np.argsort(-r[rows], kind="stable")][:most]


def _packed(P: np.ndarray) -> np.ndarray:
    """Symmetric matrices (..., n, n) as their upper triangles (..., n(n+1)/2), row by row: what a message carries."""
    iu = np.triu_indices(P.shape[-1])
    return P[..., iu[0], iu[1]]


def _unpacked(values: np.ndarray, n: int) -> np.ndarray:
    """:func:`_packed`'s inverse: the symmetric (..., n, n) matrices of upper triangles ``values``."""
    iu = np.triu_indices(n)
    out = np.empty((*values.shape[:-1], n, n))
    out[..., iu[0], iu[1]] = values
    out[..., iu[1], iu[0]] = values
    return out


def _fused(tracks: Tracks, labels: np.ndarray, r: np.ndarray, m: np.ndarray, P: np.ndarray, s: TrackerSettings,
           in_view: np.ndarray) -> Tracks:
    """``tracks`` with a neighbour's (``labels``, ``r``, ``m``, ``P``) fused in (:meth:`MultiTargetEstimator.combine`);
    ``in_view``: which of the neighbour's tracks the UAV's own sensor sees."""
    pairs, left = match(tracks.label, tracks.m, tracks.P, labels, m, P, s.gate)
    rr, mm, PP = tracks.r.copy(), tracks.m.copy(), tracks.P.copy()
    for k, j in pairs:
        if rr[k] == r[j] and np.array_equal(mm[k], m[j]) and np.array_equal(PP[k], P[j]):
            continue  # the same track (the same detections in the same order): nothing to fuse
        rr[k], mm[k], PP[k] = ga_bernoulli(rr[k], mm[k], PP[k], r[j], m[j], P[j])
    adopt = left[(r[left] > s.existence_threshold) & ~in_view[left]]
    out = Tracks(tracks.label, rr, mm, PP)
    return out.concat(Tracks(labels[adopt], r[adopt], m[adopt], P[adopt])) if len(adopt) else out


class MultiTargetEstimator:
    """One multi-target filter per UAV of ``rows``, an LMB filter by default (module docstring).
    ``positions(detections) → (p (M, 2), R (M, 2, 2))`` turns detections into world positions with covariances;
    ``pd_at(rel) → (...,)`` is the detection probability the filter assumes for objects at positions ``rel`` relative
    to the UAV that scans (0 outside its view); ``share``: whether the UAVs broadcast their detections; ``centre``:
    the centralised baseline instead, one filter fed every UAV's detections straight (not a UAV's: no message), which
    every row reports; ``make_filter()``: each UAV's filter, an :class:`~swarmtrack.estimation.lmb.LMBFilter` by
    default (or one of :mod:`swarmtrack.estimation.classic`'s, with the same interface)."""

    def __init__(self, settings: TrackerSettings, rows: Rows, positions: Callable, pd_at: Callable, share: bool = True,
                 max_shared: int = 64, compiled: bool = True, centre: bool = False, fuse_tracks: bool = False,
                 max_shared_tracks: int = 32, make_filter: Callable | None = None):
        self.settings, self.rows, self.positions, self.pd_at = settings, rows, positions, pd_at
        self.share_detections, self.max_shared, self.compiled = share and not centre, max_shared, compiled
        self.fuse_tracks, self.max_shared_tracks = fuse_tracks and not centre, max_shared_tracks
        self._sent_tracks: np.ndarray = np.zeros(len(rows), dtype=np.int64)
        self.n = len(rows)
        self.centre = centre
        make = (lambda: LMBFilter(compiled=compiled)) if make_filter is None else make_filter
        self.filters = [make() for _ in range(1 if centre else self.n)]
        self.t: float | None = None
        self._own: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._sent: np.ndarray = np.zeros(self.n, dtype=np.int64)
        self._late: np.ndarray = np.zeros(self.n, dtype=np.int64)
        k = settings.max_tracks
        self.probes = (Probe("tracks", (k, 4)), Probe("track_labels", (k,)), Probe("existence", (k,)),
                       Probe("track_position_cov", (k, 2, 2)), Probe("n_tracks"), Probe("cardinality"),
                       Probe("detections_shared"), Probe("bytes_shared"), Probe("late_batches"))

    def share(self, t: float, nav: np.ndarray, own: Detections) -> Outbox:
        """Predict every UAV's tracks to ``t`` and return what each broadcasts: its detections as positions
        (``points`` (R, S, 2) and ``covariances`` (R, S, 3), NaN past ``count``) and where it was (``origin``)."""
        s = self.settings
        steps = 0 if self.t is None else max(1, round((t - self.t) / s.dt))  # a UAV that missed steps catches up
        for f in self.filters:
            for _ in range(steps):
                f.predict(s.F, s.Q, s.survival)
                if s.region is not None:
                    x0, y0, x1, y1 = s.region
                    x, y = f.tracks.m[:, 0], f.tracks.m[:, 1]
                    f.tracks = f.tracks.take((x >= x0) & (x <= x1) & (y >= y0) & (y <= y1))
        self.t = t
        p, R = self.positions(own)
        origin = np.asarray(nav, dtype=float)[:, :2]
        self._own = []
        for r in range(self.n):
            pick = np.flatnonzero(own.owner == r)
            self._own.append((p[pick], R[pick], origin[r]))
        if not self.share_detections:
            return {}
        most = self.max_shared
        points = np.full((self.n, most, 2), np.nan)
        cov = np.full((self.n, most, 3), np.nan)
        count = np.zeros(self.n, dtype=np.int64)
        for r, (pr, Rr, o) in enumerate(self._own):
            keep = np.sort(np.argsort(np.hypot(*(pr - o).T), kind="stable")[:most])  # in the sensor's order
            c = len(keep)
            points[r, :c] = pr[keep]
            cov[r, :c] = _packed(Rr[keep])
            count[r] = c
        self._sent = count
        return {"points": points, "covariances": cov, "count": count, "origin": origin.copy()}

    def fuse(self, t: float, own: Detections, inbox: Inbox) -> None:
        """Correct each UAV's tracks with its batches (its own and its neighbours' of this step), in the order of
        the UAVs that took them, then prune."""
        s = self.settings
        batches: list[dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]]] = [
            {int(self.rows.uavs[r]): self._own[r]} for r in range(self.n)]
        if self.centre:  # every UAV's detections, straight to the one filter
            batches = [{k: v for b in batches for k, v in b.items()}]
        self._late = np.zeros(self.n, dtype=np.int64)
        for part in inbox.late:  # batches taken at earlier steps: an LMB correction is at its own step's time
            np.add.at(self._late, part.edges()[0], 1)
        if self.share_detections and "points" in inbox.payloads:
            got = inbox.payloads
            recv, send = inbox.edges()
            for r, j in zip(recv.tolist(), send.tolist(), strict=True):
                c = int(got["count"][j])
                batches[r][j] = (got["points"][j, :c], _unpacked(got["covariances"][j, :c], 2), got["origin"][j])
        step = round(t / s.dt)
        for f, mine in zip(self.filters, batches, strict=True):
            for j in sorted(mine):
                z, R, origin = mine[j]
                f.correct(z, R, self.pd_at(f.tracks.m[:, :2] - origin), np.full(len(z), s.kappa), s.gate,
                          s.birth_rate, s.birth_existence, s.birth_velocity_std,
                          labels=(step * self.rows.n + j) * BIRTHS + np.arange(len(z)))
            f.finish(s.prune_threshold, s.max_tracks, TWINS)

    def publish(self, t: float) -> Outbox:
        """After the correction, what each UAV tells its neighbours of its tracks (when it fuses tracks): at most
        ``max_shared_tracks`` of those with existence of at least :data:`SHARED_FROM`, the likeliest, as their
        labels, existence, means and covariances (upper triangles)."""
        if not self.fuse_tracks:
            return {}
        m = self.max_shared_tracks
        out = {"track_label": np.full((self.n, m), np.nan), "track_r": np.full((self.n, m), np.nan),
               "track_m": np.full((self.n, m, 4), np.nan), "track_P": np.full((self.n, m, 10), np.nan),
               "track_count": np.zeros(self.n, dtype=np.int64)}
        for r, f in enumerate(self.filters):
            tr = f.tracks
            rows = _likeliest(tr, SHARED_FROM, m)
            c = len(rows)
            out["track_label"][r, :c] = tr.label[rows]
            out["track_r"][r, :c] = tr.r[rows]
            out["track_m"][r, :c] = tr.m[rows, :4]
            out["track_P"][r, :c] = _packed(tr.P[rows])
            out["track_count"][r] = c
        self._sent_tracks = out["track_count"]
        return out

    def combine(self, t: float, inbox: Inbox) -> None:
        """Fuse each neighbour's tracks into each UAV's, one neighbour at a time in their order
        (:mod:`swarmtrack.estimation.track_fusion`): a matched pair by the geometric average (a pair already equal is
        left as it is), a neighbour's track left unmatched adopted when it is confirmed and outside the UAV's own
        field of view (inside it, the UAV's own sensor decides whether it is there)."""
        if not self.fuse_tracks or "track_label" not in inbox.payloads:
            return
        got = inbox.payloads
        recv, send = inbox.edges()
        for r, f in enumerate(self.filters):
            origin = self._own[r][2]
            for j in sorted(send[recv == r].tolist()):
                c = int(got["track_count"][j])
                m = got["track_m"][j, :c]
                f.tracks = _fused(f.tracks, got["track_label"][j, :c].astype(np.int64), got["track_r"][j, :c], m,
                                  _unpacked(got["track_P"][j, :c], 4), self.settings,
                                  self.pd_at(m[:, :2] - origin) > 0.0)
            f.finish(self.settings.prune_threshold, self.settings.max_tracks, TWINS)

    def _bytes(self) -> np.ndarray:
        """What each UAV broadcast this step at 8 bytes a number: its detections (with their count and its
        position) and its tracks (with their count)."""
        out = np.zeros(self.n)
        if self.share_detections:
            out += 8.0 * (PER_DETECTION * self._sent + 3)
        if self.fuse_tracks:
            out += 8.0 * (PER_TRACK * self._sent_tracks + 1)
        return out

    def filter_of(self, r: int) -> LMBFilter:
        """Row ``r``'s filter (the fusion centre's, for every row, in the centralised baseline)."""
        return self.filters[0 if self.centre else r]

    def view(self) -> TargetView:
        """Each UAV's reported tracks (``tracks``, ``track_labels``, as sampled) and the likeliest of them as
        ``state`` (NaN when it reports none): what a controller that follows one target follows."""
        out = self.sample()
        return TargetView(out["tracks"][:, 0].copy(), tracks=out["tracks"], track_labels=out["track_labels"])

    def sample(self) -> dict[str, np.ndarray]:
        """Every probe: each UAV's reported tracks, likeliest first, NaN past them (module docstring)."""
        k = self.settings.max_tracks
        out = {"tracks": np.full((self.n, k, 4), np.nan), "track_labels": np.full((self.n, k), np.nan),
               "existence": np.full((self.n, k), np.nan), "track_position_cov": np.full((self.n, k, 2, 2), np.nan),
               "n_tracks": np.zeros(self.n), "cardinality": np.zeros(self.n),
               "detections_shared": self._sent.astype(float), "bytes_shared": self._bytes(),
               "late_batches": self._late.astype(float)}
        for r in range(self.n):
            f = self.filter_of(r)
            tr = f.tracks
            rows = _likeliest(tr, self.settings.existence_threshold, k, strictly=True)  # the reported
            c = len(rows)
            out["tracks"][r, :c] = tr.m[rows, :4]
            out["track_labels"][r, :c] = tr.label[rows]
            out["existence"][r, :c] = tr.r[rows]
            out["track_position_cov"][r, :c] = tr.P[rows, :2, :2]
            out["n_tracks"][r] = c
            out["cardinality"][r] = tr.r.sum()
        return out
