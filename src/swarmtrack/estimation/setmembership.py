"""Guaranteed (set-membership) search and track of targets among decoys, IB21 Sec. 4 and Algorithm 1.

Each UAV i holds, as planar sets (:mod:`swarmtrack.estimation.polygons`, every one an outer approximation):

* ``identified[i, j]``: where target j can be, for the targets it has identified (the list L: the non-empty ones);
* ``unidentified[i]`` (Xᵁ): where objects it has detected but not identified can be;
* ``unexplored[i]`` (X̄): what it has not yet seen, where an undetected target can be. Initially X̄ = X0 and the
  others are empty (IB21 Sec. 4).

**The guarantee** (IB21 Secs. 3.4-3.5): while the true noise box lies in the assumed one, every object in a footprint
is detected, targets move at most ``speed`` and stay in X0, and true targets are never misidentified, every true
target j lies in ``identified[i, j] ∪ unidentified[i] ∪ unexplored[i]`` for every UAV i at every update. (Only the
union: a decoy confused with j can make ``identified[i, j]`` miss it.)

One update of a UAV's sets (Algorithm 1):

1. **prediction** over the time since its last update (eqs. 12-15): each set dilated by the reachable displacement
   ``speed·Δt`` and clipped to X0;
2. **correction by its own frame** (eqs. 16-29), with F its footprint (an inner approximation) and ``B(y)`` the box
   of positions a measurement y can come from (:func:`polygons.boxes`, the *assumed* bound):
   ``X_j ← (X_j ∩ (Y_j ∪ Yᵁ)) ∪ ((Xᵁ ∪ X̄) ∩ Y_j) ∪ (X_j \\ F)`` (S1 ∪ S4, S2 ∪ S3, S5: eqs. 17-22, and eq. 23 for a
  new j), ``Xᵁ ← ((Xᵁ ∪ X̄) ∩ Yᵁ) ∪ (Xᵁ \\ F)`` (eqs. 24-27), ``X̄ ← X̄ \\ F`` (eq. 28), with ``Y_j`` the union of the
   boxes of the detections labelled j and ``Yᵁ`` that of the unidentified ones; a detection identified as a decoy
   enters nothing (it leaves X̄ and Xᵁ through the footprint);
3. **fusion with the neighbours' corrected sets** (eqs. 31-37), written without complements (every set lies in
   X0): ``X_j ← (∪_ℓ X_{ℓ,j}) ∩ ⋂_ℓ (X_{ℓ,j} ∪ Xᵁ_ℓ ∪ X̄_ℓ)``, ``Xᵁ ← (∪_ℓ Xᵁ_ℓ) ∩ ⋂_ℓ (Xᵁ_ℓ ∪ X̄_ℓ)``,
   ``X̄ ← ⋂_ℓ X̄_ℓ``, over the UAV and the neighbours whose message arrived (eq. 32's second Xᵁ read as X̄, and
   Algorithm 1's Xᵁ line over all neighbours as eq. 36 says).

A list L is the identified sets that are not empty (eqs. 29, 35: an emptied set is dropped).

The **alarms** (counts per UAV) flag what cannot happen under the assumptions with no decoys: a detection whose box
meets no set that could hold it (``unexplained``; with decoys, a decoy seen again after it was identified as one),
and every set of a UAV empty (``all_empty``: every target lost, the paper's sign of a wrong noise bound).

**Delayed messages** (IB21 Sec. 4.5, ``estimator.delayed_data: refilter``): every broadcast is stamped with the time
its sets describe, and :class:`ReplayingSetMembershipEstimator` fuses late sets at that time and replays the updates
since; without network delays the builder uses the plain :class:`SetMembershipEstimator`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import shapely

from swarmtrack.estimation import polygons as pg
from swarmtrack.estimation.base import Probe, Regions, TargetView
from swarmtrack.sensors.detections import IDENTIFIED_FALSE, UNLABELLED  # noqa: F401 (the labels it reads)


@dataclass
class Beliefs:
    """The sets of N UAVs: ``unexplored`` (N,), ``unidentified`` (N,), ``identified`` (N, n_ids) object arrays of
    shapely geometries, ``t`` (N,) the time they describe, and the alarm counts per UAV."""

    unexplored: np.ndarray
    unidentified: np.ndarray
    identified: np.ndarray
    t: np.ndarray
    alarms: dict[str, np.ndarray] = field(default_factory=dict)
    #: X̄'s lineage (N,) each: ``unexplored[i]`` is, as a set, ``base[i] \\ cut[i]`` (its prediction and the
    #: footprints removed from it since). UAVs whose X̄ share a base (the same value: equal inputs gave it) fuse it
    #: as one difference, ``base \\ ∪ cut``, instead of intersecting near-equal sets. None: no lineage known.
    base: np.ndarray | None = None
    cut: np.ndarray | None = None
    #: The per-UAV rows (beside the alarm counts) that a replay moves between copies.
    ROWS: ClassVar[tuple[str, ...]] = ("unexplored", "unidentified", "identified", "t", "base", "cut")

    @classmethod
    def start(cls, n_uavs: int, n_ids: int, area, t: float = 0.0) -> Beliefs:
        """IB21 Sec. 4: L = ∅, Xᵁ = ∅, X̄ = X0."""
        unexplored = np.empty(n_uavs, dtype=object)
        unexplored[:] = area
        return cls(unexplored, pg.empty(n_uavs), pg.empty((n_uavs, n_ids)), np.full(n_uavs, float(t)),
                   {"unexplained": np.zeros(n_uavs, dtype=np.int64), "all_empty": np.zeros(n_uavs, dtype=np.int64)},
                   unexplored.copy(), pg.empty(n_uavs))

    @property
    def n_ids(self) -> int:
        return self.identified.shape[1]

    def copy(self) -> Beliefs:
        return Beliefs(self.unexplored.copy(), self.unidentified.copy(), self.identified.copy(), self.t.copy(),
                       {k: v.copy() for k, v in self.alarms.items()},
                       None if self.base is None else self.base.copy(), None if self.cut is None else self.cut.copy())


def predict(b: Beliefs, rows: np.ndarray, t: float, speed: float, area) -> None:
    """IB21 eqs. 12-15 for the UAVs ``rows``: their sets dilated by ``speed · (t − b.t)`` and clipped to X0. A set
    held by several UAVs (the same object, from equal inputs) is dilated once for all of them."""
    if not len(rows):
        return
    r = speed * (t - b.t[rows])
    if (r < 0).any():
        raise ValueError("set-membership prediction backwards in time")
    b.unexplored[rows] = _grow(b.unexplored[rows], r, area)
    b.unidentified[rows] = _grow(b.unidentified[rows], r, area)
    ids = b.identified[rows]
    live = ~pg.is_empty(ids)
    if live.any():
        ids[live] = _grow(ids[live], np.broadcast_to(r[:, None], ids.shape)[live], area)
        b.identified[rows] = ids
    if b.base is not None:
        b.base[rows] = b.unexplored[rows]
        b.cut[rows] = pg.EMPTY
    b.t[rows] = t


def _grow(sets: np.ndarray, r: np.ndarray, area) -> np.ndarray:
    """``(A ⊕ D(r)) ∩ X0`` of every set, computed once per distinct (set, r) and empty sets left as they are."""
    first, inverse = pg.distinct(sets, r)
    todo = first[~pg.is_empty(sets[first])]
    out = sets[first].copy()
    if len(todo):
        out[np.searchsorted(first, todo)] = pg.clip(pg.dilate(sets[todo], r[todo]), area)
    return out[inverse]


def correct(b: Beliefs, i: int, footprint, z: np.ndarray, labels: np.ndarray, bound) -> None:
    """IB21 eqs. 16-29 for UAV i with its own frame: ``footprint`` (an inner approximation of what it explored),
    detections ``z`` (M, 2) labelled ``labels`` (M,) (a target's number, :data:`UNLABELLED` or
    :data:`IDENTIFIED_FALSE`), boxes of half-widths ``bound`` (the assumed noise bound)."""
    boxes = pg.boxes(z, bound)
    unid = pg.union_all(boxes[labels == UNLABELLED])
    Xu, Xbar = b.unidentified[i], b.unexplored[i]
    _explain(b, i, boxes, labels, Xu, Xbar)
    for j in range(b.n_ids):
        Yj = pg.union_all(boxes[labels == j])
        Xj = b.identified[i, j]
        if Xj.is_empty and Yj.is_empty:
            continue
        first = pg.within(Yj, Xu, Xbar)  # S2 ∪ S3: first identified now (eqs. 18-19, 23)
        kept = pg.within(pg.union_all([Yj, unid]), Xj)  # S1 ∪ S4 (eqs. 17, 20)
        unseen = pg.remove(Xj, footprint)  # S5 (eq. 21)
        b.identified[i, j] = pg.union_all([first, kept, unseen])  # eq. 22
    found = pg.within(unid, Xu, Xbar)  # S1ᵁ ∪ S2ᵁ (eqs. 24-25)
    b.unidentified[i] = pg.union_all([found, pg.remove(Xu, footprint)])  # eqs. 26-27
    b.unexplored[i] = pg.remove(Xbar, footprint)  # eq. 28
    if b.base is not None and b.base[i] is not None:
        b.cut[i] = pg.union_all([b.cut[i], footprint])  # X̄ = base \ cut still
    _check_lost(b, i)


def _explain(b: Beliefs, i: int, boxes: np.ndarray, labels: np.ndarray, Xu, Xbar) -> None:
    """Count the detections whose box meets no predicted set that could hold their object: ``X_j ∪ Xᵁ ∪ X̄`` for one
    labelled j, any set for an unidentified one (a decoy identified as one is not checked)."""
    for m in np.flatnonzero(labels != IDENTIFIED_FALSE):
        j = labels[m]
        holders = [Xu, Xbar, b.identified[i, j]] if j >= 0 else [Xu, Xbar, *b.identified[i]]
        if not any(shapely.intersects(h, boxes[m]) for h in holders if not h.is_empty):
            b.alarms["unexplained"][i] += 1


def fuse(b: Beliefs, recv: np.ndarray, send: np.ndarray, sent: Beliefs, own: np.ndarray | None = None,
         who: np.ndarray | None = None) -> None:
    """IB21 eqs. 31-37: every UAV that heard from someone fuses its own and its neighbours' corrected sets (``sent``,
    the sets as broadcast; row ℓ read by UAV i only where a link ``i ← ℓ`` delivered it). All sets describe the same
    time.

    ``own`` (R,): the row of ``sent`` holding each receiver row's own corrected sets (default: its own row, the sets
    it broadcast); Sec. 4.5's replay (:class:`ReplayingSetMembershipEstimator`) passes the sets it recomputed.
    ``who`` (R,): the swarm's UAV each receiver row is (default: ``own``, or the row itself).

    **A UAV's result is a function of its own group only**: its own sets and those its links delivered, never of
    the other UAVs' links. One UAV computing alone (its own process, the sets it received value-equal copies of what
    the swarm's estimator shares between UAVs as objects) thus gets bit for bit the swarm's row. The outer
    approximations (:func:`polygons.loosen`, eqs. 34-37) make the last bits depend on the order of the operands and
    on which duplicates are dropped, so both are fixed by the group alone:

    * the **canonical order**: the group's sets by UAV (its own at its UAV's place among its senders'), the order of
      every union and intersection chain below;
    * sets are told apart **by value** (:class:`_ByValue`: their WKB bytes), never by object, so a copy is a
      duplicate exactly where the swarm's shared object is;
    * what UAVs share in one process is a cache of what each would compute alone, keyed by values in that order:
      groups with the same members (one result), X̄'s intersection chains by their ordered prefix (:class:`_Meets`,
      whose chains have their own canonical order, by area), the loosened operands and candidate unions
      (``loose``)."""
    who = (np.arange(len(b.t)) if own is None else own) if who is None else who
    groups = {}
    for i in np.unique(recv).tolist():
        senders = send[recv == i]
        me = i if own is None else own[i]
        order = np.argsort(np.concatenate([[who[i]], senders]), kind="stable")
        groups[i] = np.concatenate([[me], senders])[order]
    if not groups:
        return
    sent = _ByValue().beliefs(sent, np.unique(np.concatenate(list(groups.values()))))
    done: dict[tuple, int] = {}
    bases = _Meets()  # intersections of predicted X̄ by ordered prefix, shared within this round
    loose: dict = {}  # sets loosened whole and candidate unions, once this round (polygons.within)
    for i, group in groups.items():
        key = tuple(group.tolist())
        if key in done:  # the same inputs in the same order: the same outputs
            k = done[key]
            b.unexplored[i], b.unidentified[i] = b.unexplored[k], b.unidentified[k]
            b.identified[i] = b.identified[k]
        else:
            done[key] = i
            _fuse_one(b, i, group, sent, bases, loose)
        if b.base is not None:
            b.base[i], b.cut[i] = b.unexplored[i], pg.EMPTY
        _check_lost(b, i)


class _ByValue:
    """One object per set value in a fusion round: sets with the same WKB bytes (the same coordinates in the same
    order, so the same result of every operation) are replaced by the first such object seen. The fusion's identity
    tests (``A ∪ A = A``, a holder that is the candidate itself, a holder repeating an earlier one, UAVs sharing an
    X̄ base) and its caches then see value-equal copies as one set, whether they arrived as one shared object (the
    swarm's estimator) or as copies (a UAV's own process)."""

    def __init__(self):
        self._by_wkb: dict[bytes, object] = {}
        self._by_id: dict[int, tuple[object, object]] = {}  # id → (the object, kept alive; its representative)

    def __call__(self, sets: np.ndarray) -> np.ndarray:
        flat = np.asarray(sets, dtype=object).ravel()
        new = [k for k, g in enumerate(flat) if g is not None and id(g) not in self._by_id]
        if new:
            for k, w in zip(new, shapely.to_wkb(flat[new]).tolist(), strict=True):
                g = flat[k]
                self._by_id.setdefault(id(g), (g, self._by_wkb.setdefault(w, g)))
        out = flat.copy()
        for k, g in enumerate(flat):
            if g is not None:
                out[k] = self._by_id[id(g)][1]
        return out.reshape(np.shape(sets))

    def beliefs(self, sent: Beliefs, rows: np.ndarray) -> Beliefs:
        """``sent`` with the sets of ``rows`` (the rows a round reads) replaced by their representatives."""
        arrays = {}
        for name in ("unexplored", "unidentified", "identified", "base", "cut"):
            a = getattr(sent, name)
            if a is not None:
                a = a.copy()
                a[rows] = self(a[rows])
            arrays[name] = a
        return dataclasses.replace(sent, **arrays)


def _fuse_one(b: Beliefs, i: int, group: np.ndarray, sent: Beliefs, bases: _Meets | None = None,
              loose: dict | None = None) -> None:
    """Eqs. 34-37 for UAV i over ``group``, the rows of ``sent`` in canonical order (:func:`fuse`)."""
    bars, us = sent.unexplored[group], sent.unidentified[group]
    b.unexplored[i] = _common_unexplored(sent, group, bases)  # eq. 37
    cand = _candidate(us, loose)
    b.unidentified[i] = _held_by_all(cand, [[us[k], bars[k]] for k in range(len(group))], loose)  # eq. 36
    for j in range(b.n_ids):
        xs = sent.identified[group, j]
        if pg.is_empty(xs).all():
            b.identified[i, j] = pg.EMPTY  # eq. 35: dropped
            continue
        holders = [[xs[k], us[k], bars[k]] for k in range(len(group))]
        b.identified[i, j] = _held_by_all(_candidate(xs, loose), holders, loose)  # eq. 34


def _candidate(sets: np.ndarray, loose: dict | None):
    """``∪ sets`` (the union of beliefs of eqs. 34, 36), as an outer approximation: the distinct sets in the given
    (canonical) order, the first as it is and the others :func:`polygons.loosen`-ed (from the round's ``loose``
    cache, where the same objects are loosened for :func:`polygons.within` anyway). The neighbours' sets share most
    of their edges exactly, GEOS's slow case; ``A ∪ loosen(B) ⊇ A ∪ B``, wider by at most about ``2·LOOSEN`` along
    B's edges. Each union is kept in ``loose`` too, by its ordered operands: another group of the round with the
    same distinct sets in the same order reuses it (what it would compute itself)."""
    distinct = list({id(g): g for g in sets if not g.is_empty}.values())
    if len(distinct) < 2 or loose is None:
        return pg.union_all(distinct)
    key = ("union", *(id(g) for g in distinct))
    hit = loose.get(key)
    if hit is None:
        operands = [distinct[0], *(_half_loose(g, loose) for g in distinct[1:])]
        hit = loose[key] = (distinct, pg.union_all(operands))
    return hit[1]


def _half_loose(g, loose: dict):
    """``loosen(g, LOOSEN / 2)``, once per object in ``loose``: half the margin of the holders' loosening, so the
    candidate's edges fall neither on the sets' edges nor on the loosened holders' edges."""
    key = ("half", id(g))
    if key not in loose:
        loose[key] = (g, pg.loosen(g, pg.LOOSEN / 2))
    return loose[key][1]


class _Meets:
    """Intersections of sets (X̄ bases, eq. 37) for one fusion round, each a chain ``((s1 ∩ s2) ∩ s3) ∩ …`` — what
    ``shapely.intersection_all`` does, one overlay per step — with every prefix of every chain kept: a group whose
    ordered sets begin with a chain met before starts from it.

    The **canonical order** of a chain is a function of its sets' values alone: by area, smallest first, ties by
    their WKB bytes. So a chain is what the UAV would compute alone, whatever the other groups of the round (the
    order used to be ranked by how many of the round's groups held each set, which one UAV does not know). Smallest
    first keeps the intermediate results small, and bases of small area are the ones that many neighbourhoods hold
    (UAVs that fused often): on ``ib21-fleet-6`` (seed 3, first 24 s, the same groups either way) it saves 18.6 % of
    the chains' overlays, against 18.9 % with the round-wide rank and 15.3 % in UAV order.

    Every operand after the first is :func:`polygons.loosen`-ed (once per round): the bases share most of their
    boundary exactly, which makes GEOS's overlay 4-10x slower than on edges 1e-6 m apart. So the result is
    ``s1 ∩ loosen(s2) ∩ …``: a superset of ``⋂ s`` (an outer approximation, as eq. 37 needs), wider by about
    2e-6 m along its edges (more only in the tip of an acute corner between two operands' edges; it is dilated by
    V^t·T^c = 0.5 m at the next prediction anyway), and the very chain ``intersection_all`` does on the ordered,
    loosened sets (tests hold both)."""

    def __init__(self):
        self.chains: dict[tuple[int, ...], object] = {}
        self.loose: dict[int, tuple[object, object]] = {}
        self.keys: dict[int, tuple[object, float, bytes]] = {}  # id → (the set, kept alive; its place in the order)

    def order(self, sets) -> list:
        """``sets`` (distinct values) in the canonical order: by area, then by WKB bytes."""
        for s in sets:
            if id(s) not in self.keys:
                self.keys[id(s)] = (s, float(shapely.area(s)), shapely.to_wkb(s))
        return sorted(sets, key=lambda s: self.keys[id(s)][1:])

    def meet(self, sets) -> shapely.Geometry:
        """``⋂ sets`` (distinct values, in any order), reusing the longest ordered prefix already computed."""
        sets = self.order(sets)
        ids = tuple(id(s) for s in sets)
        n = len(ids)
        while n > 1 and ids[:n] not in self.chains:
            n -= 1
        acc = self.chains[ids[:n]] if n > 1 else sets[0]
        for k in range(max(n, 1), len(ids)):
            if ids[k] not in self.loose:
                self.loose[ids[k]] = (sets[k], pg.loosen(sets[k]))
            acc = pg.intersect(acc, self.loose[ids[k]][1])
            self.chains[ids[:k + 1]] = acc
        return acc


def _common_unexplored(sent: Beliefs, group: np.ndarray, bases: _Meets | None = None):
    """``⋂_ℓ X̄_ℓ`` (eq. 37). With the lineage ``X̄_ℓ = base_ℓ \\ cut_ℓ`` this is the same set as
    ``(⋂ distinct bases) \\ ∪_ℓ cut_ℓ``: one difference by a few footprints (their union in the group's canonical
    order), after an intersection only of bases that differ (by value), built by ``bases`` (:class:`_Meets`, in its
    canonical order) on the chains already done for the other UAVs this round. Near-equal large polygons are the
    dearest overlay GEOS does (their shared edges), so it is done as rarely as this allows."""
    if sent.base is None or any(sent.base[ell] is None for ell in group.tolist()):
        return pg.intersect_all(sent.unexplored[group])
    distinct = list({id(sent.base[ell]): sent.base[ell] for ell in group.tolist()}.values())
    common = (_Meets() if bases is None else bases).meet(distinct)
    cuts = pg.union_all(sent.cut[group])
    return pg.remove(common, cuts) if not cuts.is_empty else common


def _held_by_all(candidate, holders: list[list], loose: dict | None = None):
    """``candidate ∩ ⋂_ℓ (∪ holders[ℓ])``: the part of a (small) union of beliefs that no UAV proved empty (eqs. 34,
    36 without complements), the holders in the given (canonical) order. A holder that includes the candidate itself
    (the same object: after :class:`_ByValue`, the same value) or repeats an earlier holder's sets changes nothing
    and is skipped: exact."""
    seen: set[tuple[int, ...]] = set()
    for parts in holders:
        key = tuple(sorted(id(p) for p in parts))
        if key in seen:
            continue
        seen.add(key)
        candidate = pg.within(candidate, *parts, loose=loose)
    return candidate


def _check_lost(b: Beliefs, i: int) -> None:
    if b.unexplored[i].is_empty and b.unidentified[i].is_empty and pg.is_empty(b.identified[i]).all():
        b.alarms["all_empty"][i] += 1


def aggregated(b: Beliefs, cache: dict | None = None) -> np.ndarray:
    """IB21 eq. 43: ``X^A_i = (∪_j X_{i,j}) ∪ Xᵁ_i ∪ X̄_i`` (N,), one union per distinct row of sets (UAVs that
    fused the same inputs hold the same objects).

    ``cache`` (a dict the caller keeps between calls): the unions of the last call by their rows' objects; a row
    still holding the very objects (a UAV that no update touched since, e.g. at an identification frame of
    another) gets the same union object back without an overlay. The dict is left holding this call's rows."""
    keys = [_ids(b.unidentified), *(_ids(b.identified[:, j]) for j in range(b.n_ids))]
    first, inverse = pg.distinct(b.unexplored, *keys)
    out = np.empty(len(first), dtype=object)
    kept: dict = {}
    for r, i in enumerate(first):
        row = (*b.identified[i], b.unidentified[i], b.unexplored[i])
        out[r] = _union_of_row(row, cache, kept)
    if cache is not None:
        cache.clear()
        cache.update(kept)
    return out[inverse]


def _union_of_row(row: tuple, cache: dict | None, kept: dict):
    """``∪ row``, from ``cache`` when the same objects were unioned before (each entry holds its objects, so their
    ids stay theirs); recorded in ``kept``."""
    key = tuple(id(s) for s in row)
    hit = None if cache is None else cache.get(key)
    if hit is None:
        hit = kept.get(key)
    if hit is None:
        hit = (row, pg.union_all(list(row)))
    kept[key] = hit
    return hit[1]


def _ids(sets: np.ndarray) -> np.ndarray:
    return np.array([id(s) for s in sets], dtype=np.int64)


def uncertainty(b: Beliefs, region: np.ndarray | None = None, cache: dict | None = None) -> dict[str, np.ndarray]:
    """IB21 eq. 10 and its parts, (N,) each: ``phi`` = φ(X^A), ``unexplored`` = φ(X̄), ``unidentified`` = φ(Xᵁ),
    ``identified`` = φ(∪_j X_j) (m²; overlaps count once, so the parts need not add up to ``phi``). ``region``: X^A
    if already computed (:func:`aggregated`). ``cache``: as :func:`aggregated`'s, for the unions ``∪_j X_j``."""
    kept: dict = {}
    ids = np.empty(len(b.identified), dtype=object)
    for i, row in enumerate(b.identified):
        ids[i] = _union_of_row(tuple(row), cache, kept)
    if cache is not None:
        cache.clear()
        cache.update(kept)
    region = aggregated(b) if region is None else region
    return {"phi": pg.area(region), "unexplored": pg.area(b.unexplored),
            "unidentified": pg.area(b.unidentified), "identified": pg.area(ids)}


def containing(b: Beliefs, points: np.ndarray, ids: np.ndarray, tolerance: float = 1e-6) -> np.ndarray:
    """(N, P) whether each UAV's union ``X_{i,j} ∪ Xᵁ_i ∪ X̄_i`` holds each true target j at ``points`` (P, 2)
    (``ids`` (P,) their numbers): the guarantee, for the truth-side monitor (within ``tolerance`` m)."""
    pts = shapely.points(np.asarray(points, dtype=float))
    ids = np.asarray(ids)
    ok = ids >= 0
    own = np.full((len(b.unexplored), len(pts)), pg.EMPTY, dtype=object)
    own[:, ok] = b.identified[:, ids[ok]]
    out = np.zeros(own.shape, dtype=bool)
    for sets in (b.unexplored[:, None], b.unidentified[:, None], own):
        near = shapely.distance(sets, pts[None, :])
        out |= np.where(np.isnan(near), False, near <= tolerance)  # distance to an empty set is NaN
    return out


class SetMembershipEstimator:
    """IB21's guaranteed estimator on every UAV (the Estimator protocol, :mod:`swarmtrack.estimation.base`).

    ``n_ids`` true targets are numbered 0..n_ids−1 (the labels the sensor reports); ``area`` is X0 (a shapely
    polygon); ``speed`` the targets' speed bound V^t (m/s); ``bound`` the assumed noise half-widths (m, per axis);
    ``period`` T^c (s): the sets are shared and fused every ``period`` and updated then and at every frame that
    identifies something (IB21 Sec. 6: identification patches are crossed in a fraction of a second). Skipping the
    other frames drops information only, never the guarantee (the prediction covers the time elapsed).

    The sensor's detections must carry each UAV's footprint (``Detections.footprint``); it is removed as an inner
    approximation (:func:`polygons.inner`).
    """

    #: The raster grid of the sets (None: polygons; :mod:`swarmtrack.estimation.set_backends`).
    grid = None

    def __init__(self, n_uavs: int, n_ids: int, area, *, speed: float, bound, period: float = 0.5,
                 uavs: np.ndarray | None = None):
        self.n, self.area, self.speed, self.bound, self.period = n_uavs, area, speed, tuple(bound), period
        #: The swarm's UAVs the rows are (:mod:`swarmtrack.network.rows`), None for the whole swarm: row r fuses its
        #: own broadcast as the inbox's row ``uavs[r]`` of the payloads (eq. 31's ℓ = i).
        self.uavs = None if uavs is None else np.asarray(uavs, dtype=np.int64)
        self.beliefs = self._start(n_uavs, n_ids, area)
        self._next_share = 0.0
        self._sharing = False
        self._unions: tuple[dict, dict] = ({}, {})  # the last X^A and ∪_j X_j per row of objects (aggregated)
        self._phi = self._uncertainty(self._aggregated())
        self.updates = np.zeros(n_uavs, dtype=np.int64)
        self._view: TargetView | None = None  # the view of the current sets (they change only at updates)
        self._sampled: dict | None = None  # the probes of the current sets (they change only at updates)
        self.probes = (Probe("phi", ()), Probe("phi_unexplored", ()), Probe("phi_unidentified", ()),
                       Probe("phi_identified", ()), Probe("n_identified", ()), Probe("vertices", ()),
                       Probe("set_updates", ()), Probe("alarm_unexplained", ()), Probe("alarm_all_empty", ()))

    def share(self, t: float, nav: np.ndarray, own) -> dict:
        """Update the UAVs whose frame identified something, or all of them at a sharing time, and broadcast the
        corrected sets at a sharing time (IB21 Algorithm 1 lines 1-10, then eq. 30's message)."""
        self._sharing = t >= self._next_share - 1e-9
        if self._sharing:
            self._next_share = t + self.period
        events = np.zeros(self.n, dtype=bool)
        events[own.owner[own.label != UNLABELLED]] = True
        rows = np.arange(self.n) if self._sharing else np.flatnonzero(events)
        if len(rows):
            if own.footprint is None:
                raise ValueError("the set-membership estimator needs a sensor that reports footprints")
            regions = self._regions(own.footprint[rows])
            frames = []
            for i, region in zip(rows, regions, strict=True):
                mine = own.owner == i
                frames.append((i, region, own.z[mine], own.label[mine]))
            self._update(t, rows, frames)
            self.updates[rows] += 1
            self._view = self._sampled = None
        if not self._sharing:
            return {}
        return self._message(t)

    def _regions(self, corners: np.ndarray) -> np.ndarray:
        """What the correction removes for footprints ``corners`` (n, 4, 2): inner approximations, as polygons."""
        return pg.inner(shapely.polygons(corners))

    def _message(self, t: float) -> dict:
        """Eq. 30's message: the corrected sets, stamped with the time they describe (IB21 Sec. 4.5's stamp)."""
        b = self.beliefs
        return {"unexplored": b.unexplored.copy(), "unidentified": b.unidentified.copy(),
                "identified": b.identified.copy(), "unexplored_base": b.base.copy(), "unexplored_cut": b.cut.copy(),
                "taken": np.full(self.n, float(t))}

    def _update(self, t: float, rows: np.ndarray, frames: list[tuple]) -> None:
        self._advance(self.beliefs, t, rows, frames)

    def _advance(self, b: Beliefs, t: float, rows: np.ndarray, frames: list[tuple]) -> None:
        """Algorithm 1 lines 1-10 for the UAVs ``rows``: prediction to ``t`` (eqs. 12-15), then the correction by
        each one's frame, ``frames`` = ``[(i, footprint, z, labels), …]`` (eqs. 16-29)."""
        predict(b, rows, t, self.speed, self.area)
        for i, region, z, labels in frames:
            correct(b, i, region, z, labels, self.bound)

    def fuse(self, t: float, own, inbox) -> None:
        """At a sharing time, fuse what the links delivered (IB21 eqs. 31-37, Algorithm 1 lines 11-16)."""
        if not self._sharing:
            return
        recv, send = inbox.edges()
        self._fuse_sets(recv, send, inbox.payloads)
        self._refresh()

    def _fuse_sets(self, recv: np.ndarray, send: np.ndarray, got: dict) -> None:
        """Eqs. 31-37 over the links ``recv ← send`` with the broadcast sets ``got``; each UAV's own sets are its row
        of ``got`` (for a subset, row ``uavs[r]``: the very sets it broadcast)."""
        self._fuse_into(self.beliefs, recv, send, self._received(got), self.uavs)

    def _fuse_into(self, b: Beliefs, recv: np.ndarray, send: np.ndarray, sent: Beliefs,
                   own: np.ndarray | None = None, who: np.ndarray | None = None) -> None:
        """Eqs. 31-37 on the sets ``b`` (:func:`fuse`; ``own`` and ``who`` as there): the fusion of a sharing time,
        also when a replay (:class:`ReplayingSetMembershipEstimator`) does it again, with no links too."""
        fuse(b, recv, send, sent, own, who)

    def _received(self, got: dict) -> Beliefs:
        """The broadcast sets of one sharing time (:meth:`share`'s payload) as beliefs."""
        return _received(got)

    def _start(self, n_uavs: int, n_ids: int, area) -> Beliefs:
        return Beliefs.start(n_uavs, n_ids, area)

    def _aggregated(self) -> np.ndarray:
        return aggregated(self.beliefs, self._unions[0])

    def _uncertainty(self, region: np.ndarray) -> dict[str, np.ndarray]:
        return uncertainty(self.beliefs, region, self._unions[1])

    def _refresh(self) -> None:
        region = self._aggregated()  # X^A once, for Φ and the view
        self._phi = self._uncertainty(region)
        self._view = self._make_view(region)
        self._sampled = None

    def view(self) -> TargetView:
        """No single target: the centre of each UAV's aggregated set (eq. 43) as the state (NaN when empty), and the
        set itself as the region (what the set-membership MPC plans against)."""
        if self._view is None:
            self._view = self._make_view()
        return self._view

    def _make_view(self, region: np.ndarray | None = None) -> TargetView:
        region = self._aggregated() if region is None else region
        state = np.full((self.n, 4), np.nan)
        state[:, :2] = self._centres(region)
        return TargetView(state, region=Regions(region, self.grid))

    def _centres(self, region: np.ndarray) -> np.ndarray:
        """(N, 2) the centroid of each aggregated set, NaN where empty."""
        out = np.full((len(region), 2), np.nan)
        live = ~pg.is_empty(region)
        out[live] = shapely.get_coordinates(shapely.centroid(region[live]), include_z=False)
        return out

    def sample(self) -> dict[str, np.ndarray]:
        """The probes, (N,) each: built once per change of the sets (an update or a fusion) and read by every step
        until the next (the recorder copies what it keeps)."""
        if self._sampled is None:
            b, phi = self.beliefs, self._phi
            self._sampled = {
                "phi": phi["phi"], "phi_unexplored": phi["unexplored"], "phi_unidentified": phi["unidentified"],
                "phi_identified": phi["identified"], "n_identified": self._listed().sum(axis=1) * 1.0,
                "vertices": self._size() * 1.0, "set_updates": self.updates * 1.0,
                "alarm_unexplained": b.alarms["unexplained"] * 1.0, "alarm_all_empty": b.alarms["all_empty"] * 1.0}
        return dict(self._sampled)

    def _listed(self) -> np.ndarray:
        """(N, n_ids) whether each target is in each UAV's list L (its set not empty)."""
        return ~pg.is_empty(self.beliefs.identified)

    def _size(self) -> np.ndarray:
        """(N,) the vertices of each UAV's sets (the ``vertices`` probe: what the set operations cost grows with)."""
        b = self.beliefs
        return shapely.get_num_coordinates(b.unexplored) + shapely.get_num_coordinates(b.unidentified) \
            + shapely.get_num_coordinates(b.identified).sum(axis=1)

    def containing(self, points: np.ndarray, ids: np.ndarray) -> np.ndarray:
        """For the truth-side monitor only: :func:`containing` on the current sets."""
        return containing(self.beliefs, points, ids)

    def current(self, t: float) -> np.ndarray:
        """(N,) the UAVs whose sets describe time ``t`` (updated at ``t``): the guarantee is about the sets' time."""
        return np.abs(self.beliefs.t - t) < 1e-9


def _received(got: dict) -> Beliefs:
    """The broadcast sets of one sharing time (:meth:`SetMembershipEstimator.share`'s payload) as :class:`Beliefs`."""
    return Beliefs(got["unexplored"], got["unidentified"], got["identified"], got["taken"],
                   base=got.get("unexplored_base"), cut=got.get("unexplored_cut"))


class ReplayingSetMembershipEstimator(SetMembershipEstimator):
    """IB21 Sec. 4.5: a neighbour's sets that arrive late are fused at the time they describe, and the UAV's updates
    since are replayed, over a window of the last ``window`` (δ̄) sharing times.

    Every broadcast carries the time its sets describe (``taken``). A message is fused at the first sharing time
    after it arrived (a channel delivers at an estimation step: the delay rounded up to whole sharing periods). Each
    UAV keeps, for the sharing times ``m − δ̄ .. m``: its corrected sets ``X_{i,k|k}`` before the fusion (the
    snapshots ``_pre``), the messages it fused at each (``_heard``: the payload and the links), and its own frames
    (footprint, detections, labels) of every update (``_frames``, the identification frames between sharing
    times too). A UAV that got sets of time ``k − δ'`` re-fuses, at ``k − δ'``, its corrected sets with every
    message of that time it has (eqs. 31-37: the result is the one it would have had, had the late message arrived
    in time), then for ``k − δ' + 1 .. k`` predicts (eqs. 12-15), corrects by its own frames (eqs. 16-29) and fuses
    the messages of each time again. No sets of different times are ever fused. A UAV's recomputed sets are fused as
    its own row (``fuse``'s ``own``), its neighbours' as they broadcast them.

    Where the paper fuses the late sets with the already fused ``X_{i,k−δ'}``, this re-fuses from ``X_{i,k−δ'|k−δ'}``
    with all messages of that time: both are outer approximations; this one gives the sets of an on-time arrival
    (tests: to < 1e-6 m² when the replay fuses nothing on the way; when it does, each set lies inside the other's
    grown by the outer approximations' margin, ≤ 7.4 mm per prediction, since recomputed sets are new objects that
    the fusion loosens and the dilation simplifies differently). Sets older than
    the window are dropped and counted (probe ``stale``, the health check's ``stale_data`` warning); ``late`` counts
    the late messages fused. The alarm counts of the replayed updates are recounted (they replace the first count).
    The cost, one replay of up to δ̄ periods per UAV that got late sets, is paid only with delays: without them the
    builder uses the plain estimator."""

    def __init__(self, *args, window: int, **kwargs):
        super().__init__(*args, **kwargs)
        if window < 1:
            raise ValueError("the replay window must be at least one sharing period")
        self.window = int(window)
        self._pre: dict[int, Beliefs] = {}  # sharing index -> the corrected sets before the fusion
        self._heard: dict[int, tuple[dict, list, list]] = {}  # sharing index -> (payload, receivers, senders)
        self._frames: dict[int, list[tuple]] = {}  # sharing index at or after it -> (t, rows, frames) of each update
        self._waiting: list[tuple] = []  # (payload, receivers, senders) delivered since the last sharing time
        self._swarm = np.arange(self.n) if self.uavs is None else self.uavs  # row r is UAV _swarm[r]
        self._late = np.zeros(self.n)
        self._stale = np.zeros(self.n)
        self.probes = (*self.probes, Probe("late", ()), Probe("stale", ()))

    def _index(self, t: float) -> int:
        return round(t / self.period)

    def _update(self, t: float, rows: np.ndarray, frames: list[tuple]) -> None:
        at = t if self._sharing else self._next_share  # an identification frame belongs to the next sharing time
        self._frames.setdefault(self._index(at), []).append((t, rows, frames))
        super()._update(t, rows, frames)

    def share(self, t: float, nav: np.ndarray, own) -> dict:
        out = super().share(t, nav, own)
        if self._sharing:
            self._pre[self._index(t)] = self.beliefs.copy()
        return out

    def fuse(self, t: float, own, inbox) -> None:
        """Collect what arrived (a message between sharing times waits for the next one); at a sharing time ``m``,
        file each message under the time its sets describe, drop and count those older than ``m − δ̄``, and replay
        every UAV from the earliest time it got sets of (:meth:`_replay`). The ``late`` and ``stale`` probes count
        this step's (0 between sharing times), so that their sum over the recorded steps is the number of messages."""
        self._late[:] = 0.0
        self._stale[:] = 0.0
        for part in inbox.parts():
            recv, send = part.edges()
            if "taken" in part.payloads and len(recv):  # nothing is broadcast between sharing times
                self._waiting.append((part.payloads, recv, send))
        if not self._sharing:
            return
        m = self._index(t)
        self._forget(m - self.window)
        start = np.full(self.n, m)  # per UAV, the earliest sharing time it re-fuses
        for payloads, recv, send in self._waiting:
            s = self._index(payloads["taken"][send[0]])  # one part: one sending time
            if s < m - self.window:
                np.add.at(self._stale, recv, 1.0)
                continue
            heard = self._heard.setdefault(s, ([], [], []))
            heard[0].append(payloads)
            heard[1].append(recv)
            heard[2].append(send)
            if s < m:
                np.minimum.at(start, recv, s)
                np.add.at(self._late, recv, 1.0)
        self._waiting = []
        self._replay(m, start)
        self._refresh()

    def _forget(self, oldest: int) -> None:
        """Drop what a replay from the sharing time ``oldest`` on no longer needs."""
        for kept, first in ((self._pre, oldest), (self._heard, oldest), (self._frames, oldest + 1)):
            for s in [s for s in kept if s < first]:  # the frames up to ``oldest`` are in its corrected sets
                del kept[s]

    def _replay(self, m: int, start: np.ndarray) -> None:
        """From the earliest ``start`` to ``m``: each UAV joins at its ``start`` with its corrected sets of that
        time, is fused with every message of each time (eqs. 31-37), predicted and corrected by its own frames up to
        the next (eqs. 12-29). With nothing late, this is the plain fusion at ``m``."""
        s0 = int(start.min())
        w = self._pre[s0].copy()
        rows = np.arange(self.n)
        for s in range(s0, m + 1):
            if s > s0:
                old = rows[start < s]
                for t, updated, frames in self._frames.get(s, ()):
                    keep = np.isin(updated, old)
                    if keep.any():
                        self._advance(w, t, updated[keep], [f for f, k in zip(frames, keep, strict=True) if k])
                _put(self._pre[s], w, old)  # their corrected sets at s, recomputed
                _put(w, self._pre[s], rows[start == s])
            if s in self._heard:
                parts, recv, send = self._heard[s]
                sent = self._received(parts[0] if self.uavs is None else _senders(parts, send))
                recv, send = np.concatenate(recv), np.concatenate(send)
                on = start[recv] <= s
                n_sent = len(sent.t)
                mine = self._swarm  # row r's own broadcast: the payloads' row of its UAV
                own = np.where([_same_row(w, sent, r, i) for r, i in zip(rows, mine, strict=True)], mine,
                               rows + n_sent)
                if (own >= n_sent).any():
                    sent = _stacked(sent, w)
                self._fuse_into(w, recv[on], send[on], sent, own, mine)  # in each group's canonical order
            else:  # nobody heard anybody at s: the fusion step with no links (what the sharing time did)
                self._fuse_into(w, rows[:0], rows[:0], w)
        _put(self.beliefs, w, rows)

    def sample(self) -> dict[str, np.ndarray]:
        return {**super().sample(), "late": self._late.copy(), "stale": self._stale.copy()}


def _put(dst: Beliefs, src: Beliefs, rows: np.ndarray) -> None:
    """Rows ``rows`` of ``src``'s sets, times, lineage and alarm counts into ``dst`` (either representation)."""
    for name in src.ROWS:
        getattr(dst, name)[rows] = getattr(src, name)[rows]
    for name, counts in dst.alarms.items():
        counts[rows] = src.alarms[name][rows]


def _same_row(a: Beliefs, b: Beliefs, r: int, i: int) -> bool:
    """Whether row r's sets in ``a`` are the very objects of row i of ``b`` (what UAV i broadcast: nothing was
    recomputed)."""
    for name in a.ROWS:
        x, y = getattr(a, name), getattr(b, name)
        if name == "identified":
            if not all(p is q for p, q in zip(x[r], y[i], strict=True)):
                return False
        elif name != "t" and x[r] is not y[i]:
            return False
    return True


def _senders(parts: list[dict], send: list[np.ndarray]) -> dict:
    """A subset's payloads of one sending time from the parts that delivered them: the first part's, with each later
    part's delivered rows ``send`` taken from that part (a subset's inbox holds a sender's row only in the parts
    whose links delivered it; the whole swarm's parts of one time share one outbox)."""
    if len(parts) == 1 or all(p is parts[0] for p in parts):
        return parts[0]
    out = {name: np.array(value, copy=True) for name, value in parts[0].items()}
    for part, senders in zip(parts[1:], send[1:], strict=True):
        for name, value in part.items():
            out[name][senders] = value[senders]
    return out


def _stacked(sent: Beliefs, own: Beliefs) -> Beliefs:
    """The broadcast rows, then the recomputed own rows (row ``N + i``: UAV i's), for :func:`fuse`'s ``own``."""
    return dataclasses.replace(sent, **{f: np.concatenate([getattr(sent, f), getattr(own, f)]) for f in sent.ROWS})
