"""Metrics computed from a :class:`Recording` (truth is allowed here: this is the evaluation side).

Conventions (L24 Tables 1-3, L23 Table 1): a statistic is computed per UAV and then averaged over the UAVs.
Steps before the chase starts (the first 20 filter iterations, when the filter starts from no information)
are left out of the RMSE and spread, so that the numbers describe tracking, not initialisation.

Every metric streams over the recording's chunks (:meth:`Recording.chunks`) with accumulators of O(N) per
quantity (O(pairs) for the spacing metrics), never steps × N, so it works on recordings larger than memory.
Inter-agent spacing is measured over every pair for swarms of up to :data:`ALL_PAIRS_UP_TO` UAVs; for larger
swarms over the neighbour pairs (closer than r_comm) of each step, from a KD-tree (see :func:`spacing`).
The time series (:func:`series`) are per-bin means over fixed time bins, O(bins) per quantity.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.analysis import health
from swarmtrack.analysis.health import chi2_mean_band
from swarmtrack.sim.recorder import Chunk, Recording

COMPONENTS = ("x", "y", "vx", "vy")
#: Up to this many UAVs the spacing metrics follow every pair (P = N(N−1)/2 accumulators).
ALL_PAIRS_UP_TO = 64
#: Two UAVs closer than this (m) have collided: an Iris-sized quadrotor spans about 0.55 m.
COLLISION_M = 0.5
#: A run's time series have at most this many bins (:func:`series_bin_width`).
SERIES_MAX_BINS = 200


def _window(rec: Recording, t: np.ndarray) -> np.ndarray:
    """Steps after the chase starts (all steps if it never does, judged on the whole run)."""
    if rec.t_last < rec.chase_start - 1e-9:
        return np.ones(len(t), dtype=bool)
    return t >= rec.chase_start - 1e-9


def _errors(rec: Recording, c: Chunk) -> np.ndarray:
    """(k, N, 4) estimate minus truth of the tracked target's [x, y, vx, vy]."""
    return c.probes["estimate"][..., :4] - c.truth[:, rec.tracked, None, :]


def errors(rec: Recording) -> np.ndarray:
    """(K, N, 4) estimate minus truth of [x, y, vx, vy] (whole run in memory: for plots of small runs)."""
    return rec.estimate - rec.target[:, None, :]


class _Moments:
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


def _phase_groups(rec: Recording) -> tuple[list[str], np.ndarray]:
    """The distinct phase names in order of first appearance and, per phase index, its name's position: phases
    of one name are one row of the per-phase tables (a ground robot's many ``ct`` segments are one motion type)."""
    names = list(dict.fromkeys(rec.phase_names))
    return names, np.asarray([names.index(p) for p in rec.phase_names] or [0], dtype=np.int64)


class _Rmse:
    """Squared errors per phase, UAV and component (L24 Tables 1-3)."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.names, self.group = _phase_groups(rec)
        self.sq = np.zeros((len(self.names) + 1, rec.n_agents, 4))
        self.count = np.zeros(len(self.names) + 1)

    def add(self, c: Chunk, keep: np.ndarray, err: np.ndarray) -> None:
        e2 = err ** 2
        phase = self.group[c.phase[keep, self.rec.tracked]]
        for p in np.unique(phase):
            sel = phase == p
            self.sq[p] += e2[sel].sum(axis=0)
            self.count[p] += sel.sum()
        self.sq[-1] += e2.sum(axis=0)
        self.count[-1] += len(e2)

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
        self.mom = _Moments()

    def add(self, c: Chunk, keep: np.ndarray, err: np.ndarray) -> None:
        self.mom.add(err)

    def result(self) -> dict[str, float]:
        return dict(zip(COMPONENTS, self.mom.std.mean(axis=0).tolist(), strict=True))


class _ReportedStd:
    """The filters' own standard deviation ``sqrt(P_ii)``, mean over time and UAVs."""

    def __init__(self, rec: Recording):
        self.total, self.n = 0.0, 0

    def add(self, c: Chunk, keep: np.ndarray, err: np.ndarray) -> None:
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
        self.names, self.group = _phase_groups(rec)
        k = len(self.names) + 1
        self.full, self.comp, self.count = np.zeros(k), np.zeros((k, 4)), np.zeros(k)
        self.nis, self.nis_count = np.zeros(k), np.zeros(k)

    def add(self, c: Chunk, keep: np.ndarray, err: np.ndarray) -> None:
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


def _scan(rec: Recording, metrics: list) -> list:
    """One pass over the recording's chunks feeding every accumulator the chase-window errors."""
    for c in rec.chunks():
        keep = _window(rec, c.t)
        err = _errors(rec, c)[keep] if "estimate" in c.probes and rec.tracked is not None else None
        for m in metrics:
            m.add(c, keep, err)
    return [m.result() for m in metrics]


def rmse_table(rec: Recording) -> dict[str, dict[str, float]]:
    """RMSE per phase and in total, per component, mean over UAVs (L24 Tables 1-3), in metres and m/s."""
    return _scan(rec, [_Rmse(rec)])[0]


def spread_table(rec: Recording) -> dict[str, float]:
    """Standard deviation over time of each UAV's estimation error, mean over UAVs (L23 Table 1)."""
    return _scan(rec, [_Spread(rec)])[0]


def reported_std(rec: Recording) -> dict[str, float]:
    """The filters' own standard deviation ``sqrt(P_ii)``, mean over time and UAVs (compare with the spread)."""
    return _scan(rec, [_ReportedStd(rec)])[0]


def nees(rec: Recording) -> float:
    """Mean normalised estimation error squared of [x, y, vx, vy] (4 for a consistent filter)."""
    return _scan(rec, [_Consistency(rec)])[0]["total"]["nees"]


def target_distances(rec: Recording) -> np.ndarray:
    """(K, N) true distance of every UAV to the tracked target (whole run in memory: for plots)."""
    return np.linalg.norm(rec.uav[:, :, :2] - rec.target[:, None, :2], axis=-1)


def pair_distances(rec: Recording) -> np.ndarray:
    """(K, P) true distance of every UAV pair (i < j) (whole run in memory: for plots of small swarms)."""
    return _pairs_of(rec.uav[:, :, :2])


def _pairs_of(q: np.ndarray) -> np.ndarray:
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
        dist = _pairs_of(c.truth[:, rec.uav_slice, :2])
        d_min = min(d_min, float(dist.min()))
        tail = c.t >= tail_from
        tail_sum = tail_sum + dist[tail].sum(axis=0)
        tail_n += int(tail.sum())
        dev = dist[_window(rec, c.t)] - rec.d
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


class _TargetDistance:
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


class _MeanError:
    """W20 eq. 4.41 (with the truth it omits): the mean distance between each UAV's estimate and the target's
    position, mean over UAVs; also over the steps where no UAV detected the target (W20 Table 4.5's occlusions)."""

    def __init__(self, rec: Recording):
        self.total, self.n, self.occluded, self.n_occluded, self.steps_occluded = 0.0, 0, 0.0, 0, 0

    def add(self, c: Chunk, keep: np.ndarray, err: np.ndarray) -> None:
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


class _ModelUse:
    """Which team member's estimate each UAV's output used (the ``winner`` probe: T-test winner, or the most
    probable filter): the share of steps per member and the count of switches per UAV (W20 Fig. 4.9 counts 36)."""

    def __init__(self, rec: Recording):
        self.counts = np.zeros(rec.n_agents)
        self.switches = 0.0

    def add(self, c: Chunk, keep: np.ndarray, err) -> None:
        winner = c.probes["winner"][keep].astype(np.int64)  # 1-based, 0: none
        self.counts += np.bincount(winner.ravel(), minlength=len(self.counts) + 1)[1:len(self.counts) + 1]
        if len(winner):
            self.switches = float(c.probes["switches"][keep][-1].mean())

    def result(self) -> dict:
        total = self.counts.sum()
        share = (self.counts / total).tolist() if total else []
        return {"share": share, "switches": self.switches}


def formation_spec(rec: Recording) -> tuple[np.ndarray, float, dict]:
    """``(offsets (N, 2), MPC start s, controller spec)`` from ``meta["controller"]`` (zero offsets, start 0 if
    absent)."""
    ctrl = (rec.meta or {}).get("controller") or {}
    offsets = ctrl.get("offsets") or [(0.0, 0.0)] * rec.n_agents
    return np.asarray(offsets, dtype=float).reshape(rec.n_agents, 2), float(ctrl.get("start") or 0.0), ctrl


def slot_offsets(rec: Recording, truth: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(k, N, 2) each UAV's true position minus its formation slot (the target's true position plus the UAV's offset
    r_r, W20 eq. 5.22) at the steps of ``truth`` (k, objects, 4)."""
    return truth[:, rec.uav_slice, :2] - (truth[:, rec.tracked, None, :2] + offsets)


class _Formation:
    """W20 Ch. 5's tracking error (Tables 5.6, 5.8, 5.11, 5.12): each UAV's true distance to its formation place
    (the target's true position plus its offset r_r) from the MPC's start on, mean per UAV, per axis and (mean over
    the UAVs) per target phase; and the
    MPC's solver statistics (cumulative probes: plans solved, fallbacks, wall time, OSQP iterations)."""

    def __init__(self, rec: Recording):
        n = rec.n_agents
        self.rec = rec
        self.offsets, self.start, _ = formation_spec(rec)
        self.sum, self.sum_axes, self.n = np.zeros(n), np.zeros((n, 2)), 0
        self.names, self.group = _phase_groups(rec)
        self.phase_sum, self.phase_n = np.zeros(len(self.names)), np.zeros(len(self.names))
        self.last = None

    def add(self, c: Chunk, keep, err) -> None:
        after = c.t >= self.start - 1e-9
        off = slot_offsets(self.rec, c.truth[after], self.offsets)  # (k, N, 2)
        dist = np.linalg.norm(off, axis=-1)
        self.sum += dist.sum(axis=0)
        self.sum_axes += np.abs(off).sum(axis=0)
        self.n += int(after.sum())
        phase = self.group[c.phase[after, self.rec.tracked]]
        np.add.at(self.phase_sum, phase, dist.mean(axis=1))
        np.add.at(self.phase_n, phase, 1)
        if len(c.t):
            self.last = {k: c.probes[k][-1] for k in ("solves", "fallbacks", "solve_time", "iterations")}

    def result(self) -> dict:
        n = max(self.n, 1)
        solves = self.last["solves"]
        done = np.maximum(solves, 1)
        return {"tracking_error": (self.sum / n).tolist(), "tracking_error_mean": float(self.sum.mean() / n),
                "tracking_error_xy": (self.sum_axes / n).tolist(),
                "tracking_error_by_phase": {name: float(self.phase_sum[k] / self.phase_n[k])
                                            for k, name in enumerate(self.names) if self.phase_n[k]},
                "solver": {"solves": int(solves.sum()), "fallbacks": self.last["fallbacks"].astype(int).tolist(),
                           "mean_solve_us": float(1e6 * self.last["solve_time"].sum() / done.sum()),
                           "mean_iterations": float(self.last["iterations"].sum() / done.sum())}}


def _formation_warnings(formation: dict, min_distance: float | None) -> list[dict]:
    """A plan that fell back (the QP was not solved) and UAVs that came within :data:`COLLISION_M` of each other."""
    out = []
    for i, k in enumerate(formation["solver"]["fallbacks"]):
        if k:
            out.append({"kind": "solver_fallback", "uav": i + 1, "t_start": None, "t_end": None,
                        "message": f"UAV {i + 1}'s MPC was not solved {k} time(s): it flew its last setpoint"})
    if min_distance is not None and min_distance < COLLISION_M:
        out.append({"kind": "collision", "t_start": None, "t_end": None,
                    "message": f"two UAVs came {min_distance:.2f} m apart (below {COLLISION_M:g} m: a collision)"})
    return out


#: The parts of Φ (IB21 eq. 10) a set-membership estimator records, by their names in the summary.
PHI_PARTS = {"unexplored": "phi_unexplored", "unidentified": "phi_unidentified", "identified": "phi_identified"}


def plan_steps(t: np.ndarray, dt: float, period: float, start: float = 0.0) -> np.ndarray:
    """(k,) whether the record at each time ``t`` is the first to show a new plan of a controller that plans every
    ``period`` s from ``start`` (IB21's SM-MPC: ``meta["controller"]``'s ``period``, T^c = 0.5 s).

    The engine records a step before its control runs, so a plan made at ``t_p`` first shows in the record of the
    next estimation step: the record at ``t`` holds a new plan iff a plan time ``start + m·period`` (m ≥ 0) lies in
    ``[t − dt, t)``. (With control faster than estimation only the last plan of a step would show; no built-in
    scenario does that.)"""
    def plans_before(x):  # plan times in [start, x), counted
        return np.maximum(np.ceil((x - start) / period - 1e-9), 0.0)

    t = np.asarray(t, dtype=float)
    return plans_before(t) > plans_before(t - dt)


class _SetMembership:
    """IB21's uncertainty, guarantee and SM-MPC cost, streamed (O(N)): see :func:`summary`'s ``set_membership``."""

    def __init__(self, rec: Recording):
        n, probes = rec.n_agents, rec.meta["probes"]
        self.rec, self.health = rec, health.SetHealth(rec)
        self.phi_sum, self.steps, self.final, self.cleared = 0.0, 0, None, None
        ctrl = rec.meta.get("controller") or {}
        self.period = ctrl.get("period") if "solve_time" in probes else None
        self.start = float(ctrl.get("start") or 0.0)
        self.plans, self.fleet_sum, self.fleet_max = 0, 0.0, 0.0
        self.uav_sum, self.uav_max = np.zeros(n), np.zeros(n)

    def add(self, c: Chunk, keep, err) -> None:
        self.health.add(c)
        if not len(c.t):
            return
        bar = c.probes["phi"].mean(axis=1)  # Φ̄, eq. 11
        self.phi_sum += float(bar.sum())
        self.steps += len(bar)
        self.final = {"phi_bar": float(bar[-1]), "n_identified": float(c.probes["n_identified"][-1].mean()),
                      **{part: float(c.probes[p][-1].mean()) for part, p in PHI_PARTS.items()}}
        if self.cleared is None:
            clear = np.flatnonzero(c.probes["phi_unexplored"].mean(axis=1) == 0)
            self.cleared = float(c.t[clear[0]]) if len(clear) else None
        if self.period:
            solve = c.probes["solve_time"][plan_steps(c.t, self.rec.dt, self.period, self.start)]  # (plans, N)
            if len(solve):
                fleet = solve.sum(axis=1)
                self.plans += len(solve)
                self.fleet_sum += float(fleet.sum())
                self.fleet_max = max(self.fleet_max, float(fleet.max()))
                self.uav_sum += solve.sum(axis=0)
                self.uav_max = np.maximum(self.uav_max, solve.max(axis=0))

    def result(self) -> dict:
        area = _area(self.rec)
        final = self.final or dict.fromkeys(["phi_bar", "n_identified", *PHI_PARTS], None)
        solve = None
        if self.plans:
            solve = {"plans": self.plans, "fleet_mean": self.fleet_sum / self.plans, "fleet_max": self.fleet_max,
                     "per_uav_mean": (self.uav_sum / self.plans).tolist(), "per_uav_max": self.uav_max.tolist()}
        return {"phi_bar_final": final["phi_bar"],
                "phi_bar_mean": self.phi_sum / self.steps if self.steps else None,
                "phi_bar_final_fraction": final["phi_bar"] / area if area and self.final else None,
                "area": area,
                "parts_final": {part: final[part] for part in PHI_PARTS},
                **self.health.counts(),
                "time_unexplored_cleared": self.cleared,
                "identified_final": final["n_identified"],
                "solve_time": solve}


def _area(rec: Recording) -> float | None:
    """Area of X0 (m²) from the estimator's ``area`` box ``[x0, y0, x1, y1]`` in the run's meta (None if absent)."""
    box = ((rec.meta or {}).get("estimator") or {}).get("area")
    return None if box is None else float((box[2] - box[0]) * (box[3] - box[1]))


def series_bin_width(t_last: float) -> float:
    """Width (s) of a run's time-series bins: 1 s, doubled until a run of ``t_last`` seconds fits in
    :data:`SERIES_MAX_BINS` bins. Powers of two, so the bins of runs of different lengths nest (``summarize``
    merges finer bins into the coarsest run's)."""
    width = 1.0
    while t_last / width + 1 > SERIES_MAX_BINS:
        width *= 2.0
    return width


class _Series:
    """Per-bin means over fixed time bins ``[k·w, (k+1)·w)``, ``w`` = :func:`series_bin_width` (bins start at
    t = 0 whatever the chunking, so they do not depend on the recording's chunk size), from t = 0 on (the
    initialisation included, which the scalar RMSE leaves out):

    - ``position_error``: the RMS over the UAVs of each UAV's estimated target position error, ``sqrt(mean_i
      |p̂_i − p|²)`` per step (a Gaussian estimator following one target);
    - ``nees``: the NEES of ``[x, y, vx, vy]``, mean over the UAVs per step (same);
    - ``tracking_error``: each UAV's true distance to its formation slot, mean over the UAVs per step, from the
      MPC's start on (runs with the ``setpoint`` probe: W20 Ch. 5's tracking error over time);
    - ``phi_bar`` (Φ̄, IB21 eq. 11), ``phi_unexplored``, ``phi_unidentified``, ``phi_identified`` (its parts φ(X̄),
      φ(Xᵁ), φ(X)): each the mean over the UAVs per step, m² (runs with the ``phi`` probe: IB21 Figs. 8-11);
    - ``solve_time``: the fleet's total MPC solve time per plan (sum over the UAVs at the steps that show a new plan,
      :func:`plan_steps`), s (runs with ``solve_time`` and a controller ``period``: IB21 Fig. 11 right).

    ``t`` holds the bin centres; a bin without data is None."""

    def __init__(self, rec: Recording):
        self.rec = rec
        self.width = series_bin_width(rec.t_last)
        self.n_bins = int(np.floor(rec.t_last / self.width + 1e-9)) + 1
        self.quantities = []
        if health.applies(rec):
            self.quantities += ["position_error", "nees"]
        if rec.tracked is not None and "setpoint" in rec.meta["probes"]:
            self.quantities.append("tracking_error")
            self.offsets, self.start, _ = formation_spec(rec)
        if health.guaranteed(rec):
            self.quantities += ["phi_bar", *PHI_PARTS.values()]
            ctrl = rec.meta.get("controller") or {}
            if "solve_time" in rec.meta["probes"] and ctrl.get("period"):
                self.quantities.append("solve_time")
                self.plan = (ctrl["period"], float(ctrl.get("start") or 0.0))
        self.sum = {q: np.zeros(self.n_bins) for q in self.quantities}
        self.count = {q: np.zeros(self.n_bins) for q in self.quantities}

    def _bins(self, t: np.ndarray) -> np.ndarray:
        return np.minimum(np.floor(t / self.width + 1e-9).astype(np.int64), self.n_bins - 1)

    def _add(self, q: str, t: np.ndarray, values: np.ndarray) -> None:
        b = self._bins(t)
        self.sum[q] += np.bincount(b, weights=values, minlength=self.n_bins)
        self.count[q] += np.bincount(b, minlength=self.n_bins)

    def add(self, c: Chunk, keep, err) -> None:
        if "nees" in self.sum:
            e = _errors(self.rec, c)  # every step, not only the chase window
            self._add("position_error", c.t, np.sqrt(np.mean(e[..., 0] ** 2 + e[..., 1] ** 2, axis=1)))
            self._add("nees", c.t, nees_per_uav(e, c.probes["covariance"][..., :4, :4]).mean(axis=1))
        if "tracking_error" in self.sum:
            after = c.t >= self.start - 1e-9
            dist = np.linalg.norm(slot_offsets(self.rec, c.truth[after], self.offsets), axis=-1)  # (k, N)
            self._add("tracking_error", c.t[after], dist.mean(axis=1))
        if "phi_bar" in self.sum:
            self._add("phi_bar", c.t, c.probes["phi"].mean(axis=1))
            for p in PHI_PARTS.values():
                self._add(p, c.t, c.probes[p].mean(axis=1))
        if "solve_time" in self.sum:
            plan = plan_steps(c.t, self.rec.dt, *self.plan)
            self._add("solve_time", c.t[plan], c.probes["solve_time"][plan].sum(axis=1))

    def result(self) -> dict:
        out = {"bin_s": self.width, "t": ((np.arange(self.n_bins) + 0.5) * self.width).tolist()}
        for q in self.quantities:
            n = self.count[q]
            mean = self.sum[q] / np.maximum(n, 1)
            out[q] = [float(v) if k and np.isfinite(v) else None for v, k in zip(mean, n, strict=True)]
        return out


def series(rec: Recording) -> dict:
    """The run's time series (see :class:`_Series`): ``bin_s``, ``t`` (bin centres, s) and each quantity the run
    recorded what it needs for, one value per bin (None: no data in that bin)."""
    return _scan(rec, [_Series(rec)])[0]


def summary(rec: Recording) -> dict:
    """All scalar metrics of one run, JSON-ready, in one pass over the recording (and one over its truth for the
    spacing), with the run's ``warnings`` (:func:`swarmtrack.analysis.health.check`) and its compact time series
    ``series`` (:func:`series`: at most :data:`SERIES_MAX_BINS` values per quantity). The estimation metrics
    need a followed target and the ``estimate`` and ``covariance`` probes of a Gaussian estimator (capability
    1's); a run whose estimator records others gets the rest.

    A run that recorded a set-membership estimator's ``phi`` (IB21) gets ``set_membership``: ``phi_bar_final`` and
    ``phi_bar_mean`` (Φ̄ = the mean over the UAVs of Φ_i, eq. 11, m², at the last step and averaged over the steps,
    which are evenly spaced: the time average), ``phi_bar_final_fraction`` (over the area of X0, ``area``),
    ``parts_final`` (φ(X̄), φ(Xᵁ), φ(X), each the mean over the UAVs, at the last step), the guarantee and alarm
    counts of :meth:`swarmtrack.analysis.health.SetHealth.counts` (``guarantee_violations``: the monitor's counts
    summed over all steps and UAVs, ``max_violations_per_step``, ``empty_set_alarms``: the UAVs whose all-empty
    alarm ever rose, ``alarms_unexplained`` …), ``time_unexplored_cleared`` (the first t at which the mean over the
    UAVs of φ(X̄) is exactly 0, else None; X̄ never regrows once empty), ``identified_final`` (identified targets,
    mean over the UAVs, at the last step) and ``solve_time`` (the MPC's: ``plans`` seen, ``fleet_mean`` and
    ``fleet_max`` over the plans of the sum over the UAVs, ``per_uav_mean`` and ``per_uav_max`` per UAV; plans are
    found from the controller's period, :func:`plan_steps`; None without plans)."""
    accs = {}
    if health.applies(rec):
        accs = {"rmse": _Rmse(rec), "spread": _Spread(rec), "reported_std": _ReportedStd(rec),
                "consistency": _Consistency(rec), "mean_error": _MeanError(rec), "warnings": health.Health(rec)}
        if "winner" in rec.meta["probes"]:
            accs["model_use"] = _ModelUse(rec)
    if health.guaranteed(rec):
        accs["set_membership"] = _SetMembership(rec)
    if health.networked(rec):
        accs["network"] = health.NetworkHealth(rec)
    if rec.tracked is not None:
        accs["target_distance"] = _TargetDistance(rec)
        if "setpoint" in rec.meta["probes"]:
            accs["formation"] = _Formation(rec)
    accs["series"] = _Series(rec)
    out = {"warnings": [], **dict(zip(accs, _scan(rec, list(accs.values())), strict=True))}
    if "consistency" in out:
        out["nees"] = out["consistency"]["total"]["nees"]  # the run-wide figure, kept for comparison
        out["position_rmse_per_uav"] = accs["rmse"].per_uav_position()
    if rec.meta.get("liar") is not None:  # which UAV lied (network.liar), 1-based: the others are the honest ones
        out["liar_uav"] = rec.meta["liar"] + 1
    if "network" in out:  # its result() is the warnings
        out["warnings"] += out["network"]
        out["network"] = accs["network"].counts()
    out["inter_agent_distance"] = spacing(rec)
    if "formation" in out:
        out["warnings"] += _formation_warnings(out["formation"], out["inter_agent_distance"]["min"])
    if "set_membership" in out:
        out["warnings"] += accs["set_membership"].health.result()
    return out
