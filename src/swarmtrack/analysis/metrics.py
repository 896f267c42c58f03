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
swarms over the neighbour pairs (closer than r_comm) of each step, from a KD-tree (see :func:`spacing`).
The time series (:func:`series`) are per-bin means over fixed time bins, O(bins) per quantity.

**The accumulator protocol.** A registered section's ``make(recording)`` gives an object with ``add(chunk, keep,
err)`` (every chunk of the recording in order; ``keep``: the chunk's steps in the judged window; ``err`` is None:
an accumulator reads the probes it needs from the chunk) and ``result()`` (the section). Optionally ``warnings()``
(a list of warning dicts added to the run's ``warnings``) and ``extras()`` (more top-level keys, e.g. the run-wide
``nees`` beside its ``consistency`` section). A health check's ``result()`` is its list of warnings. A section
registered as :data:`SERIES` is a part of the time series: its accumulator has ``quantities`` (their names) and
``values(chunk)`` → ``{quantity: (t, values)}`` (one value per time ``t`` to average into the bins).
"""

from __future__ import annotations

import numpy as np

from swarmtrack import registry
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

    def add(self, x: np.ndarray) -> None:
        """Add samples along axis 0."""
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

    @property
    def std(self):
        return np.sqrt(self.m2 / self.n)


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
    """
    n = rec.n_agents
    if n < 2:
        return {"min": None, "offset": None, "open_pairs": 0, "overshoot": None}
    if n > ALL_PAIRS_UP_TO:
        return _neighbour_spacing(rec, last)
    tail_from = rec.t_last - last
    d_min, tail_sum, tail_n = np.inf, 0.0, 0
    last_sign = None  # sign of each pair's deviation at the last step seen (carried across chunks)
    crossed = np.zeros(n * (n - 1) // 2, dtype=bool)
    over = np.zeros(n * (n - 1) // 2)
    for c in rec.chunks(probes_wanted=False):
        dist = pairs_of(c.truth[:, rec.uav_slice, :2])
        d_min = min(d_min, float(dist.min()))
        tail = c.t >= tail_from
        tail_sum = tail_sum + dist[tail].sum(axis=0)
        tail_n += int(tail.sum())
        dev = dist[chase_window(rec, c.t)] - rec.d
        if not len(dev):
            continue
        # a pair counts from the step after its first sign change (the crossing of d) on
        sign = np.sign(dev)
        before = sign[:1] if last_sign is None else last_sign[None]
        changed = np.concatenate([before, sign[:-1]]) != sign  # (k, P): changed at this step
        counted = crossed[None] | np.logical_or.accumulate(changed, axis=0)
        over = np.maximum(over, np.where(counted, np.abs(dev), 0.0).max(axis=0))
        crossed, last_sign = counted[-1], sign[-1]
    mean = tail_sum / tail_n
    near = mean < rec.r_comm
    return {"min": d_min, "offset": float(np.mean(np.abs(mean[near] - rec.d))) if near.any() else float("nan"),
            "open_pairs": int(np.sum(~near)), "overshoot": float(over.max())}


def _neighbour_spacing(rec: Recording, last: float) -> dict:
    from scipy.spatial import cKDTree

    tail_from = rec.t_last - last
    d_min, offsets = np.inf, []
    for c in rec.chunks(probes_wanted=False):
        for t, q in zip(c.t, c.truth[:, rec.uav_slice, :2], strict=True):
            tree = cKDTree(q, balanced_tree=False, compact_nodes=False)  # faster to build, same answers
            d_min = min(d_min, float(tree.query(q, k=2)[0][:, 1].min()))  # each UAV's nearest other UAV
            if t >= tail_from:
                pairs = tree.query_pairs(rec.r_comm, output_type="ndarray")
                dist = np.linalg.norm(q[pairs[:, 0]] - q[pairs[:, 1]], axis=1)
                near = dist < rec.r_comm
                if near.any():
                    offsets.append(float(np.mean(np.abs(dist[near] - rec.d))))
    return {"min": d_min, "offset": float(np.mean(offsets)) if offsets else float("nan"), "open_pairs": None,
            "overshoot": None}


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

    def add(self, c: Chunk, keep: np.ndarray, err) -> None:
        truth = c.truth[keep]
        dist = np.linalg.norm(truth[:, self.rec.uav_slice, :2] - truth[:, self.rec.tracked, None, :2], axis=-1)
        self.total += float(dist.sum())
        self.n += dist.size
        self.far = max(self.far, float(dist.max())) if dist.size else self.far

    def result(self) -> dict:
        return {"mean": self.total / self.n, "max": self.far}


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

    def add(self, c: Chunk, keep, err) -> None:
        for part in self.parts:
            for q, (t, values) in part.values(c).items():
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
    """One pass over the recording's chunks feeding every accumulator."""
    for c in rec.chunks():
        keep = chase_window(rec, c.t)
        for m in accumulators:
            m.add(c, keep, None)
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
    """All scalar metrics of one run, JSON-ready, in one pass over the recording (and one over its truth for the
    spacing): the sections every run gets (``target_distance`` with a followed target, ``inter_agent_distance``,
    ``liar_uav`` when a member lied), the sections the run's kinds register (:func:`run_kinds`; e.g. a Gaussian
    estimator's ``rmse``, ``spread``, ``reported_std``, ``consistency``, ``mean_error``, a set-membership
    estimator's ``set_membership``, the formation MPC's ``formation``: see each capability's ``metrics`` module),
    the run's ``warnings`` (the kinds' health checks, then the warnings of their sections, in the order of the
    kinds: sensor, estimator, controller) and its compact time series ``series`` (:func:`series`: at most
    :data:`SERIES_MAX_BINS` values per quantity)."""
    kinds = run_kinds(rec)
    accs = {m.section: registry.resolve(m.make)(rec) for m in _applying(rec, kinds, "metrics")
            if m.section != SERIES}
    checks = [registry.resolve(h.make)(rec) for h in _applying(rec, kinds, "health")]
    if rec.tracked is not None:
        accs["target_distance"] = TargetDistance(rec)
    accs[SERIES] = Series(rec, series_parts(rec, kinds))
    results = _scan(rec, [*accs.values(), *checks])
    sections, checked = results[:len(accs)], results[len(accs):]
    out = {"warnings": [w for ws in checked for w in ws]}
    out.update(zip(accs, sections, strict=True))
    for acc in accs.values():
        if hasattr(acc, "warnings"):
            out["warnings"] += acc.warnings()
        if hasattr(acc, "extras"):
            out.update(acc.extras())
    if rec.meta.get("liar") is not None:  # which UAV lied (network.liar), 1-based: the others are the honest ones
        out["liar_uav"] = rec.meta["liar"] + 1
    out["inter_agent_distance"] = spacing(rec)
    return out


def warnings(rec: Recording) -> list[dict]:
    """The warnings of one run (empty: nothing looked wrong), as :func:`summary` gives them."""
    return summary(rec)["warnings"]
