"""Metrics computed from a :class:`Recording` (truth is allowed here: this is the evaluation side).

What a run gets is read from the registrations (:mod:`swarmtrack.registry`) of the kinds it used
(:func:`run_kinds`): each kind's :class:`~swarmtrack.registry.Metric` sections, its health checks and its parts of
the time series. This module holds only what every run gets: the distance of the UAVs to a followed target
(``target_distance``), their spacing (``inter_agent_distance``, see :func:`spacing`), which UAV lied (``liar_uav``)
and the machinery of the time series (``series``), and it names no kind's probes. The capabilities' metrics live
beside them (``swarmtrack.capabilities.<capability>.metrics``).

Conventions (L24 Tables 1-3, L23 Table 1): a statistic is computed per UAV and then averaged over the UAVs.
Steps before the chase starts (the first 20 filter iterations, when the filter starts from no information)
are left out of the judged window (:func:`chase_window`), so that the numbers describe tracking, not
initialisation.

Every metric streams over the recording's chunks (:meth:`Recording.chunks`) with accumulators of O(N) per
quantity (O(pairs) for the spacing metrics), never steps × N, so it works on recordings larger than memory.
Inter-agent spacing is measured over every pair for swarms of up to :data:`ALL_PAIRS_UP_TO` UAVs; for larger
swarms over the neighbour pairs (closer than r_comm) of each step, from a grid of cells (:func:`close_pairs`, compiled;
see :func:`spacing`).
The time series (:func:`series`) are per-bin means over fixed time bins, O(bins) per quantity.

**The accumulator protocol.** A registered section's ``make(recording)`` gives an object with ``add(chunk, keep,
shared)`` (every chunk of the recording in order; ``keep``: the chunk's steps in the judged window; an accumulator
reads the probes it needs from the chunk; ``shared``: a dict fresh for each chunk, the same for every accumulator of
the pass, where they keep what several of them compute from the chunk, e.g. a Gaussian estimate's errors and NEES,
so that it is computed once; None: nothing is shared) and ``result()`` (the section). Optionally ``warnings()``
(a list of warning dicts added to the run's ``warnings``) and ``extras()`` (more top-level keys, e.g. the run-wide
``nees`` beside its ``consistency`` section). A health check's ``result()`` is its list of warnings. A section
registered as :data:`SERIES` is a part of the time series: its accumulator has ``quantities`` (their names) and
``values(chunk)`` → ``{quantity: (t, values)}`` (one value per time ``t`` to average into the bins); a part with
``shares = True`` gets ``values(chunk, shared)``.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from swarmtrack import registry
from swarmtrack.analysis.coverage import Presence
from swarmtrack.sim.recorder import Chunk, Recording

COMPONENTS = ("x", "y", "vx", "vy")
#: Up to this many UAVs the spacing metrics follow every pair (P = N(N−1)/2 accumulators).
ALL_PAIRS_UP_TO = 64
#: A run's time series have at most this many bins (:func:`series_bin_width`).
SERIES_MAX_BINS = 200
#: The section name under which a kind registers a part of the time series (:class:`Series`).
SERIES = "series"
#: The estimator whose analysis a recording gets when its ``estimator`` section names no kind that registers any
#: (:meth:`Recording.from_arrays`, for tests and external data, makes one target followed by a Gaussian estimate;
#: a toy kind registered without metrics): its sections and checks apply where their probes were recorded.
DEFAULT_ESTIMATOR = "information"


def run_kinds(rec: Recording) -> list[registry.Kind]:
    """The registered kinds whose metrics, health checks and figures apply to ``rec``: those of its meta's
    ``sensor``, ``estimator`` and ``controller`` sections (:func:`swarmtrack.registry.of_run`), in that order; an
    estimator that registers no analysis (or none named) is read as :data:`DEFAULT_ESTIMATOR`'s."""
    kinds = registry.of_run(rec.meta or {})
    estimator = next((k for k in kinds if k.role == "estimator"), None)
    if estimator is None or not (estimator.metrics or estimator.health or estimator.figures):
        default = registry.get("estimator", DEFAULT_ESTIMATOR)
        kinds = [k for k in kinds if k.role == "sensor"] + [default] + [k for k in kinds if k.role == "controller"]
    return kinds


def chase_window(rec: Recording, t: np.ndarray) -> np.ndarray:
    """Steps after the chase starts (all steps if it never does, judged on the whole run)."""
    if rec.t_last < rec.chase_start - 1e-9:
        return np.ones(len(t), dtype=bool)
    return t >= rec.chase_start - 1e-9


def errors(rec: Recording) -> np.ndarray:
    """(K, N, 4) estimate minus truth of [x, y, vx, vy] (whole run in memory: for plots of small runs)."""
    return rec.estimate - rec.target[:, None, :]


class Moments:
    """Running count, mean and M2 per element (Chan et al.'s pairwise combination: exact and stable)."""

    def __init__(self):
        self.n, self.mean, self.m2 = 0, 0.0, 0.0

    def add(self, x: np.ndarray, mask: np.ndarray | None = None) -> None:
        """Add samples along axis 0; ``mask`` (the leading axes of ``x``, axis 0 included): only the samples it
        marks, so that each element counts its own samples (None or all True: every sample, one count for all)."""
        if mask is not None and not mask.all():
            self._add_masked(x, mask)
            return
        k = len(x)
        if not k:
            return
        mean = x.mean(axis=0)
        m2 = ((x - mean) ** 2).sum(axis=0)
        n = self.n + k
        delta = mean - self.mean
        self.mean = self.mean + delta * (k / n)
        self.m2 = self.m2 + m2 + delta**2 * (self.n * k / n)
        self.n = n

    def _add_masked(self, x: np.ndarray, mask: np.ndarray) -> None:
        m = mask.reshape(mask.shape + (1,) * (x.ndim - mask.ndim))
        k = np.broadcast_to(m, x.shape).sum(axis=0).astype(float)
        xs = np.where(m, x, 0.0)
        mean = np.divide(xs.sum(axis=0), k, out=np.zeros(k.shape), where=k > 0)
        m2 = np.where(m, (x - mean) ** 2, 0.0).sum(axis=0)
        n = self.n + k
        delta = mean - self.mean
        w = np.divide(k, n, out=np.zeros(k.shape), where=n > 0)
        self.mean = self.mean + delta * w
        self.m2 = self.m2 + m2 + delta**2 * self.n * w
        self.n = n

    @property
    def std(self):
        """The standard deviation per element (NaN where no sample was added)."""
        n = np.asarray(self.n, dtype=float)
        return np.sqrt(np.divide(self.m2, n, out=np.full(np.broadcast(self.m2, n).shape, np.nan), where=n > 0))


def phase_groups(rec: Recording) -> tuple[list[str], np.ndarray]:
    """The distinct phase names in order of first appearance and, per phase index, its name's position: phases
    of one name are one row of the per-phase tables (a ground robot's many ``ct`` segments are one motion type)."""
    names = list(dict.fromkeys(rec.phase_names))
    return names, np.asarray([names.index(p) for p in rec.phase_names] or [0], dtype=np.int64)


def target_distances(rec: Recording) -> np.ndarray:
    """(K, N) true distance of every UAV to the tracked target (whole run in memory: for plots)."""
    return np.linalg.norm(rec.uav[:, :, :2] - rec.target[:, None, :2], axis=-1)


def pair_distances(rec: Recording) -> np.ndarray:
    """(K, P) true distance of every UAV pair (i < j) (whole run in memory: for plots of small swarms)."""
    return pairs_of(rec.uav[:, :, :2])


def pairs_of(q: np.ndarray) -> np.ndarray:
    """(k, P) distances of every pair i < j, positions (k, N, 2)."""
    i, j = np.triu_indices(q.shape[1], 1)
    return np.linalg.norm(q[:, i] - q[:, j], axis=-1)


def spacing(rec: Recording, last: float = 10.0) -> dict:
    """Inter-agent spacing (L23 Fig. 1, L24 Fig. 7), streamed.

    ``min``: smallest distance of any pair at any step. ``offset``: steady-state distance offset, the mean over
    the pairs that are neighbours at the end (mean distance over the last ``last`` seconds below r_comm) of
    ``|mean distance − d|``; flocking regulates neighbours only (a_ij = 0 beyond r_comm), so a chain whose outer
    pair lies beyond r_comm is a valid α-lattice, not an offset: ``open_pairs`` counts such pairs.
    ``overshoot``: largest ``|distance − d|`` of any pair after that pair's distance first crosses d.

    Above :data:`ALL_PAIRS_UP_TO` UAVs: ``min`` from each step's nearest neighbours, ``offset`` the mean over
    the last ``last`` seconds of the mean ``|distance − d|`` over each step's neighbour pairs, and no
    ``open_pairs``/``overshoot`` (None): they follow pairs through time, which a large swarm's changing
    neighbourhoods do not define.

    The accumulator (:func:`spacing_accumulator`) reads the truth only; :func:`summary` feeds it in its own pass.
    """
    acc = spacing_accumulator(rec, last)
    for c in rec.chunks(probes_wanted=False):
        acc.add(c, None, None)
    return acc.result()


def spacing_accumulator(rec: Recording, last: float = 10.0):
    """The accumulator of :func:`spacing` (``add(chunk, keep, shared)``, ``result()``): every pair followed up to
    :data:`ALL_PAIRS_UP_TO` UAVs, each step's close pairs above."""
    if rec.n_agents < 2:
        return _NoSpacing()
    return _PairSpacing(rec, last) if rec.n_agents <= ALL_PAIRS_UP_TO else _NeighbourSpacing(rec, last)


class _NoSpacing:
    def add(self, c: Chunk, keep, shared) -> None:
        pass

    def result(self) -> dict:
        return {"min": None, "offset": None, "open_pairs": 0, "overshoot": None}


class _PairSpacing:
    """Every pair's distance, followed through time (small swarms)."""

    def __init__(self, rec: Recording, last: float):
        n = rec.n_agents
        self.rec, self.tail_from = rec, rec.t_last - last
        self.d_min, self.tail_sum, self.tail_n = np.inf, 0.0, 0
        self.last_sign = None  # sign of each pair's deviation at the last step seen (carried across chunks)
        self.crossed = np.zeros(n * (n - 1) // 2, dtype=bool)
        self.over = np.zeros(n * (n - 1) // 2)

    def add(self, c: Chunk, keep, shared) -> None:
        rec = self.rec
        if not len(c.t):
            return
        dist = pairs_of(c.truth[:, rec.uav_slice, :2])  # NaN: a replayed UAV without navigation at that step
        known = np.isfinite(dist)
        if known.any():
            self.d_min = min(self.d_min, float(dist[known].min()))
        tail = (c.t >= self.tail_from)[:, None] & known
        self.tail_sum = self.tail_sum + np.where(tail, dist, 0.0).sum(axis=0)
        self.tail_n = self.tail_n + tail.sum(axis=0)
        dev = dist[chase_window(rec, c.t)] - rec.d
        if not len(dev):
            return
        # a pair counts from the step after its first sign change (the crossing of d) on
        sign = np.sign(dev)
        before = sign[:1] if self.last_sign is None else self.last_sign[None]
        changed = np.concatenate([before, sign[:-1]]) != sign  # (k, P): changed at this step
        counted = self.crossed[None] | np.logical_or.accumulate(changed, axis=0)
        self.over = np.maximum(self.over, np.where(counted & np.isfinite(dev), np.abs(dev), 0.0).max(axis=0))
        self.crossed, self.last_sign = counted[-1], sign[-1]

    def result(self) -> dict:
        rec = self.rec
        mean = np.divide(self.tail_sum, self.tail_n, out=np.full(np.shape(self.tail_sum), np.inf),
                         where=np.asarray(self.tail_n) > 0)
        near = mean < rec.r_comm
        return {"min": self.d_min if np.isfinite(self.d_min) else None,
                "offset": float(np.mean(np.abs(mean[near] - rec.d))) if near.any() else float("nan"),
                "open_pairs": int(np.sum(~near)), "overshoot": float(self.over.max())}


class _NeighbourSpacing:
    """Each step's pairs closer than r_comm (large swarms): from a grid of cells, :func:`close_pairs`."""

    def __init__(self, rec: Recording, last: float):
        self.rec, self.tail_from = rec, rec.t_last - last
        self.d_min = np.inf
        self.offsets: list = []

    def add(self, c: Chunk, keep, shared) -> None:
        rec = self.rec
        q = c.truth[:, rec.uav_slice, :2]
        tail = c.t >= self.tail_from
        best, total, count = close_pairs(q, rec.r_comm, rec.d, nearest=~tail)  # before the tail: the nearest pair
        for b, s, n, in_tail, step in zip(best, total, count, tail, q, strict=True):
            # no pair closer than r_comm: the nearest pair is farther, found by a KD-tree (rare: a scattered swarm)
            self.d_min = min(self.d_min, float(b) if np.isfinite(b) else _nearest_pair(step))
            if in_tail and n:
                self.offsets.append(float(s / n))

    def result(self) -> dict:
        return {"min": self.d_min, "offset": float(np.mean(self.offsets)) if self.offsets else float("nan"),
                "open_pairs": None, "overshoot": None}


def _nearest_pair(q: np.ndarray) -> float:
    """The smallest distance between two of the positions ``q`` (n, 2), n ≥ 2 (KD-tree)."""
    from scipy.spatial import cKDTree  # scipy's import costs a run 0.3-0.9 s: only where needed

    return float(cKDTree(q).query(q, k=2)[0][:, 1].min())


def close_pairs(q: np.ndarray, r, d: float, nearest=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per step of the positions ``q`` (k, n, 2), over the pairs closer than ``r`` (> 0; one for all steps or one
    per step): the smallest distance (inf: no such pair), the sum of ``|distance − d|`` and their count, as three
    (k,) arrays. O(n + pairs) per step (compiled, :func:`_close_pairs`); the distances are ``sqrt(dx² + dy²)`` as
    ``np.linalg.norm`` gives them, the sums in another order than numpy's (equal to round-off). ``nearest`` (k,)
    marks the steps of which only the smallest distance is wanted: they are searched first within a few times the
    smallest distance of the step before (a contracted swarm has hundreds of pairs within r), and their sum and
    count are of the pairs within the radius that found it. Positions that are not all finite, or spread over more
    cells than 64-bit keys hold, are measured by a KD-tree instead (which refuses non-finite positions)."""
    q = np.ascontiguousarray(q, dtype=float)
    k, n = q.shape[:2]
    r = np.ascontiguousarray(np.broadcast_to(np.asarray(r, dtype=float), (k,)))
    if n >= 2 and k and np.isfinite(q).all():
        cells = (q.max(axis=1) - q.min(axis=1)) / r[:, None] + 3.0  # cells along x and y, with the margins
        if float((cells[:, 0] * cells[:, 1]).max()) < _KEYS:
            only = np.zeros(k, dtype=bool) if nearest is None else np.asarray(nearest, dtype=bool)
            return _close_pairs_kernel()(q, r, float(d), np.ascontiguousarray(only))
    best, total, count = np.full(k, np.inf), np.zeros(k), np.zeros(k, dtype=np.int64)
    if n < 2:
        return best, total, count
    from scipy.spatial import cKDTree

    for i, step in enumerate(q):
        pairs = cKDTree(step).query_pairs(r[i], output_type="ndarray")
        dist = np.linalg.norm(step[pairs[:, 0]] - step[pairs[:, 1]], axis=1)
        dist = dist[dist < r[i]]
        if len(dist):
            best[i], total[i], count[i] = dist.min(), np.abs(dist - d).sum(), len(dist)
    return best, total, count


#: Fewer cells than this (with the margins) number their keys in 64 bits.
_KEYS = 2.0**62
#: A nearest-only step of :func:`close_pairs` is first searched within this many times the step before's smallest
#: distance (then within r if no pair is that close).
_NEAREST_REACH = 4.0
#: The cells of :func:`_close_pairs` are this much wider than r: a pair closer than r is always in the same or
#: neighbouring cells, whatever the rounding of the cell indices.
_CELL_MARGIN = 1.0 + 1e-9


@functools.cache
def _close_pairs_kernel():
    """:func:`_close_pairs` compiled (numba, imported on first use; cached on disk like the simulator's kernels) for
    C-contiguous arrays, read-only or not (one signature: a chunk read from disk has read-only arrays, one in memory
    writable ones, and each compilation costs seconds)."""
    import numba
    from numba import types

    def array(ndim: int, dtype=types.float64):
        return types.Array(dtype, ndim, "C", readonly=True)

    out = types.Array(types.float64, 1, "C")
    signature = types.Tuple((out, out, types.Array(types.int64, 1, "C")))(array(3), array(1), types.float64,
                                                                        array(1, types.boolean))
    return numba.njit([signature], cache=True, fastmath=False)(_close_pairs)


def _close_pairs(q, r, d, nearest):
    """:func:`close_pairs` on finite positions (k, n ≥ 2, 2): per step, the points are sorted into square cells of
    width the radius (a hair wider) by the key ``cx·w + cy`` (a counting sort, or a radix sort when the cells far
    outnumber the points); each point is compared with the points after it in its own cell and in the cell above,
    and with the three cells of the next column, so that every pair of neighbouring cells is visited once. The keys
    of those cells are consecutive, so three pointers that only move forward find them."""
    k, n = q.shape[0], q.shape[1]
    best, total, count = np.full(k, np.inf), np.zeros(k), np.zeros(k, dtype=np.int64)
    cx, cy = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
    skey, order = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)
    xs, ys = np.empty(n), np.empty(n)
    before = np.inf  # the step before's smallest distance
    for step in range(k):
        x0, y0, x1, y1 = q[step, 0, 0], q[step, 0, 1], q[step, 0, 0], q[step, 0, 1]
        for i in range(n):
            x0, y0 = min(x0, q[step, i, 0]), min(y0, q[step, i, 1])
            x1, y1 = max(x1, q[step, i, 0]), max(y1, q[step, i, 1])
        rs = r[step]
        if nearest[step] and _NEAREST_REACH * before < rs:
            reach = max(_NEAREST_REACH * before, rs * 1e-6)
            if ((x1 - x0) / reach + 3.0) * ((y1 - y0) / reach + 3.0) < _KEYS:
                rs = reach
        while True:
            h = rs * _CELL_MARGIN
            right, top = 0, 0
            for i in range(n):
                cx[i] = int(math.floor((q[step, i, 0] - x0) / h))
                cy[i] = int(math.floor((q[step, i, 1] - y0) / h)) + 1
                right, top = max(right, cx[i]), max(top, cy[i])
            w = top + 2  # cy in 1..top: the cells below and above a point's never wrap into another column
            cells = (right + 1) * w
            if cells <= 8 * n + 1024:  # counting sort, points of a cell in their order
                start = np.zeros(cells + 1, dtype=np.int64)
                for i in range(n):
                    start[cx[i] * w + cy[i] + 1] += 1
                for c in range(cells):
                    start[c + 1] += start[c]
                for i in range(n):
                    c = cx[i] * w + cy[i]
                    order[start[c]] = i
                    start[c] += 1
            else:  # far more cells than points (a narrow search): a radix sort of the keys, 11 bits a pass
                for i in range(n):
                    skey[i], order[i] = cx[i] * w + cy[i], i
                shift, digits, other = 0, np.empty(2049, dtype=np.int64), np.empty(n, dtype=np.int64)
                while (cells - 1) >> shift:
                    digits[:] = 0
                    for i in range(n):
                        digits[((skey[order[i]] >> shift) & 2047) + 1] += 1
                    for c in range(2048):
                        digits[c + 1] += digits[c]
                    for i in range(n):
                        c = (skey[order[i]] >> shift) & 2047
                        other[digits[c]] = order[i]
                        digits[c] += 1
                    order[:] = other
                    shift += 11
            for s in range(n):
                i = order[s]
                skey[s], xs[s], ys[s] = cx[i] * w + cy[i], q[step, i, 0], q[step, i, 1]
            lo_best, lo_total, lo_count = np.inf, 0.0, 0
            near = rs * rs * _CELL_MARGIN  # squared: only a pair this close is worth its square root
            e = a = b = 0
            for s in range(n):
                c = skey[s]
                while e < n and skey[e] <= c + 1:  # own cell and the one above
                    e += 1
                while a < n and skey[a] < c + w - 1:  # next column: the cells below, beside and above
                    a += 1
                b = max(a, b)
                while b < n and skey[b] <= c + w + 1:
                    b += 1
                for part in range(2):
                    lo, hi = (s + 1, e) if part == 0 else (a, b)
                    for j in range(lo, hi):
                        dx, dy = xs[j] - xs[s], ys[j] - ys[s]
                        sq = dx * dx + dy * dy
                        if sq > near:
                            continue
                        dist = math.sqrt(sq)
                        if dist < rs:
                            lo_best = min(lo_best, dist)
                            lo_total += abs(dist - d)
                            lo_count += 1
            if lo_count or rs >= r[step]:
                break
            rs = r[step]  # no pair that close: search within r
        best[step], total[step], count[step] = lo_best, lo_total, lo_count
        before = lo_best
    return best, total, count


def spacing_offset(rec: Recording, last: float = 10.0) -> float:
    """Steady-state inter-agent distance offset (see :func:`spacing`)."""
    return spacing(rec, last)["offset"]


def open_pairs(rec: Recording, last: float = 10.0) -> int:
    """Pairs that end beyond r_comm (not neighbours): a chain instead of a closed formation."""
    return spacing(rec, last)["open_pairs"]


def spacing_overshoot(rec: Recording) -> float:
    """Largest ``|distance − d|`` of any pair after that pair's distance first crosses d (L23 Fig. 1)."""
    return spacing(rec)["overshoot"]

def min_separations(q: np.ndarray) -> np.ndarray:
    """(k,) smallest distance between any two of the N positions ``q`` (k, N, 2) at each step (inf for N < 2): all
    pairs, a block of steps at a time, up to :data:`ALL_PAIRS_UP_TO` UAVs, else each step's nearest neighbours from
    a KD-tree."""
    k, n = q.shape[:2]
    if n < 2:
        return np.full(k, np.inf)
    if n > ALL_PAIRS_UP_TO:
        from scipy.spatial import cKDTree  # scipy's import costs a run 0.3-0.9 s: only for large swarms

        return np.array([cKDTree(step).query(step, k=2)[0][:, 1].min() for step in q])
    block = max(1, (1 << 20) // (n * (n - 1) // 2))
    return np.concatenate([pairs_of(q[s:s + block]).min(axis=1) for s in range(0, k, block)])


class TargetDistance:
    """True distance of every UAV to the tracked target: mean and max over the chase window."""

    def __init__(self, rec: Recording):
        self.rec, self.total, self.n, self.far = rec, 0.0, 0, 0.0

    def add(self, c: Chunk, keep: np.ndarray, shared=None) -> None:
        truth = c.truth if keep.all() else c.truth[keep]
        off = truth[:, self.rec.uav_slice, :2] - truth[:, self.rec.tracked, None, :2]
        dist = np.sqrt(off[..., 0] ** 2 + off[..., 1] ** 2)  # np.linalg.norm(off, axis=-1), bit for bit
        known = np.isfinite(dist)  # a replayed log: truth only where it holds ground truth
        if not known.all():
            dist = dist[known]
        self.total += float(dist.sum())
        self.n += dist.size
        self.far = max(self.far, float(dist.max())) if dist.size else self.far

    def result(self) -> dict:
        return {"mean": self.total / self.n if self.n else None, "max": self.far if self.n else None}

    def samples(self) -> int:
        return self.n


def series_bin_width(t_last: float) -> float:
    """Width (s) of a run's time-series bins: 1 s, doubled until a run of ``t_last`` seconds fits in
    :data:`SERIES_MAX_BINS` bins. Powers of two, so the bins of runs of different lengths nest (``summarize``
    merges finer bins into the coarsest run's)."""
    width = 1.0
    while t_last / width + 1 > SERIES_MAX_BINS:
        width *= 2.0
    return width

class Series:
    """Per-bin means over fixed time bins ``[k·w, (k+1)·w)``, ``w`` = :func:`series_bin_width` (bins start at
    t = 0 whatever the chunking, so they do not depend on the recording's chunk size), from t = 0 on (the
    initialisation included, which the scalar metrics leave out), of the quantities of ``parts``: the run's kinds'
    :data:`SERIES` accumulators (see the module's protocol), e.g. ``position_error`` and ``nees`` of a Gaussian
    estimator, ``tracking_error`` of the formation MPC, ``phi_bar`` and its parts of a set-membership estimator.

    ``t`` holds the bin centres; a bin without data is None."""

    def __init__(self, rec: Recording, parts: list | None = None):
        self.rec = rec
        self.parts = list(series_parts(rec) if parts is None else parts)
        self.width = series_bin_width(rec.t_last)
        self.n_bins = int(np.floor(rec.t_last / self.width + 1e-9)) + 1
        self.quantities = [q for part in self.parts for q in part.quantities]
        self.sum = {q: np.zeros(self.n_bins) for q in self.quantities}
        self.count = {q: np.zeros(self.n_bins) for q in self.quantities}

    def _bins(self, t: np.ndarray) -> np.ndarray:
        return np.minimum(np.floor(t / self.width + 1e-9).astype(np.int64), self.n_bins - 1)

    def _add(self, q: str, t: np.ndarray, values: np.ndarray) -> None:
        b = self._bins(t)
        self.sum[q] += np.bincount(b, weights=values, minlength=self.n_bins)
        self.count[q] += np.bincount(b, minlength=self.n_bins)

    def add(self, c: Chunk, keep, shared=None) -> None:
        for part in self.parts:
            got = part.values(c, shared) if getattr(part, "shares", False) else part.values(c)
            for q, (t, values) in got.items():
                self._add(q, t, values)

    def result(self) -> dict:
        out = {"bin_s": self.width, "t": ((np.arange(self.n_bins) + 0.5) * self.width).tolist()}
        for q in self.quantities:
            n = self.count[q]
            mean = self.sum[q] / np.maximum(n, 1)
            out[q] = [float(v) if k and np.isfinite(v) else None for v, k in zip(mean, n, strict=True)]
        return out


def _applying(rec: Recording, kinds: list[registry.Kind], attr: str) -> list[registry.Metric]:
    """The entries ``attr`` (``metrics`` or ``health``) of ``kinds`` that apply to ``rec``, the first of each
    section (a section two kinds register is computed once)."""
    seen, out = set(), []
    for kind in kinds:
        for m in getattr(kind, attr):
            if m.section not in seen and m.applies(rec):
                seen.add(m.section)
                out.append(m)
    return out


def series_parts(rec: Recording, kinds: list[registry.Kind] | None = None) -> list:
    """The accumulators of the time-series parts the run's kinds register (:data:`SERIES` sections)."""
    kinds = run_kinds(rec) if kinds is None else kinds
    return [registry.resolve(m.make)(rec) for kind in kinds for m in kind.metrics
            if m.section == SERIES and m.applies(rec)]


def _scan(rec: Recording, accumulators: list) -> list:
    """One pass over the recording's chunks feeding every accumulator. A diverged filter's NaN and infinite numbers
    stay in the sections and are named by the health checks, not by numpy's floating-point warnings."""
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        for c in rec.chunks():
            keep = chase_window(rec, c.t)
            shared: dict = {}  # what several accumulators compute from this chunk, computed once (e.g. the errors)
            for m in accumulators:
                m.add(c, keep, shared)
        return [m.result() for m in accumulators]


def section(rec: Recording, name: str):
    """One section of :func:`summary` computed alone, from the run's kinds (None: no kind of the run registers it)."""
    for m in _applying(rec, run_kinds(rec), "metrics"):
        if m.section == name:
            return _scan(rec, [registry.resolve(m.make)(rec)])[0]
    return None


def rmse_table(rec: Recording) -> dict[str, dict[str, float]]:
    """RMSE per phase and in total, per component, mean over UAVs (L24 Tables 1-3), in metres and m/s."""
    return section(rec, "rmse")


def spread_table(rec: Recording) -> dict[str, float]:
    """Standard deviation over time of each UAV's estimation error, mean over UAVs (L23 Table 1)."""
    return section(rec, "spread")


def reported_std(rec: Recording) -> dict[str, float]:
    """The filters' own standard deviation ``sqrt(P_ii)``, mean over time and UAVs (compare with the spread)."""
    return section(rec, "reported_std")


def nees(rec: Recording) -> float:
    """Mean normalised estimation error squared of [x, y, vx, vy] (4 for a consistent filter)."""
    return section(rec, "consistency")["total"]["nees"]


def series(rec: Recording) -> dict:
    """The run's time series (see :class:`Series`): ``bin_s``, ``t`` (bin centres, s) and each quantity the run's
    kinds register, one value per bin (None: no data in that bin)."""
    return _scan(rec, [Series(rec)])[0]


def summary(rec: Recording) -> dict:
    """All scalar metrics of one run, JSON-ready, in one pass over the recording (health checks and spacing
    included): the sections every run gets (``target_distance`` with a followed target, ``inter_agent_distance``,
    ``liar_uav`` when a member lied), the sections the run's kinds register (:func:`run_kinds`; e.g. a Gaussian
    estimator's ``rmse``, ``spread``, ``reported_std``, ``consistency``, ``mean_error``, a set-membership
    estimator's ``set_membership``, the formation MPC's ``formation``: see each capability's ``metrics`` module),
    the run's ``warnings`` (the kinds' health checks, then the warnings of their sections, in the order of the
    kinds: sensor, estimator, controller, then the samples that did not come) and its compact time series ``series``
    (:func:`series`: at most :data:`SERIES_MAX_BINS` values per quantity). ``coverage``
    (:class:`~swarmtrack.analysis.coverage.Presence`) says which samples the numbers cover: a sample that did not
    come and a step without ground truth are left out of every section, never counted as errors."""
    kinds = run_kinds(rec)
    accs = {m.section: registry.resolve(m.make)(rec) for m in _applying(rec, kinds, "metrics")
            if m.section != SERIES}
    checks = [registry.resolve(h.make)(rec) for h in _applying(rec, kinds, "health")]
    if rec.tracked is not None:
        accs["target_distance"] = TargetDistance(rec)
    accs[SERIES] = Series(rec, series_parts(rec, kinds))
    accs["coverage"] = presence = Presence(rec)
    results = _scan(rec, [*accs.values(), *checks, spacing_accumulator(rec)])
    sections, checked, spaced = results[:len(accs)], results[len(accs):-1], results[-1]
    out: dict[str, Any] = {"warnings": [w for ws in checked for w in ws]}
    out.update(zip(accs, sections, strict=True))
    for acc in accs.values():
        if hasattr(acc, "warnings") and acc is not presence:  # presence's last: it reads the sections
            out["warnings"] += acc.warnings()
        if hasattr(acc, "extras"):
            out.update(acc.extras())
    if rec.meta.get("liar") is not None:  # which UAV lied (network.liar), 1-based: the others are the honest ones
        out["liar_uav"] = rec.meta["liar"] + 1
    out["inter_agent_distance"] = spaced
    out["coverage"]["sections"] = {name: acc.samples() for name, acc in accs.items() if hasattr(acc, "samples")}
    out["warnings"] += presence.warnings(out)
    return out


def warnings(rec: Recording) -> list[dict]:
    """The warnings of one run (empty: nothing looked wrong), as :func:`summary` gives them."""
    return summary(rec)["warnings"]
