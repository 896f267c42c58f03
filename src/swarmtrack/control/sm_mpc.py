"""Set-membership MPC (IB21 Sec. 5, eqs. 38-49) and its SimpleBaselineMPC, onboard.

Every control period ``T^c`` (0.5 s) UAV i picks the input sequence ``(u_0, …, u_{h−1})`` from ``U_d^h`` (a discrete
input set, each input a yaw acceleration held for ``T^c``) that minimises eq. 47,

    ``J = φ(X^{A,P}_{i,k+h}) + α·d(x^{u,P}_{i,k+h}, X^{A,P}_{i,k+h})``,

and applies ``u_0`` (receding horizon). The predicted aggregated set comes from the UAV's aggregated set ``X^A_i``
(eq. 43: the union of its identified sets, Xᵁ and X̄) by ``h`` rounds of

* eq. 44: ``P = (A ⊕ D(V^t·T^c)) ∩ X0``, dilation by the targets' reach in one period (outward, as the estimator
  dilates: :func:`swarmtrack.estimation.polygons.dilate`, without its vertex cap) and clipping to the area;
* eqs. 46, 49: ``A = P \\ (F_i(x^P_{i,k+κ}) ∪ ∪_{ℓ ∈ N^P_{i,k+κ}} F_ℓ(x^P_{ℓ,k+κ}))``, the UAV's predicted footprint and
  those of its lower-indexed neighbours ℓ < i (Sec. 5.3: they have already planned) whose predicted position is
  within the communication range ``d^c`` of the UAV's predicted position at that step (eq. 48).

The UAV's own states ``x^P`` are its fixed-wing model (:mod:`swarmtrack.models.fixed_wing`, the world's own
equations, eq. 1) stepped at ``T_d`` with each input held for ``T^c``; a neighbour's from the state it broadcast and
the plan it made earlier in the same call. ``d`` (A10): ``"nearest"`` (default) ``inf_{y ∈ X} ‖p − y‖`` in the
plane, the distance that "drives UAV i towards X^{A,P}" as the text says, or ``"hausdorff"``, ``sup_{y ∈ X} ‖p − y‖``
(the Hausdorff distance between {p} and X, the paper's word); 0 for an empty set. With α = 1e-4 the term only
breaks ties of the area (0.06 m² for 566 m).

**SimpleBaselineMPC** (IB21 Sec. 6, the video): "the evolution of the set estimates and the control input from
the neighbors are not taken into account": ``J = φ(X^A \\ ∪_κ F_i(x^P_{k+κ})) + α·d``, no dilation, no neighbours.

**Ties** (and the empty set, where every J is 0): candidates are ordered lexicographically, first input major, over
:func:`input_order` (0 first, then increasing ``|u|``; equal ``|u|`` in the order given: ``+`` before ``−`` by
default); the first candidate within round-off of the minimum wins, so with nothing to gain the UAV flies straight.

**Local window** (performance plan lever 4; ``exact=False``, the default). Let ρ be the buffer distance of one
dilation (the circumscribed radius of ``D(V^t T^c)``) and R the union of every footprint that differs between
candidates: the UAV's own at k+1 … k+h for every candidate, and a neighbour's at step κ if eq. 48 keeps it for some
candidates and drops it for others. Take the box ``W = bbox(R) ⊕ m`` with ``m = 2hρ + 1 m`` and run the same
rounds on ``X^A ∩ W`` instead of ``X^A``. Then **the local cost differs from the exact one by a constant, the same
for every candidate**, so both pick the same input:

1. *Locality.* Whether a point y lies in a dilation depends only on the input set within ρ of y; removals and
   clips are pointwise. So after j rounds the local set equals the exact one on ``W ⊖ jρ`` (the box shrunk by jρ).
2. *Where candidates differ.* Before any removal the set is the same for all candidates; a removal changes it only
   on R, and each dilation spreads a difference by at most ρ; so after h rounds two candidates' sets (exact, and
   local alike) can differ only on ``E = R ⊕ (h−1)ρ``.
3. Since ``m ≥ (2h−1)ρ``, ``E ⊆ W ⊖ hρ``: on E local and exact sets are equal; off E each is the same for every
   candidate. Hence ``φ(A_exact(c)) − φ(A_local(c)) = φ(A_exact \\ E) − φ(A_local \\ E)`` does not depend on c. ∎

The area outside the window is therefore dropped from the comparison, and the rounds operate on a polygon of
≈ 200 m × 200 m or less instead of the whole area. The distance term needs the true set: on ``W_ex = W ⊖ hρ`` the
local set is exact, so the nearest distance to ``A_local ∩ W_ex`` is the true one whenever it is no larger than the
distance from p to W_ex's edge (nothing outside can be nearer). Otherwise (the UAV far from any set) and always for
``"hausdorff"``, the part outside ``W_ex`` (the same for every candidate by 2.) is computed once per plan on the
full set, without the UAV's footprints, and ``d = min`` (``max`` for Hausdorff) over both parts. The reference
(``exact=True``) runs the rounds on the full set for every candidate.

**What the controller needs from outside.**

* ``nav``: each UAV's (N, 7) fixed-wing navigation state ``[x, y, z, γ, ψ, ψ̇, ψ̈]`` (exact, IB21 assumes known UAV
  states); the world hands the fixed-wing navigation state (extra columns beyond 7 are ignored).
* Each UAV's aggregated set X^A (eq. 43) as an (N,) object array of shapely geometries (None or empty: nothing left):
  the set-membership estimator's ``view().region`` (:func:`swarmtrack.estimation.setmembership.aggregated` of its
  beliefs), or a ``regions`` callable ``TargetView → (N,)`` given at construction; :func:`plan_all` takes the array
  directly.
* The inbox of the beacons it broadcast (``{"state": (N, 7)}``), with the links that carried them: UAV i reads
  neighbour ℓ's state, and the plan ℓ made earlier in the same call, only where ``links[i, ℓ]`` (A19; with no delays
  this is Sec. 5.3's waiting rule).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely

from swarmtrack.control.sm_mpc_problem import (
    DEFAULT_SETTINGS,
    DISTANCES,  # noqa: F401 (re-exported: importable from here as before the problem moved)
    Choice,
    Removals,
    SMMPCSettings,
    candidates,
    choose,
    footprints,
    input_order,  # noqa: F401 (re-exported)
    predict,
    removals,
)
from swarmtrack.estimation import polygons as pg
from swarmtrack.estimation.base import Probe, TargetView
from swarmtrack.estimation.set_backends import SetBackend
from swarmtrack.models import fixed_wing as fw
from swarmtrack.network.links import edge_list

#: Slack (m) added to the local window beyond what the proof needs (GEOS's arcs, round-off).
WINDOW_SLACK = 1.0


# --- the rounds of eqs. 44-49 ------------------------------------------------------------------------------------


_BOXES: dict[int, tuple[object, bool]] = {}


def _is_box(area) -> bool:
    """Whether X0 is a rectangle, once per area object (kept with its answer, so its id stays its own)."""
    hit = _BOXES.get(id(area))
    if hit is None or hit[0] is not area:
        if len(_BOXES) > 64:
            _BOXES.clear()
        hit = _BOXES[id(area)] = (area, bool(shapely.equals(area, shapely.box(*area.bounds))))
    return hit[1]


def evolve(region, rem: Removals, s: SMMPCSettings, area, *, use_own: bool = True,
           nb_masks: list[np.ndarray] | None = None, own_last: bool = True, box: bool = False,
           window: tuple[float, float, float, float] | None = None) -> np.ndarray:
    """The predicted aggregated sets at k+h, one per node of the last level (C,): h rounds of eq. 44 (skipped by the
    baseline) and eqs. 46/49. ``own_last`` False leaves the UAV's own footprint out of the last round (the caller
    measures it, :func:`_minus_areas`). With ``use_own`` False: one set, without the UAV's footprints and with only
    the neighbours in ``nb_masks[κ]`` (L,) at each step, which eq. 48 must then keep for all candidates or none.
    ``box``: X0 is a rectangle, clipped to with GEOS's rectangle clipping (same set, faster). ``window``: also clip
    every round to this box (the local window: what a dilation pushes out of it is dropped, which only widens the
    band along its edge where the local sets are inexact by the ρ the proof allows per round). The empty set (a UAV
    whose window holds nothing) gives empty sets without a GEOS call (:func:`_evolve_empty`)."""
    region = pg.EMPTY if region is None else region
    rect = None if s.baseline else _rect(area, box, window)
    if region.is_empty:
        return _evolve_empty(s, len(s.inputs) if use_own else 1, box, rect)
    return _rounds(region, rem, s, area, use_own, nb_masks, own_last, box, rect)


def _rounds(region, rem: Removals, s: SMMPCSettings, area, use_own: bool, nb_masks, own_last: bool, box: bool,
            rect) -> np.ndarray:
    """:func:`evolve`'s rounds, with ``rect`` the rectangle of every round's clip (:func:`_rect`)."""
    branch = len(s.inputs) if use_own else 1
    a = np.array([region], dtype=object)
    reach = s.target_speed * s.period
    for k in range(s.horizon):
        if not s.baseline:
            a = pg.dilate(a, reach, quad_segs=s.quad_segs, cap=math.inf)
            if not box:
                a = pg.clip(a, area)
            if rect is not None:
                pg.OPS["clip"] += len(a)
                a = shapely.clip_by_rect(a, *rect) if rect else pg.empty(len(a))  # () : the window lies off X0
        if branch > 1:
            a = np.repeat(a, branch)
        kept = rem.kept[k] if use_own else rem.kept[k][:1]
        if nb_masks is not None:
            kept = kept & nb_masks[k][None, :]
        if kept.any():  # eq. 49: once per distinct (parent, kept neighbours), not per candidate
            a = _remove_neighbours(a, kept, branch, rem, k)
        if use_own and (own_last or k < s.horizon - 1):  # eq. 46 (a footprint that misses leaves the set as it is)
            a = pg.remove(a, rem.own[k])
    return a


def _evolve_empty(s: SMMPCSettings, branch: int, box: bool, rect) -> np.ndarray:
    """:func:`evolve` of the empty set: empty sets, with the operations :func:`_rounds` counts for it (every
    dilation and clip of each node; no removal, as no footprint meets an empty set, so no union of footprints)."""
    n = 1
    for _ in range(s.horizon):
        if not s.baseline:
            pg.OPS["buffer"] += n
            pg.OPS["clip"] += n * (int(not box) + int(rect is not None))
        n *= branch
    return pg.empty(n)


def _rect(area, box: bool, window) -> tuple[float, ...] | None:
    """The rectangle :func:`evolve` clips every round to: X0's bounds (``box``), the ``window``, or both's
    intersection; None for none, ``()`` where the window lies off X0."""
    if not box and window is None:
        return None
    bounds = np.array(area.bounds if box else window)
    if box and window is not None:
        bounds = np.concatenate([np.maximum(bounds[:2], window[:2]), np.minimum(bounds[2:], window[2:])])
    return tuple(bounds.tolist()) if bounds[2] > bounds[0] and bounds[3] > bounds[1] else ()


def _remove_neighbours(a: np.ndarray, kept: np.ndarray, branch: int, rem: Removals, k: int) -> np.ndarray:
    """Eq. 49 at step ``k``: each set ``a`` (n,) minus the union of the neighbours' footprints ``kept`` (n, L) keeps
    for it, computed once per distinct (parent, kept neighbours) (the rows are coded as integers: L is small)."""
    n, n_nb = kept.shape
    if n == 1:
        first, group = np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64)
    else:
        code = (np.arange(n) // branch) * (1 << n_nb) + kept.astype(np.int64) @ (1 << np.arange(n_nb))
        _, first, group = np.unique(code, return_index=True, return_inverse=True)
    unions: dict[bytes, shapely.Geometry] = {}
    out = a[first].copy()
    for g, row in enumerate(first):
        mask = kept[row]
        if mask.any() and not out[g].is_empty:
            key = mask.tobytes()
            if key not in unions:
                unions[key] = rem.neighbours(k, mask)
            out[g] = pg.remove(out[g], unions[key])  # a miss removes nothing: no overlay
    return out[group.ravel()]


def _minus_areas(sets: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """``φ(A_c ∩ F_c)`` for sets (C,) and rectangles F_c given by their corners (C, 4, 2) (as
    :func:`footprint_corners` orders them), without an overlay: each set is mapped, by the affine map that takes
    F_c to the unit square [−1, 1]², into that square's frame, clipped there by GEOS's rectangle clipping (a few µs,
    against ≈ 20 µs for a general overlay) and its area scaled back. Then ``φ(A \\ F) = φ(A) − φ(A ∩ F)``. An
    empty set's is 0 without a GEOS call (most candidates', when the window holds nothing)."""
    centre = corners.mean(axis=1)
    along, across = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 1]
    la, lc = np.linalg.norm(along, axis=1), np.linalg.norm(across, axis=1)
    ua, uc = along / la[:, None], across / lc[:, None]
    pg.OPS["clip"] += len(sets)
    out = np.zeros(len(sets))  # an empty set's: 0 (its clip is empty)
    live = ~shapely.is_empty(sets)
    if live.any():
        sets, la, lc = sets[live], la[live], lc[live]
        # per vertex: the centre and the map's two rows of its set's rectangle (one repeat for all six numbers)
        maps = np.repeat(np.column_stack([centre[live], ua[live] * 2 / la[:, None], uc[live] * 2 / lc[:, None]]),
                         shapely.get_num_coordinates(sets), axis=0)
        xy = shapely.get_coordinates(sets)
        dx, dy = xy[:, 0] - maps[:, 0], xy[:, 1] - maps[:, 1]
        unit = np.column_stack([dx * maps[:, 2] + dy * maps[:, 3], dx * maps[:, 4] + dy * maps[:, 5]])
        unit = shapely.clip_by_rect(shapely.set_coordinates(sets.copy(), unit), -1.0, -1.0, 1.0, 1.0)
        out[live] = shapely.area(unit) * la * lc / 4
    return out


def set_distance(sets, xy, kind: str = "nearest") -> np.ndarray:
    """d of eq. 47 from points ``xy`` (n, 2) to ``sets`` (n,), or to one set from every point: nearest (inf) or
    Hausdorff (sup, the farthest vertex); NaN for an empty set."""
    return _point_distance(shapely.points(np.asarray(xy, dtype=float).reshape(-1, 2)), sets, kind)


def _point_distance(pts, sets, kind: str = "nearest") -> np.ndarray:
    """:func:`set_distance` from points already made (a set may be one geometry for all of them)."""
    if kind == "nearest":
        return shapely.distance(pts, sets)
    return shapely.hausdorff_distance(pts, sets)  # from a point: the farthest vertex, sup over the polygon


def _box_gap(xy: np.ndarray, box) -> np.ndarray:
    """Distance from points inside ``box`` (x0, y0, x1, y1) to its edge."""
    x0, y0, x1, y1 = box
    return np.minimum.reduce([xy[:, 0] - x0, xy[:, 1] - y0, x1 - xy[:, 0], y1 - xy[:, 1]])


def plan_one(region, own_states: np.ndarray, nb_states: np.ndarray, area, s: SMMPCSettings = DEFAULT_SETTINGS,
             exact: bool | None = None, prune: bool = True, shared: dict | None = None,
             corners: tuple[np.ndarray, np.ndarray | None] | None = None) -> Choice:
    """Eq. 47 minimised over U_d^h for one UAV: ``region`` its X^A (a shapely geometry), ``own_states`` (C, h, 7)
    its predicted states per candidate (:func:`predict` over :func:`candidates`), ``nb_states`` (L, h, 7) its
    lower-indexed neighbours' predicted states, ``area`` X0. ``exact`` (default ``s.exact``): the full-set
    reference instead of the local window (module docstring). ``prune`` (local window only): compute the distance
    only for candidates whose area term leaves them a chance (the others' cost is reported as ``inf``). ``shared``:
    a dict kept across the UAVs of one fleet plan, where the full-set rounds without any footprint (the far part
    of the distance) are kept per X^A object: UAVs holding the same X^A share them. ``corners``: the footprints'
    corners of both kinds of states, if known (:func:`removals`)."""
    exact = s.exact if exact is None else exact
    ops0 = sum(pg.OPS.values())
    cands = candidates(s.inputs, s.horizon)
    rem = removals(own_states, nb_states, s, neighbours=not s.baseline, corners=corners)
    xy_end = rem.xy[-1]
    region = pg.EMPTY if region is None else region
    window = None
    if region.is_empty:
        areas, dist = np.zeros(len(cands)), np.zeros(len(cands))
    elif exact:
        leaves = evolve(region, rem, s, area)
        areas = pg.area(leaves)
        dist = np.nan_to_num(set_distance(leaves, xy_end, s.distance), nan=0.0)
    else:
        areas, dist, window = _local_costs(region, rem, s, area, prune, shared)
    cost = areas + s.alpha * dist
    index = choose(cost)
    ops = sum(pg.OPS.values()) - ops0
    return Choice(index, cands[index], cost, areas, dist, ops, window)


def _local_costs(region, rem: Removals, s: SMMPCSettings, area, prune: bool, shared: dict | None = None):
    """Areas (up to a constant) and exact distances on the local window (module docstring, lever 4). The last
    round's own footprint is measured, not removed (:func:`_minus_areas`); the sets themselves are built (one
    overlay each) only for the candidates whose distance is needed."""
    h, rho = s.horizon, (0.0 if s.baseline else s.reach)
    pts = [np.concatenate(rem.corners).reshape(-1, 2)]
    steady = []  # per step, the neighbours eq. 48 keeps for all candidates or for none
    for k in range(h):
        kept = rem.kept[k]
        vary = kept.any(axis=0) & ~kept.all(axis=0)  # eq. 48 keeps ℓ for some candidates only: part of R
        if vary.any():
            pts.append(rem.nb_corners[vary, k].reshape(-1, 2))
        steady.append(~vary)
    window_pts = np.concatenate(pts)
    m = 2 * h * rho + WINDOW_SLACK
    lo, hi = window_pts.min(axis=0) - m, window_pts.max(axis=0) + m
    window = (lo[0], lo[1], hi[0], hi[1])
    shrink = h * rho
    exact_box = (lo[0] + shrink, lo[1] + shrink, hi[0] - shrink, hi[1] - shrink)  # W ⊖ hρ, where local is exact
    pg.OPS["clip"] += 1
    local = shapely.clip_by_rect(region, *window)
    box = _is_box(area)
    touch = [((rem.nb_corners[:, k].min(axis=1) <= hi) & (rem.nb_corners[:, k].max(axis=1) >= lo)).all(axis=1)
             for k in range(h)]  # a neighbour's footprint off the window changes nothing in it
    before = evolve(local, rem, s, area, nb_masks=touch, own_last=False, box=box, window=window)  # (C,) P_h
    cut = _minus_areas(before, rem.corners[-1])
    areas = shapely.area(before) - cut
    # eq. 47's distance, for the candidates that can still win
    need = np.ones(len(areas), dtype=bool)
    dist = np.full(len(areas), np.inf)
    far: dict = {"shared": shared}  # the part outside the exact box, the same for every candidate: once per plan
    if prune:
        first = choose(areas)
        need[:] = False
        need[first] = True
        dist[first] = _distances(region, rem, s, area, before, cut, np.array([first]), exact_box, steady, box,
                                 far)[0]
        bound = areas[first] + s.alpha * dist[first]
        need = areas <= bound + 1e-9 + 1e-12 * abs(bound)
        need[first] = False
    rows = np.flatnonzero(need)
    if len(rows):
        dist[rows] = _distances(region, rem, s, area, before, cut, rows, exact_box, steady, box, far)
    return areas, dist, window


def _distances(region, rem: Removals, s: SMMPCSettings, area, before, cut, rows, exact_box, steady, box,
               far: dict):
    """d of eq. 47 (0 for an empty set) for the candidates ``rows`` (their ends ``rem.xy[-1]``), exact although the
    sets are local: true on the exact box ``W ⊖ hρ`` (``exact_box``) when no farther than its edge, otherwise (and
    for Hausdorff) combined with the part of the set outside that box, the same for every candidate (module
    docstring)."""
    h = s.horizon
    sets = before[rows].copy()
    hit = cut[rows] > 0
    if hit.any():
        sets[hit] = pg.remove(sets[hit], rem.own[-1][rows[hit]])
    xy = rem.xy[-1][rows]
    pg.OPS["clip"] += len(sets)
    near = np.full(len(sets), np.nan)  # from an empty set: NaN
    live = ~shapely.is_empty(sets)
    if live.any():
        near[live] = set_distance(shapely.clip_by_rect(sets[live], *exact_box), xy[live], s.distance)
    certified = near <= _box_gap(xy, exact_box)  # NaN (nothing inside) is not certified
    if s.distance == "nearest" and certified.all():
        return near
    if s.distance == "nearest":
        return np.nan_to_num(np.fmin(near, _far_nearest(region, rem, s, area, xy, exact_box, steady, box, far)),
                             nan=0.0)
    if "set" not in far:  # ``far`` caches it for the plan's other calls
        plain = not any((rem.kept[k][:1] & steady[k][None, :]).any() for k in range(h))  # no footprint removed
        cache = far["shared"] if plain and far["shared"] is not None else {}
        key = (id(region), box)
        if key not in cache:
            cache[key] = evolve(region, rem, s, area, use_own=False, nb_masks=steady, box=box)[0]
        outside = cache[key]
        pg.OPS["difference"] += 1
        far["set"] = shapely.difference(outside, shapely.box(*exact_box))
    outer = set_distance(far["set"], xy, s.distance)
    both = np.fmin(near, outer) if s.distance == "nearest" else np.fmax(near, outer)
    return np.nan_to_num(both, nan=0.0)


def _far_nearest(region, rem: Removals, s: SMMPCSettings, area, xy, exact_box, steady, box, far: dict):
    """The nearest distance (eq. 47's d, NaN if empty) from points ``xy`` to the part of the full-set rounds (without
    the UAV's footprints, :func:`evolve` ``use_own=False``) outside ``exact_box``, computed part by part of X^A,
    nearest parts first, with a bound that skips the others:

    * every operation of the rounds acts part by part (a dilation of a union is the union of the dilations, clips
      and removals are pointwise), so the set is the union of each part's rounds and its distance the minimum;
    * a part's rounds lie within ``h·ρ`` of it (each buffer by ρ stays within ρ of its input; clips and removals
      only remove), so its distance is at least ``d(p, part) − h·ρ``: a part whose bound is not below every point's
      best distance so far cannot be nearer and is not evolved.

    So the result is the distance to the whole set's rounds (the same value up to round-off), while only the parts
    near the UAV are dilated. Each part's rounds are kept per plan in ``far`` (per fleet plan, with the sharing
    rules of :func:`_distances`, when no footprint is removed)."""
    h, rho = s.horizon, (0.0 if s.baseline else s.reach)
    if "parts" not in far:
        plain = not any((rem.kept[k][:1] & steady[k][None, :]).any() for k in range(h))  # no footprint removed
        far["cache"] = far["shared"] if plain and far["shared"] is not None else {}
        far["parts"] = shapely.get_parts(region)
        far["rounds"] = {}
    parts = far["parts"]
    pts = shapely.points(xy)
    bound = shapely.distance(parts[:, None], pts[None, :]) - h * rho - 1e-9  # (P, n)
    lowest = bound.min(axis=1).tolist()
    best = np.full(len(xy), np.inf)
    worst = math.inf  # best.max()
    for p in np.argsort(lowest, kind="stable").tolist():
        if lowest[p] >= worst:
            break  # this part and every later one are no nearer
        if (bound[p] >= best).all():
            continue
        key = (id(region), p, box)
        if key not in far["cache"]:
            far["cache"][key] = (region, evolve(parts[p], rem, s, area, use_own=False, nb_masks=steady, box=box)[0])
        if p not in far["rounds"]:
            pg.OPS["difference"] += 1
            far["rounds"][p] = shapely.difference(far["cache"][key][1], shapely.box(*exact_box))
        best = np.fmin(best, _point_distance(pts, far["rounds"][p], s.distance))
        worst = best.max()
    return np.where(np.isinf(best), np.nan, best)


# --- the fleet, in index order (Sec. 5.3) ------------------------------------------------------------------------


@dataclass
class FleetPlan:
    """Every UAV's plan this period: ``plans`` (N, h), ``cost`` (N,) the chosen eq. 47 value (local window: up to a
    constant per UAV), ``solve_time`` (N,) s, ``neighbours`` (N,) lower-indexed neighbours heard, ``ops`` (N,) set
    operations."""

    plans: np.ndarray
    cost: np.ndarray
    solve_time: np.ndarray
    neighbours: np.ndarray
    ops: np.ndarray
    choices: list[Choice]


def plan_all(nav, regions, area, s: SMMPCSettings = DEFAULT_SETTINGS, links=None, beacons=None,
             exact: bool | None = None, grid=None, uavs=None, heard_plans=None) -> FleetPlan:
    """Sec. 5.3's sequential rounds in index order: UAV i plans from its own ``nav`` (N, 7) row and ``regions[i]``
    (its X^A), with the plans of its lower-indexed neighbours ℓ < i made before it in this call, read only where
    ``links[i, ℓ]`` carried ℓ's beacon (``beacons`` (N, 7), the broadcast states; default ``nav``). ``grid``: the
    regions are raster fields on it (:mod:`swarmtrack.estimation.raster`), planned by
    :func:`swarmtrack.control.sm_mpc_raster.plan_one_raster`.

    For a subset of the swarm (one UAV's own process): ``uavs`` (R,) the swarm's UAVs the rows of ``nav``,
    ``regions`` and ``links`` are (sorted; default every UAV), ``beacons`` every sender's, and ``heard_plans``
    (N, h) the plans the other UAVs made in this call (their plan messages; a row is read only for a lower-indexed
    neighbour outside ``uavs`` whose beacon was heard). Such a neighbour's predicted states are its beacon's rolled
    out over its plan (:func:`predict`, elementwise: the numbers the fleet rollout gives that row)."""
    if grid is not None:
        from swarmtrack.control.sm_mpc_raster import plan_one_raster

        def plan(region, own_states, nb_states, shared, corners):
            return plan_one_raster(grid, region, own_states, nb_states, s, shared=shared, corners=corners)
    else:
        def plan(region, own_states, nb_states, shared, corners):
            return plan_one(region, own_states, nb_states, area, s, exact, shared=shared, corners=corners)
    nav = np.asarray(nav, dtype=float)[:, :fw.STATE_DIM]
    n = len(nav)
    ids = np.arange(n) if uavs is None else np.asarray(uavs)
    beacons = nav if beacons is None else np.asarray(beacons, dtype=float)[:, :fw.STATE_DIM]
    cands = candidates(s.inputs, s.horizon)
    t0 = time.perf_counter()
    own = predict(nav[:, None, :], cands[None, :, :], s)  # (N, C, h, 7), one batched rollout for the fleet
    corners = footprints(own, s)  # (N, C, h, 4, 2), the footprints of eqs. 46, 49, once for the fleet too
    shared = (time.perf_counter() - t0) / max(n, 1)
    if links is None or s.baseline:
        recv = send = np.zeros(0, dtype=int)
    else:
        recv, send = edge_list(links)
    plans = np.zeros((n, s.horizon))
    out = FleetPlan(plans, np.zeros(n), np.full(n, shared), np.zeros(n), np.zeros(n), [])
    common: dict = {}  # what UAVs with the same X^A can share (plan_one)
    chosen = np.zeros(n, dtype=np.int64)
    row_of = np.full(len(beacons), -1)  # the row of each of the swarm's UAVs built here (−1: another process's)
    row_of[ids] = np.arange(n)
    same = np.zeros(len(beacons), dtype=bool)  # the broadcast state is the one the fleet rollout used
    same[ids] = (beacons[ids] == nav).all(axis=1)
    for r, i in enumerate(ids.tolist()):
        t0 = time.perf_counter()
        lower = send[(recv == r) & (send < i)]
        nb_corners = None
        if not len(lower):
            nb = np.zeros((0, s.horizon, fw.STATE_DIM))
        elif same[lower].all():  # planned here, from the states the fleet rollout used
            rows = row_of[lower]
            nb, nb_corners = own[rows, chosen[rows]], corners[rows, chosen[rows]]
        else:
            nb = predict(beacons[lower], _plans_of(lower, row_of[lower], plans, heard_plans), s)
        choice = plan(regions[r], own[r], nb, common, (corners[r], nb_corners))
        plans[r], chosen[r] = choice.plan, choice.index
        out.solve_time[r] += time.perf_counter() - t0
        out.cost[r] = choice.cost[choice.index]
        out.neighbours[r] = len(lower)
        out.ops[r] = choice.ops
        out.choices.append(choice)
    return out


def _plans_of(senders: np.ndarray, rows: np.ndarray, plans: np.ndarray, heard_plans) -> np.ndarray:
    """The plans (L, h) the ``senders`` made in this call: those planned here (``rows`` ≥ 0) from ``plans``, the
    others' from their plan messages ``heard_plans``."""
    out = plans[rows]
    away = rows < 0
    if away.any():
        if heard_plans is None:
            raise ValueError("a UAV whose lower-indexed neighbours plan in other processes needs their plans of "
                             "this call: the inbox's `plan` payload")
        out[away] = np.asarray(heard_plans, dtype=float)[senders[away]]
    return out


def _view_region(view: TargetView) -> np.ndarray:
    if view.region is None:
        raise ValueError("the set-membership MPC needs each UAV's aggregated set X^A: an estimator whose view() has "
                         "`region` (Regions), or a `regions` callable")
    return view.region.sets


def _own_state(nav: np.ndarray) -> np.ndarray:
    """The fixed wing's full state (N, 7): the last columns of its navigation solution (the world appends it after
    ``[x, y, vx, vy]``; a bare (N, 7) state is taken as it is)."""
    return np.asarray(nav, dtype=float)[:, -fw.STATE_DIM:]


class SetMembershipMPC:
    """IB21's SM-MPC on every UAV (Controller protocol): plans every ``settings.period`` s in index order
    (:func:`plan_all`) and commands the first input of its plan, held until the next plan, as the yaw acceleration
    (N, 1) rad/s².

    ``sets``: the run's set backend (:mod:`swarmtrack.estimation.set_backends`: X0 as polygons, or as raster fields
    on a grid, the estimator's own). ``regions``: ``TargetView → (N,)`` X^A per UAV (default: ``view.region.sets``,
    what the set-membership estimator exposes).
    ``start``: s before which every UAV flies straight.
    Broadcasts each UAV's state (its beacon for eq. 48); reads a neighbour's plan only over the links that carried
    its beacon.

    ``uavs``: the swarm's UAVs it is built for (default: every UAV of the first command; a subset is one UAV's own
    process, whose lower-indexed neighbours in other processes send their plans of the call as the inbox's ``plan``
    payload (N, h) before it plans); :meth:`plans` is this component's own plan message."""

    def __init__(self, sets: SetBackend, settings: SMMPCSettings = DEFAULT_SETTINGS, *,
                 regions: Callable[[TargetView], np.ndarray] | None = None, start: float = 0.0, n_uavs: int = 0,
                 uavs: np.ndarray | None = None):
        self.area, self.s, self.start = sets.area, settings, start
        self.uavs = None if uavs is None else np.asarray(uavs)
        self.n = n_uavs if self.uavs is None else len(self.uavs)
        self.grid = sets.grid
        if self.grid is not None:  # the raster planner's kernels, loaded before any plan is timed
            from swarmtrack.control.sm_mpc_raster import warm

            warm()
        self.region_of = regions or _view_region
        self._next = start
        self.u: np.ndarray | None = None
        self.last: FleetPlan | None = None
        self.probes = (Probe("yaw_accel", ()), Probe("solve_time", ()), Probe("cost", ()), Probe("candidates", ()),
                       Probe("neighbours", ()), Probe("set_ops", ()))
        self._values: dict[str, np.ndarray] = {}

    def broadcast(self, t: float, nav: np.ndarray) -> dict:
        """Beacon: own fixed-wing state (Sec. 5.3: the state at k; the plan follows in the same call)."""
        return {"state": _own_state(nav)}

    def command(self, t: float, nav: np.ndarray, view: TargetView, inbox, dt: float) -> np.ndarray:
        n = len(nav)
        if self.u is None:
            self.u = np.zeros(n)
            self._values = {p.name: np.zeros(n) for p in self.probes}
        if t >= self._next - 1e-9:
            links = None if inbox is None else inbox.links
            beacons = None if inbox is None else inbox.payloads.get("state")
            heard = None if inbox is None else inbox.payloads.get("plan")
            plan = plan_all(_own_state(nav), self.region_of(view), self.area, self.s, links, beacons, grid=self.grid,
                            uavs=self.uavs, heard_plans=heard)
            self.u = plan.plans[:, 0].copy()
            self.last = plan
            self._values.update(solve_time=plan.solve_time, cost=plan.cost, neighbours=plan.neighbours,
                                set_ops=plan.ops, candidates=np.full(n, float(len(plan.choices[0].cost))))
            self._next = t + self.s.period
        self._values["yaw_accel"] = self.u.copy()
        return self.u[:, None].copy()

    def plans(self) -> dict[str, np.ndarray]:
        """The plan message of this component's UAVs (R, h): the input sequences of their last plan (NaN before the
        first), which the higher-indexed neighbours of another process read in the same call (Sec. 5.3)."""
        n = self.n if self.u is None else len(self.u)
        return {"plan": np.full((n, self.s.horizon), np.nan) if self.last is None else self.last.plans.copy()}

    def sample(self) -> dict[str, np.ndarray]:
        n = self.n if self.u is None else len(self.u)
        return {p.name: self._values.get(p.name, np.zeros(n)).copy() for p in self.probes}
