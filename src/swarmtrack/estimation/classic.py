"""The classic multi-target trackers, kept as baselines beside the LMB filter (issue 40): global nearest neighbour
(GNN) and joint probabilistic data association (JPDA), with the usual track management.

Both hold Gaussian tracks (:class:`~swarmtrack.estimation.lmb.Tracks`) and have the interface of
:class:`~swarmtrack.estimation.lmb.LMBFilter` (``predict``, ``correct`` once per batch of detections, ``finish``), so
the swarm's estimator (:mod:`swarmtrack.estimation.multitarget`) runs any of the three, with the same messages and
fusion. A track's ``r`` is its status, not a probability: :data:`TENTATIVE` or :data:`CONFIRMED` (0 once deleted).

Track management (the M-of-N logic of Blackman and Popoli 1999, in its simplest form): a detection no track takes
starts a tentative track at it (velocity unknown: ``velocity_std``); a track is hit when it takes a detection (GNN:
one is assigned to it; JPDA: it more likely made one than none), missed when its sensor could see it (``pd > 0``)
and it takes none; a tentative track is confirmed at its ``confirm``-th hit and deleted at its first miss, a
confirmed one deleted after ``delete`` misses in a row.

* GNN: the assignment of detections to tracks that minimises the sum of ``d² + ln |S|`` over the gated pairs
  (``scipy.optimize.linear_sum_assignment``), each assigned track Kalman-updated with its detection.
* JPDA: every track updated with all its gated detections weighted by their marginal association probabilities,
  the joint events' marginals taken by loopy belief propagation (Williams and Lau 2014) as in the LMB filter, with
  every track assumed to exist: it is :func:`~swarmtrack.estimation.lmb.update` with ``r = 1``, whose moment-matched
  posterior is the JPDA update (Bar-Shalom, Daum and Huang 2009). A track is hit when it more likely made one of the
  detections than none, and a detection starts a track when it more likely came from no track.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from swarmtrack.estimation.kalman import ekf_update
from swarmtrack.estimation.lbp import lbp
from swarmtrack.estimation.lmb import MEAS_DIM, Tracks, merge_twins, predict, prune, update

#: A track's status as its ``r``: tentative (not reported) and confirmed (reported above an existence threshold
#: of 0.5).
TENTATIVE = 0.25
CONFIRMED = 1.0


def _gated(tracks: Tracks, z: np.ndarray, R: np.ndarray, gate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``d²`` (K, M), ``ln |S|`` (K, M) and the innovations ν (K, M, 2) of every track-detection pair."""
    nu = z[None, :, :] - tracks.m[:, None, :MEAS_DIM]
    S = tracks.P[:, None, :MEAS_DIM, :MEAS_DIM] + R[None]
    d2 = np.einsum("kma,kma->km", nu, np.linalg.solve(S, nu[..., None])[..., 0])
    return d2, np.linalg.slogdet(S)[1], nu


class _Managed:
    """Tracks with hits and misses (module docstring); a subclass associates a batch (:meth:`_associate`)."""

    def __init__(self, confirm: int, delete: int, compiled: bool = True):
        self.tracks = Tracks.empty(4)
        self.confirm, self.delete, self.compiled = confirm, delete, compiled
        self.hits: dict[int, int] = {}
        self.misses: dict[int, int] = {}
        self.next_label = 0

    def predict(self, F: np.ndarray, Q: np.ndarray, survival) -> None:
        """Every track predicted (its status kept: a classic tracker's tracks do not fade, they are deleted)."""
        self.tracks = predict(self.tracks, F, Q, 1.0)

    def _associate(self, z: np.ndarray, R: np.ndarray, pd: np.ndarray, kappa: np.ndarray,
                   gate: float) -> tuple[Tracks, np.ndarray, np.ndarray]:
        """The updated tracks, which were hit (K,) and which detections no track took (M,)."""
        raise NotImplementedError

    def correct(self, z, R, pd, kappa, gate: float, birth_rate: float, r_max: float, velocity_std: float,
                labels=None) -> np.ndarray:
        """One batch: associate, update, manage, and start a tentative track at each detection no track took
        (labelled ``labels``, as :meth:`LMBFilter.correct <swarmtrack.estimation.lmb.LMBFilter.correct>`;
        ``birth_rate`` and ``r_max`` are the LMB's and not read). Returns 1 for a detection no track took, else
        0."""
        z = np.asarray(z, dtype=float).reshape(-1, MEAS_DIM)
        R = np.asarray(R, dtype=float).reshape(-1, MEAS_DIM, MEAS_DIM)
        pd = np.broadcast_to(np.asarray(pd, dtype=float), (len(self.tracks),))
        kappa = np.broadcast_to(np.asarray(kappa, dtype=float), (len(z),))
        updated, hit, free = self._associate(z, R, pd, kappa, gate) if len(self.tracks) else \
            (self.tracks, np.zeros(0, dtype=bool), np.ones(len(z), dtype=bool))
        r = updated.r.copy()
        for k, label in enumerate(updated.label.tolist()):
            if hit[k]:
                self.hits[label] = self.hits.get(label, 0) + 1
                self.misses[label] = 0
                r[k] = CONFIRMED if self.hits[label] >= self.confirm or r[k] >= CONFIRMED else TENTATIVE
            elif pd[k] > 0.0:
                self.misses[label] = self.misses.get(label, 0) + 1
                if r[k] < CONFIRMED or self.misses[label] >= self.delete:
                    r[k] = 0.0
        if labels is None:
            labels = np.arange(self.next_label, self.next_label + len(z))
            self.next_label += len(z)
        new = np.flatnonzero(free)
        m = np.zeros((len(new), 4))
        m[:, :MEAS_DIM] = z[new]
        P = np.zeros((len(new), 4, 4))
        P[:, :MEAS_DIM, :MEAS_DIM] = R[new]
        P[:, 2, 2] = P[:, 3, 3] = velocity_std**2
        born = Tracks(np.asarray(labels, dtype=np.int64)[new], np.full(len(new), TENTATIVE), m, P)
        for label in born.label.tolist():
            self.hits[label], self.misses[label] = 1, 0
        self.tracks = Tracks(updated.label, r, updated.m, updated.P).concat(born)
        return free.astype(float)

    def finish(self, threshold: float = 1e-3, max_tracks: int | None = None, merge: float | None = None) -> None:
        """Deleted tracks dropped, twins merged (``merge``), at most ``max_tracks`` kept; the counts of the dropped
        forgotten."""
        tracks = self.tracks.take(np.flatnonzero(self.tracks.r > 0.0))
        if merge is not None:
            tracks = merge_twins(tracks, merge)
        self.tracks = prune(tracks, threshold, max_tracks)
        kept = set(self.tracks.label.tolist())
        self.hits = {k: v for k, v in self.hits.items() if k in kept}
        self.misses = {k: v for k, v in self.misses.items() if k in kept}


class GNNFilter(_Managed):
    """Global nearest neighbour (module docstring)."""

    def _associate(self, z, R, pd, kappa, gate):
        tr = self.tracks
        d2, logdet, nu = _gated(tr, z, R, gate)
        ok = (d2 <= gate) & (pd[:, None] > 0.0)
        cost = np.where(ok, d2 + logdet, 1e12)
        rows, cols = linear_sum_assignment(cost) if len(z) else (np.zeros(0, int), np.zeros(0, int))
        good = ok[rows, cols]
        rows, cols = rows[good], cols[good]
        m, P = tr.m.copy(), tr.P.copy()
        if len(rows):
            H = np.eye(MEAS_DIM, tr.n)
            m[rows], P[rows] = ekf_update(tr.m[rows], tr.P[rows], H, R[cols], nu[rows, cols])
        hit = np.zeros(len(tr), dtype=bool)
        hit[rows] = True
        free = np.ones(len(z), dtype=bool)
        free[cols] = False
        return Tracks(tr.label, tr.r, m, P), hit, free


class JPDAFilter(_Managed):
    """Joint probabilistic data association (module docstring)."""

    def _associate(self, z, R, pd, kappa, gate):
        tr = self.tracks
        d2, logdet, _ = _gated(tr, z, R, gate)
        g = np.where(d2 <= gate, np.exp(-0.5 * d2 - np.log(2.0 * np.pi) - 0.5 * logdet), 0.0)
        p, p_free = lbp(1.0 - pd, pd[:, None] * g / kappa[None, :])  # the marginals of the joint events
        sure = Tracks(tr.label, np.ones(len(tr)), tr.m, tr.P)
        posterior, _ = update(sure, z, R, pd, kappa, gate, compiled=self.compiled)
        hit = p[:, 0] < 0.5  # more likely detected than not
        return Tracks(tr.label, tr.r, posterior.m, posterior.P), hit, p_free > 0.5
