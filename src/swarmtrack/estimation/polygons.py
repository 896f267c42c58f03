"""Planar sets for guaranteed (set-membership) estimation, IB21 Secs. 4-5: every operation returns an *outer*
approximation of the exact set, so a set that must contain a target still contains it after the operation.

Sets are shapely 2 geometries (polygons, multipolygons, or empty), held in object arrays over the swarm; the
functions take and return such arrays and use shapely's vectorised functions. What each operation needs:

* **dilation** by a disc of radius r (the reachable displacement, IB21 eqs. 13-15, 44): GEOS places a buffer's
  vertices *on* the circle, so a plain buffer lies inside the exact dilation (0.48 % short at ``quad_segs=8``). A
  buffer by ``r / cos(π / (4 q))`` circumscribes it: each segment of a quarter circle cut into q subtends π/(2q), and
  its midpoint is at the buffer radius times ``cos(π/(4q))``;
* **simplification**, against vertex counts that grow with every buffer and difference: Douglas-Peucker with
  tolerance ε keeps the Hausdorff distance to the original within ε, so ``original ⊆ simplified ⊕ D(ε)``; it is
  done only inside :func:`dilate`, whose buffer then grows by ε, so no simplified set is ever used uncovered;
* **removal of an explored region** ``A \\ F`` (eqs. 21, 26, 28): F must be an *inner* approximation of what was
  truly explored, so the footprint is eroded by a small margin before it is removed;
* **intersection** with the area or a measurement box and **union**: exact, from outer operands.

:data:`OPS` counts the operations by kind, to profile a run.
"""

from __future__ import annotations

import collections
import math

import numba
import numpy as np
import shapely

#: Absolute margin (m) against floating-point round-off: dilations grow by it, removed regions shrink by it.
DELTA = 1e-6
#: How far (m) :func:`loosen` pushes edges out: at 1e-6 m GEOS's overlay still meets near-coincident edges (about
#: 2x slower than at 1e-5 m on the fusion's operands); the sets are dilated by V^t·T^c = 0.5 m every period anyway.
LOOSEN = 1e-5
#: Segments per quarter circle of a dilation's disc.
QUAD_SEGS = 8
#: Outward simplification: tolerance (m) and the vertex count from which a set is simplified.
SIMPLIFY_EPS, VERTEX_CAP = 0.005, 300
#: Operations done, by kind (buffer, clip, difference, intersection, union, simplify).
OPS: collections.Counter = collections.Counter()

EMPTY = shapely.Polygon()


def empty(n: int | tuple[int, ...]) -> np.ndarray:
    """An object array of empty sets."""
    out = np.empty(n, dtype=object)
    out[...] = EMPTY
    return out


def distinct(sets: np.ndarray, *keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows holding the same set object with equal ``keys`` (per-row values): ``first`` (sorted), the first row of
    each kind, and ``inverse``, so that ``x[first][inverse]`` rebuilds the rows. The same object in, the same result
    out: an operation on ``sets[first]`` serves every row."""
    seen: dict[tuple, int] = {}
    first, inverse = [], np.empty(len(sets), dtype=np.int64)
    for row, s in enumerate(sets):
        key = (id(s), *(k[row] for k in keys))
        if key not in seen:
            seen[key] = len(first)
            first.append(row)
        inverse[row] = seen[key]
    return np.array(first, dtype=np.int64), inverse


def circumscribed(r, quad_segs: int = QUAD_SEGS):
    """The buffer distance whose buffer contains the exact dilation by ``r`` (a number or an array), plus
    :data:`DELTA`.

    GEOS draws the arc of a convex vertex, of angle θ, with ``round(θ / q)`` chords of equal angle (``q = π /
    (2·quad_segs)``; JTS/GEOS ``OffsetSegmentGenerator::addDirectedFillet``), and none under ``q / 2``: a chord spans
    up to ``1.5 q``, not ``q``, so it dips inside the distance by up to ``1 − cos(0.75 q)``. Growing ``r`` by
    ``1 / cos(0.75 q)`` keeps every chord outside the exact arc. (With ``1 / cos(q / 2)``, the factor for chords of
    ``q`` alone, used until 2026-12: points of the exact dilation up to 0.6 % of ``r`` outside, at vertices whose
    turn is just over ``q``; found on random polygons, see the tests.)"""
    return r / math.cos(3 * math.pi / (8 * quad_segs)) + DELTA


def dilate(sets: np.ndarray, r: float, *, quad_segs: int = QUAD_SEGS, eps: float = SIMPLIFY_EPS,
           cap: float = VERTEX_CAP) -> np.ndarray:
    """``A ⊕ D(r)`` of every set, as an outer approximation: sets above ``cap`` vertices are simplified with
    tolerance ``eps`` first and the buffer grows by ``eps`` (IB21 eqs. 13-15 with the reachable displacement r)."""
    sets = np.asarray(sets, dtype=object)
    big = shapely.get_num_coordinates(sets) > cap if cap < math.inf else None
    if big is None or not big.any():  # nothing to simplify: every set grows by r (the same numbers as below)
        OPS["buffer"] += len(sets)
        return shapely.buffer(sets, circumscribed(r, quad_segs), quad_segs=quad_segs)
    grow = np.where(big, r + eps, r)
    if big.any():
        OPS["simplify"] += int(big.sum())
        sets = sets.copy()
        sets[big] = simplify_outer(sets[big], eps)
    OPS["buffer"] += len(sets)
    return shapely.buffer(sets, circumscribed(grow, quad_segs), quad_segs=quad_segs)


@numba.njit(cache=True)
def _dp_keep(xy: np.ndarray, rings: np.ndarray, eps: float) -> np.ndarray:  # pragma: no cover (compiled)
    """Douglas-Peucker on each closed ring ``xy[rings[k]:rings[k+1]]`` (first point repeated last): which vertices
    stay. Every vertex dropped lies within ``eps`` of the segment between the two kept ones around it (distance to
    the segment, not the line). A ring left with fewer than 4 points keeps all of its own."""
    keep = np.zeros(len(xy), dtype=np.bool_)
    stack = np.empty((len(xy) + 2, 2), dtype=np.int64)
    for k in range(len(rings) - 1):
        a0, b0 = rings[k], rings[k + 1] - 1
        keep[a0] = True
        keep[b0] = True
        stack[0, 0], stack[0, 1] = a0, b0
        top = 1
        while top > 0:
            top -= 1
            a, b = stack[top, 0], stack[top, 1]
            if b - a < 2:
                continue
            ax, ay, bx, by = xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1]
            dx, dy = bx - ax, by - ay
            ll = dx * dx + dy * dy
            far, worst = -1.0, a
            for m in range(a + 1, b):
                px, py = xy[m, 0] - ax, xy[m, 1] - ay
                if ll > 0.0:
                    t = (px * dx + py * dy) / ll
                    t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
                else:
                    t = 0.0
                ex, ey = px - t * dx, py - t * dy
                d2 = ex * ex + ey * ey
                if d2 > far:
                    far, worst = d2, m
            if far > eps * eps:
                keep[worst] = True
                stack[top, 0], stack[top, 1] = a, worst
                stack[top + 1, 0], stack[top + 1, 1] = worst, b
                top += 2
        n = 0
        for m in range(a0, b0 + 1):
            if keep[m]:
                n += 1
        if n < 4:
            for m in range(a0, b0 + 1):
                keep[m] = True
    return keep


def simplify_outer(sets: np.ndarray, eps: float) -> np.ndarray:
    """Each set with its rings simplified (Douglas-Peucker, tolerance ``eps``) so that ``A ⊆ S ⊕ D(eps)``: the
    dilation of S by ``r + eps`` contains that of A by r (what :func:`dilate` needs).

    Why it is outer: each ring R of A becomes a ring R' of S made of a subsequence of its vertices, each dropped
    vertex (so each dropped stretch of R, the ε-neighbourhood of a segment being convex) within ε of the chord R'
    replaces it by. Mapping each point of R to its projection on that chord and moving it there in a straight line
    is a homotopy from R to R' that never leaves ``R' ⊕ D(ε)``, so any point x farther than ε from every ring of S
    has the same winding number about R and R' for every ring. S keeps every ring of A in its polygon (no ring is
    dropped: one left with < 4 points keeps all its vertices), so when S is *valid*, x lies in S exactly when it
    lies in A (A is valid, as GEOS's operations return it). Hence ``A \\ S ⊆ ∂S ⊕ D(ε)``. Where S is not valid
    (a ring crossing itself or another), the set is simplified by GEOS's topology-preserving simplifier instead,
    whose result is within Hausdorff distance ε of A in the same way. No GEOS call but the validity test: several
    times faster than the topology-preserving simplifier on the estimator's sets."""
    sets = np.asarray(sets, dtype=object)
    out = sets.copy()
    kinds = shapely.get_type_id(sets)
    ours = ((kinds == 3) | (kinds == 6)) & ~shapely.is_empty(sets)  # polygons, multipolygons
    if ours.any():
        kind, xy, offsets = shapely.to_ragged_array(sets[ours])  # as multipolygons
        rings = offsets[0].astype(np.int64)
        keep = _dp_keep(np.ascontiguousarray(xy), rings, float(eps))
        counts = np.add.reduceat(keep.astype(np.int64), rings[:-1])
        simple = shapely.from_ragged_array(kind, xy[keep], (np.concatenate([[0], np.cumsum(counts)]), *offsets[1:]))
        single = kinds[ours] == 3
        simple[single] = shapely.get_geometry(simple[single], 0)
        bad = ~shapely.is_valid(simple)
        if bad.any():
            simple[bad] = shapely.simplify(sets[ours][bad], eps, preserve_topology=True)
        out[ours] = simple
    if (~ours).any():
        out[~ours] = shapely.simplify(sets[~ours], eps, preserve_topology=True)
    return out


def clip(sets: np.ndarray, area) -> np.ndarray:
    """``A ∩ X0``: exact."""
    OPS["clip"] += len(np.atleast_1d(sets))
    return shapely.intersection(sets, area)


def inner(footprints: np.ndarray, margin: float = DELTA) -> np.ndarray:
    """The footprints shrunk by ``margin``: an inner approximation of the explored region (points on its edge were
    detected, so removing them would be safe too, but round-off in the difference must not remove more)."""
    return shapely.buffer(footprints, -margin, join_style="mitre")


def remove(sets, regions):
    """``A \\ F`` for inner ``F`` (IB21 eqs. 21, 26, 28): outer when A is. Where A and F do not meet (their bounding
    boxes apart, or then the ``intersects`` predicate false) ``A \\ F = A`` exactly and A itself, the same object, is
    returned: no overlay, and equal sets stay one object (fusion and prediction compare sets by identity)."""
    if isinstance(sets, shapely.Geometry):
        return _remove_one(sets, regions)
    sets = np.asarray(sets, dtype=object)
    out = sets.copy()
    meet = _boxes_meet(sets, regions)
    if meet.any():
        regions = np.broadcast_to(regions, sets.shape)
        meet[meet] = shapely.intersects(sets[meet], regions[meet])
        if meet.any():
            OPS["difference"] += int(meet.sum())
            out[meet] = shapely.difference(sets[meet], regions[meet])
    return out


def _remove_one(a, f):
    """:func:`remove` of one set: the same tests and overlay, without the arrays."""
    if a.is_empty or f.is_empty:  # NaN bounds: no box meets them
        return a
    (ax0, ay0, ax1, ay1), (fx0, fy0, fx1, fy1) = shapely.bounds(np.array([a, f], dtype=object)).tolist()
    if not (ax0 <= fx1 and fx0 <= ax1 and ay0 <= fy1 and fy0 <= ay1) or not shapely.intersects(a, f):
        return a
    OPS["difference"] += 1
    return shapely.difference(a, f)


def _boxes_meet(a, b) -> np.ndarray:
    """Whether the bounding boxes of ``a`` and ``b`` (broadcast) overlap (closed); False where either is empty."""
    ba, bb = shapely.bounds(a), shapely.bounds(b)
    return (ba[..., 0] <= bb[..., 2]) & (bb[..., 0] <= ba[..., 2]) & (ba[..., 1] <= bb[..., 3]) \
        & (bb[..., 1] <= ba[..., 3])  # NaN bounds (empty) compare False


def intersect(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    OPS["intersection"] += len(np.atleast_1d(a))
    return shapely.intersection(a, b)


def within(small, *big, loose: dict | None = None):
    """``small ∩ (∪ big)`` for one small set and some big ones: each big set is first cut to the bounding box of
    each part of the small one (exact, and fast), which keeps large sets out of the overlays. The parts are disjoint,
    so their results are too and make a multipolygon without a union. If ``small`` is itself (the same object as)
    one of the big sets, it is the result, exactly, with no operation.

    The cut big sets are :func:`loosen`-ed: the small set is mostly a union of beliefs that the big ones share
    edges with exactly (``X_j ⊆ ∪_ℓ X_{ℓ,j}`` against ``X_{ℓ,j} ∪ …``), the slow case of GEOS's overlay. The result
    is thus an outer approximation of ``small ∩ (∪ big)``, within ``small`` and about ``2·LOOSEN`` wider.

    ``loose`` (a dict kept by the caller, e.g. over one fusion round): the big sets are loosened whole, once, and
    cut afterwards to the part's box grown by ``4·LOOSEN`` (so no edge of the cut lies on the part's own extreme
    edges); ``part ∩ cut(loosen(B))`` is ``part ∩ loosen(B)``, the same outer approximation. A part that the
    loosened union covers (a robust predicate, much cheaper than the overlay) is its own result: exact. The result
    is kept in ``loose`` too, by the objects: another group of the round that meets the same sets with the same
    holders (the same first holder of a chain, :func:`setmembership._held_by_all`) reuses it, as a copy where the
    computation would have made a new object (so which sets are one object, which the estimator and the MPC
    compare, is as without the cache)."""
    if small.is_empty:
        return small
    if any(g is small for g in big):  # small ∩ (small ∪ …) = small, exactly
        return small
    if loose is None:
        return _within(small, big, None)
    origin = loose.get(("copy", id(small)), (small, small))[1]  # the set small is a copy of (or itself)
    key = ("within", id(origin), *(id(g) for g in big))
    hit = loose.get(key)
    if hit is None:  # the entry holds its operands: their ids stay theirs for the round
        out = _within(small, big, loose)
        hit = loose[key] = (origin, big, out, out is small)
        return out
    out = hit[2]
    if hit[3]:  # small itself
        return small
    if out is EMPTY:
        return out
    copy = shapely.force_2d(out)  # a new object of the same value (as the computation would make), known as a copy
    loose[("copy", id(copy))] = (copy, loose.get(("copy", id(out)), (out, out))[1])
    return copy


def _within(small, big: tuple, loose: dict | None):
    """:func:`within` of a non-empty ``small`` that is none of ``big``."""
    big = np.array(list({id(g): g for g in big if not g.is_empty}.values()), dtype=object)
    if loose is not None and len(big):
        big = np.array([within_loosened(g, loose) for g in big], dtype=object)
    pieces = []
    for part in parts(small):
        local = _local_union(big, part.bounds, loose is not None)
        if local.is_empty:
            continue
        if shapely.covers(local, part):  # part ∩ local = part
            pieces.append(part)
            continue
        OPS["intersection"] += 1
        pieces.extend(parts(shapely.intersection(part, local)))
    pieces = [p for p in pieces if not p.is_empty]
    if not pieces:
        return EMPTY
    if len(pieces) == 1:
        return pieces[0]
    if all(p.geom_type == "Polygon" for p in pieces):
        return shapely.MultiPolygon(pieces)
    return union_all(pieces)  # a degenerate contact (line, point) is kept, as the overlay would


def parts(g) -> np.ndarray:
    """``shapely.get_parts(g)`` of one geometry, with a polygon's own (itself) without the call."""
    if g.geom_type == "Polygon":
        out = np.empty(1, dtype=object)
        out[0] = g
        return out
    return shapely.get_parts(g)


def within_loosened(g, loose: dict):
    """``loosen(g)``, computed once per object kept in ``loose`` (the object is held there too: its id stays its)."""
    hit = loose.get(id(g))
    if hit is None:
        hit = loose[id(g)] = (g, loosen(g))
    return hit[1]


def _local_union(big: np.ndarray, box, already_loose: bool):
    """The union of the (loosened) big sets cut to ``box``: cut then loosened, or, if they are loosened already, cut
    to the box grown by ``4·LOOSEN``."""
    if already_loose:
        grow = 4 * LOOSEN
        return union_all(shapely.clip_by_rect(big, box[0] - grow, box[1] - grow, box[2] + grow, box[3] + grow))
    return union_all(loosen(shapely.clip_by_rect(big, *box)))


def loosen(sets, margin: float = LOOSEN):
    """A superset of each set whose edges all lie ``margin`` off its own: the mitred buffer by ``margin`` (an offset
    of every edge outwards; a corner is mitred, or bevelled beyond twice the margin, never cut inside the set).

    For intersecting sets that share much of their boundary *exactly* (UAVs' X̄ after fusions of overlapping
    neighbourhoods): GEOS's overlay on coincident edges falls back to a robust noder, 4-10x slower than on edges
    ``margin`` apart. ``A ∩ loosen(B)`` is an outer approximation of ``A ∩ B``, wider by at most about twice
    ``margin`` (the mitre limit; measured ≤ 2.02 ``margin``): the same kind of allowance as :data:`DELTA` in every
    dilation."""
    OPS["buffer"] += len(np.atleast_1d(sets))
    return shapely.buffer(sets, margin, join_style="mitre", mitre_limit=2.0)


def union_all(sets) -> shapely.Geometry:
    """The union of a sequence of sets (empty for none). A set given several times (the same object) counts once,
    and a single set is returned as it is (the same object, no overlay): exact, since ``A ∪ A = A``."""
    sets = list({id(s): s for s in sets if s is not None and not s.is_empty}.values())
    if len(sets) == 1:
        return sets[0]
    OPS["union"] += max(0, len(sets) - 1)
    return shapely.union_all(sets) if sets else EMPTY


def intersect_all(sets) -> shapely.Geometry:
    """The intersection of a non-empty sequence of sets."""
    sets = list(sets)
    OPS["intersection"] += len(sets) - 1
    return shapely.intersection_all(sets) if len(sets) > 1 else sets[0]


def boxes(z: np.ndarray, bound) -> np.ndarray:
    """The measurement boxes ``B(y) = y − [w]`` (IB21 Sec. 6: ``h(x) = (x1, x2)``, a box noise of half-widths
    ``bound``): the exact set of positions a measurement ``y`` (M, 2) can come from."""
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    wx, wy = bound
    return shapely.box(z[:, 0] - wx, z[:, 1] - wy, z[:, 0] + wx, z[:, 1] + wy)


def area(sets) -> np.ndarray:
    """φ: the area of every set (m²), 0 for an empty one."""
    return shapely.area(np.asarray(sets, dtype=object))


def is_empty(sets) -> np.ndarray:
    return shapely.is_empty(np.asarray(sets, dtype=object))
