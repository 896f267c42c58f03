"""Communication links, dense for small swarms and sparse for large ones.

A *links* object says who hears whom at one step: ``links[i, j]`` true means UAV i receives from UAV j; there
are no self-loops. It is one of

* a dense ``(N, N)`` boolean numpy array, or
* a ``scipy.sparse.csr_array`` of bool with the same meaning, canonical (sorted indices, no duplicates, no
  explicit zeros, no diagonal).

Links may also be *rectangular*, ``(R, N)``: the rows of R receivers, a subset of the swarm's UAVs (one UAV's own
process, :meth:`swarmtrack.network.messages.Inbox.restrict`), over all N senders. Row r is the links of the swarm's
UAV ``receivers[r]`` (:func:`rows_of`), which holds no self-loop; only square links have a diagonal to leave out.

Both hold exactly the same set of links; the constructors here choose the form from the swarm size
(``sparse=None``: sparse from :data:`SPARSE_MIN_UAVS` UAVs up) and every function accepts both, so without
message loss the numbers downstream do not depend on the choice. Message loss (:func:`drop`) draws one uniform
per ordered pair on dense links (as the first release did, so small swarms keep their seeded numbers) and one
per link on CSR links, so a lossy run's draws differ between the forms. A dense array costs N² bytes (100 MB
at N = 10,000) whatever the number of links; the CSR form costs O(N + links).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Union

import numba
import numpy as np

from swarmtrack.network.rows import Rows

if TYPE_CHECKING:  # scipy is imported where sparse links are built: small swarms never pay for it (~0.4 s)
    from scipy import sparse as sp

TOPOLOGIES = ("none", "line", "ring", "full", "proximity", "edges")

SPARSE_MIN_UAVS = 300
"""Swarm size from which the constructors return CSR links (when called with ``sparse=None``).

Measured for :func:`proximity_links` (2-core machine shared with other jobs, numpy 2.4, scipy 1.17; positions
uniform in a square of half-width ``2.2 √N`` with r_comm = 4.8, i.e. ≈ 3.5 links per UAV; fastest / median
of 10-50 calls):

======  ==================  ===============
N       dense, ms           sparse (KD), ms
======  ==================  ===============
100     0.04 / 0.04         0.17 / 0.19
200     0.13 / 0.14         0.25 / 0.50
300     1.4 / 1.5           0.34 / 0.60
400     2.8 / 7.0           0.45 / 0.56
1,000   15 / 20             1.4 / 1.6
10,000  1,500 / 2,600       25 / 43
======  ==================  ===============

The dense cost jumps between 200 and 300 UAVs (where its (N, N) float temporaries pass 0.5 MB each); from
300 UAVs on sparse construction wins, and so do the inbox sum (4×4 payload: 0.15 ms dense
vs 0.08 ms CSR at N = 300) and the compiled flocking kernel. Below, both forms take well under a
millisecond and the dense form keeps the small-swarm code paths (and their numbers, bit for bit) as they
were. ``full`` stays dense at any size (see :func:`static_links`).
"""

Links = Union[np.ndarray, "sp.csr_array"]


def is_sparse(links: Links) -> bool:
    """Whether ``links`` is the CSR form."""
    return not isinstance(links, np.ndarray)  # the CSR form is the only other one


def _wants_sparse(n: int, sparse: bool | None = None) -> bool:
    """The form a constructor returns for ``n`` UAVs: ``sparse`` if given, else ``n ≥ SPARSE_MIN_UAVS``."""
    return n >= SPARSE_MIN_UAVS if sparse is None else bool(sparse)


def n_links(links: Links) -> int:
    """Number of directed links."""
    return int(links.nnz) if is_sparse(links) else int(np.count_nonzero(links))


def to_dense(links: Links) -> np.ndarray:
    """The ``(N, N)`` boolean array of ``links`` (for small swarms, tests and plots)."""
    return links.toarray() if is_sparse(links) else np.asarray(links, dtype=bool)


def neighbour_lists(links: Links) -> tuple[np.ndarray, np.ndarray]:
    """CSR structure ``(indptr, senders)``: UAV i hears ``senders[indptr[i]:indptr[i + 1]]``.

    CSR links are returned as stored (no copy); for dense square links the diagonal, if set, is left out, so both
    forms of the same links give the same lists (rectangular links hold no self-loop, :func:`rows_of`).
    """
    if is_sparse(links):
        return links.indptr, links.indices
    receivers, senders = np.nonzero(links)
    if _square(links):
        keep = receivers != senders
        receivers, senders = receivers[keep], senders[keep]
    return _indptr(receivers, links.shape[0]), senders


def _square(links: Links) -> bool:
    return links.shape[0] == links.shape[1]


def edge_list(links: Links) -> tuple[np.ndarray, np.ndarray]:
    """Directed links as ``(receivers, senders)`` int arrays in row-major order, self-loops left out (a dense
    mask or a hand-made CSR array may carry some). Rectangular links give the rows' indices as receivers."""
    indptr, senders = neighbour_lists(links)
    receivers = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr))
    if is_sparse(links) and _square(links):
        keep = receivers != senders
        receivers, senders = receivers[keep], senders[keep]
    return receivers, senders


def neighbour_sum(links: Links, payload: np.ndarray, receivers: np.ndarray | None = None) -> np.ndarray:
    """Inbox sum ``Σ_j links[i, j] payload_j`` for every receiver i (L24 eq. 7): payload ``(N, ...)`` →
    ``(R, ...)`` for links ``(R, N)``.

    Dense: ``links @ payload``; sparse: the CSR product, O(links · payload size per UAV), row by row. Rectangular
    dense links of the swarm's UAVs ``receivers`` are multiplied in the swarm's shape
    (:meth:`swarmtrack.network.rows.Rows.matmul`), so each row is bit for bit the whole swarm's.
    """
    flat = payload.reshape(payload.shape[0], -1)
    shape = (links.shape[0], *payload.shape[1:])
    if is_sparse(links):
        if flat.dtype == np.float64 and flat.shape[1] <= 4 and links.dtype == bool and links.data.all():
            return _csr_sum(links.indptr, links.indices, np.ascontiguousarray(flat)).reshape(shape)
        return np.asarray(links @ flat).reshape(shape)  # bool CSR @ float upcasts by itself (no float copy)
    weights = links.astype(payload.dtype)
    if receivers is None or _square(links):
        return (weights @ flat).reshape(shape)
    return Rows(receivers, links.shape[1]).matmul(weights, flat).reshape(shape)


def neighbour_sums(links: Links, first: np.ndarray, second: np.ndarray,
                   receivers: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`neighbour_sum` of two payloads, ``(Σ_j first_j, Σ_j second_j)``: the same numbers, over CSR links and
    float64 payloads of up to eight numbers per UAV together (the information filter's ``I`` and ``i``) side by side
    in one :func:`_csr_sum` (each column is summed alone: the same bits; 15 % faster than two calls at 10,000 UAVs)."""
    a, b = first.reshape(first.shape[0], -1), second.reshape(second.shape[0], -1)
    if (is_sparse(links) and a.dtype == np.float64 and b.dtype == np.float64 and a.shape[1] + b.shape[1] <= 8
            and links.dtype == bool and links.data.all()):
        both = _csr_sum(links.indptr, links.indices, np.concatenate([a, b], axis=1))
        return (both[:, :a.shape[1]].reshape(links.shape[0], *first.shape[1:]),
                both[:, a.shape[1]:].reshape(links.shape[0], *second.shape[1:]))
    return neighbour_sum(links, first, receivers), neighbour_sum(links, second, receivers)


@numba.njit(cache=True)
def _csr_sum(indptr, indices, flat):  # pragma: no cover (compiled)
    """``links @ flat`` of bool CSR links with every stored value true and ``flat`` (N, k) float64: each receiver's
    senders' rows added in the links' order to a row of zeros, as scipy's ``csr_matvec``/``csr_matvecs`` add them
    (``y += 1.0 · x``, the product exact), so the sums are scipy's bit for bit (tested), without scipy's float copy
    of the links' values. Four columns at a time, each summed in a register of its own (twice as fast as scipy up to
    four columns; wider payloads go to scipy)."""
    rows, k = len(indptr) - 1, flat.shape[1]
    out = np.empty((rows, k))
    for m0 in range(0, k, 4):
        cols = min(4, k - m0)
        for i in range(rows):
            a0 = a1 = a2 = a3 = 0.0
            for jj in range(indptr[i], indptr[i + 1]):
                j = indices[jj]
                a0 += flat[j, m0]
                if cols > 1:
                    a1 += flat[j, m0 + 1]
                if cols > 2:
                    a2 += flat[j, m0 + 2]
                if cols > 3:
                    a3 += flat[j, m0 + 3]
            out[i, m0] = a0
            if cols > 1:
                out[i, m0 + 1] = a1
            if cols > 2:
                out[i, m0 + 2] = a2
            if cols > 3:
                out[i, m0 + 3] = a3
    return out


def rows_of(links: Links, receivers: np.ndarray) -> Links:
    """The rows of the swarm's UAVs ``receivers`` (sorted, distinct) of square ``links``: rectangular links
    ``(R, N)``, in the same form, without self-loops (module docstring)."""
    receivers = np.asarray(receivers, dtype=np.int64)
    if len(receivers) == links.shape[0]:
        return links
    rows = np.arange(len(receivers))
    if not is_sparse(links):
        out = np.array(links[receivers], dtype=bool)
        out[rows, receivers] = False
        return out
    from scipy import sparse as sp

    indptr, senders = links.indptr, links.indices
    parts = [senders[indptr[i]:indptr[i + 1]] for i in receivers]
    cols = [p[p != i] for p, i in zip(parts, receivers, strict=True)]
    counts = np.array([len(c) for c in cols], dtype=np.int64)
    ptr = np.zeros(len(receivers) + 1, dtype=senders.dtype)
    np.cumsum(counts, out=ptr[1:])
    flat = np.concatenate(cols) if cols else np.empty(0, dtype=senders.dtype)
    out = sp.csr_array((np.ones(flat.size, dtype=bool), flat.astype(senders.dtype), ptr),
                       shape=(len(receivers), links.shape[1]))
    out.has_sorted_indices = True
    return out


def drop(links: Links, probability: float, rng: np.random.Generator | None) -> Links:
    """Independent loss of every directed link with ``probability`` (the message did not arrive).

    Dense links draw ``rng.random((N, N))`` (one uniform per ordered pair, as the channel always did, so
    seeded runs are unchanged); CSR links draw one uniform per stored link, in row-major order. A link is
    kept when its uniform is ``≥ probability``. ``probability ≤ 0`` returns ``links`` and draws nothing.
    """
    if probability <= 0.0:
        return links
    if not is_sparse(links):
        return links & (rng.random(links.shape) >= probability)
    receivers, senders = edge_list(links)
    keep = rng.random(receivers.size) >= probability
    return _sorted_csr(links.shape[0], receivers[keep], senders[keep])


def subset(links: Links, keep: np.ndarray) -> Links:
    """The links of :func:`edge_list` order where ``keep`` (one flag per directed link), in the same form."""
    receivers, senders = edge_list(links)
    if is_sparse(links):
        return _sorted_csr(links.shape[0], receivers[keep], senders[keep])
    out = np.zeros(links.shape, dtype=bool)
    out[receivers[keep], senders[keep]] = True
    return out


def cut(links: Links, off: np.ndarray) -> Links:
    """``links`` without every link from or to a UAV where ``off`` (N,) is set (a UAV cut off from the network)."""
    if not off.any():
        return links
    if not is_sparse(links):
        return links & ~off[:, None] & ~off[None, :]
    receivers, senders = edge_list(links)
    keep = ~off[receivers] & ~off[senders]
    return _sorted_csr(links.shape[0], receivers[keep], senders[keep])


def proximity_links(positions: np.ndarray, r_comm: float, *, sparse: bool | None = None) -> Links:
    """UAVs strictly closer than ``r_comm`` hear each other: ``‖q_i − q_j‖² < r_comm²`` (no self-loops).

    ``positions`` (N, d). Dense: all pairs, O(N²), in one compiled pass (:func:`_proximity_dense`, the test of
    :func:`proximity_blocks`). Sparse, planar positions: a compiled sweep over strips (:func:`_proximity_strips`, O(N +
    candidate pairs)) writes the canonical CSR arrays directly; positions spread over too many strips of width
    r_comm/3 (:data:`STRIPS_PER_UAV` per UAV), non-finite ones or other dimensions: candidate pairs from a KD-tree
    queried a hair beyond r_comm (``cKDTree.query_pairs`` counts distance == r as inside, and rounds its own way).
    Either way a candidate pair is kept by the same squared-distance test as the dense form, so all forms give
    exactly the same links, including pairs at exactly r_comm (out) and coincident UAVs (in).

    Measured on the 10,000-UAV 60 s run of ``benchmarks/bench_sim.py --large`` (its positions at four steps; the
    2-core machine shared with other jobs, fastest of 9 calls, ms):

    ====================  ===========  =================  ==============
    step                  links/UAV    KD-tree, ms        strips, ms
    ====================  ===========  =================  ==============
    2 s (spread)          8            9.0                5.4
    10 s (contracted)     375          300                32
    25 s                  183          123                18
    55 s                  37           23                 6.9
    ====================  ===========  =================  ==============

    A Verlet list (candidates within r_comm plus a skin, kept while the UAVs move less than it) was tried and left:
    that swarm's UAVs move 0.5-2 m per 50 ms step, so its candidates would be drawn again at nearly every step.
    """
    q = np.asarray(positions, dtype=float)
    n = q.shape[0]
    r2 = float(r_comm) * float(r_comm)
    if not _wants_sparse(n, sparse):
        return _proximity_dense(np.ascontiguousarray(q), r2)
    if _strips_fit(q, r_comm):
        return _csr_of(n, *_proximity_strips(np.ascontiguousarray(q), r2, float(r_comm) * _STRIP_MARGIN))
    return _proximity_kdtree(q, r_comm)


def _proximity_kdtree(q: np.ndarray, r_comm: float) -> sp.csr_array:
    """The sparse :func:`proximity_links` of positions the strips do not take (and the strips' reference in
    the tests): candidate pairs from a KD-tree, kept by the squared-distance test."""
    n = q.shape[0]
    r2 = float(r_comm) * float(r_comm)
    from scipy.spatial import cKDTree

    tree = cKDTree(q, balanced_tree=False, compact_nodes=False)  # faster to build, same pairs
    pairs = tree.query_pairs(float(r_comm) * (1.0 + 1e-9), output_type="ndarray")
    a, b = pairs[:, 0], pairs[:, 1]
    near = _squared_distance(q[a], q[b]) < r2
    a, b = a[near].astype(np.int64), b[near].astype(np.int64)
    # distinct pairs i < j: both directions, sorted row-major by one sort of the keys (no duplicates to merge)
    key = np.sort(np.concatenate([a * n + b, b * n + a]))
    rows, cols = np.divmod(key, n)
    return _sorted_csr(n, rows, cols)


#: The strips of :func:`proximity_links` are used while the positions' extent along x holds at most this many strips
#: of width r_comm/3 per UAV (beyond, a scattered swarm with few links, a KD-tree finds them).
STRIPS_PER_UAV = 16
#: The strips of :func:`_proximity_strips` are this much wider than r_comm/3, its windows along y this much taller than
#: the pairs closer than r_comm reach: such a pair is always within three strips and a window of each other, whatever
#: the rounding (of the strips' numbers too, up to :data:`_MAX_STRIPS` strips).
_STRIP_MARGIN = 1.0 + 1e-6
#: Strips per r_comm of :func:`_proximity_strips`.
_STRIPS_PER_R = 3
#: At most this many strips: their numbers are then rounded by far less than :data:`_STRIP_MARGIN`.
_MAX_STRIPS = 1e9


def _strips_fit(q: np.ndarray, r_comm: float) -> bool:
    """Whether :func:`_proximity_strips` takes the positions ``q``: planar, finite, r_comm > 0 and their extent along
    x at most :data:`STRIPS_PER_UAV` strips of width r_comm/3 per UAV."""
    if not (q.ndim == 2 and q.shape[1] == 2 and 0 < len(q) < 2**31 and float(r_comm) > 0.0 and np.isfinite(q).all()):
        return False
    strips = float(np.ptp(q[:, 0])) / (float(r_comm) * _STRIP_MARGIN / _STRIPS_PER_R) + 1.0
    return strips <= min(STRIPS_PER_UAV * len(q) + 1024, _MAX_STRIPS)


def _proximity_strips(q: np.ndarray, r2: float, width: float) -> tuple[np.ndarray, np.ndarray]:
    """CSR ``(indptr, indices)`` (rows sorted; int32 while the links fit, else int64) of the pairs ``i ≠ j`` of planar
    ``q`` (N, 2), finite, with ``(q_i0 − q_j0)² + (q_i1 − q_j1)² < r2`` (summed as :func:`_squared_distance` sums
    it; the squares of opposite differences are equal, so the test is symmetric), from vertical strips of width
    ``width / 3`` (``width`` ≥ √r2 with a margin; the caller bounds their number), each sorted along y
    (:func:`_strips_sorted`): a point's candidates are the points of its strip and the three on either side within
    ``width`` along y (less in the outer strips, which are farther along x), an area of 4.25 r², 1.35 times the
    disc's (2.9 times for square cells of width r). :func:`_strips_fill` tests them and writes the links,
    :func:`_strips_rows` puts the rows in place."""
    strips = _strips_sorted(q, width)
    degree, ranked, first, count = _strips_fill(q, r2, *strips)
    indptr = np.zeros(len(q) + 1, dtype=np.int64)
    np.cumsum(degree, out=indptr[1:])
    index = np.int32 if indptr[-1] < 2**31 - 1 else np.int64
    indptr = indptr.astype(index)
    indices = np.empty(int(indptr[-1]), dtype=index)
    _strips_rows(strips[0], ranked, first, count, indptr, indices)
    return indptr, indices


@numba.njit(cache=True)
def _strips_sorted(q, width):  # pragma: no cover (compiled)
    """The strips of :func:`_proximity_strips`: the points sorted by their strip ``int((x − x0) / (width/3))`` (a
    counting sort), then along y within each strip. Returns ``(idx, xs, ys, window)``: ``idx`` the points in that
    order (a point's *rank* is its place in it), ``xs``, ``ys`` their coordinates, ``window[b, o]`` the ranks of strip
    ``s + o − 3`` (``s`` rank b's strip) within ``reach[o]`` of rank b along y (``width``, less where the strip is
    more than one strip away along x: a pair whole strips apart along x is that much closer along y), from sweeps
    that only move up as b does. Every point within √r2 of b lies in b's windows, and b in its own."""
    n = q.shape[0]
    step = width / _STRIPS_PER_R
    x0, x1 = q[0, 0], q[0, 0]
    for i in range(n):
        x0, x1 = min(x0, q[i, 0]), max(x1, q[i, 0])
    ns = int((x1 - x0) / step) + 1
    strip = np.empty(n, dtype=np.int64)
    start = np.zeros(ns + 1, dtype=np.int64)
    for i in range(n):
        strip[i] = int((q[i, 0] - x0) / step)
        start[strip[i] + 1] += 1
    for s in range(ns):
        start[s + 1] += start[s]
    fill = start[:-1].copy()
    idx = np.empty(n, dtype=np.int64)
    for i in range(n):
        idx[fill[strip[i]]] = i
        fill[strip[i]] += 1
    ys = np.empty(n)
    for b in range(n):
        ys[b] = q[idx[b], 1]
    for s in range(ns):  # along y within each strip
        lo, hi = start[s], start[s + 1]
        if hi - lo > 1:
            order = np.argsort(ys[lo:hi], kind="mergesort")
            part = idx[lo:hi].copy()
            for k in range(hi - lo):
                idx[lo + k] = part[order[k]]
    xs = np.empty(n)
    for b in range(n):
        xs[b] = q[idx[b], 0]
        ys[b] = q[idx[b], 1]
    windows = 2 * _STRIPS_PER_R + 1
    reach = np.empty(windows)  # each window's half-height: a strip o apart is at least (|o| − 1)·step away along x
    for o in range(windows):
        gap = max(abs(o - _STRIPS_PER_R) - 1, 0) * step * (2.0 - _STRIP_MARGIN)  # less the margin: rounding
        reach[o] = math.sqrt(max(width * width - gap * gap, 0.0)) * _STRIP_MARGIN
    window = np.zeros((n, windows, 2), dtype=np.int64)
    for s in range(ns):
        for o in range(windows):
            t = s + o - _STRIPS_PER_R
            if t < 0 or t >= ns:
                continue  # no such strip: an empty window
            lo = hi = start[t]
            for b in range(start[s], start[s + 1]):
                while lo < start[t + 1] and ys[lo] < ys[b] - reach[o]:
                    lo += 1
                hi = max(hi, lo)
                while hi < start[t + 1] and ys[hi] <= ys[b] + reach[o]:
                    hi += 1
                window[b, o, 0], window[b, o, 1] = lo, hi
    return idx, xs, ys, window


@numba.njit(cache=True)
def _strips_fill(q, r2, idx, xs, ys, window):  # pragma: no cover (compiled)
    """The links of :func:`_proximity_strips`, by rank: the senders ``j`` in increasing order, each written into the row
    of every point of its windows it links to, so each row comes out sorted. Rank b's row starts at ``first[b]``
    with room for as many links as b has candidates (the points of its windows, b among them) and holds ``count[b]``
    links. Every candidate is written at its row's next slot and only a link moves the row on, without a branch (a
    third of the candidates are links, in no order a predictor could learn): b's links are among its candidates
    other than itself, so even the write of a candidate that is no link stays in b's row. The rows a sender writes
    to lie in seven runs of ranks, near each other in memory (the ranks follow the points along x, then y).
    Returns ``(degree, ranked, first, count)``, ``degree`` by point."""
    n = q.shape[0]
    first = np.empty(n + 1, dtype=np.int64)
    first[0] = 0
    for b in range(n):
        room = 0
        for o in range(window.shape[1]):
            room += window[b, o, 1] - window[b, o, 0]
        first[b + 1] = first[b] + room
    ranked = np.empty(first[n], dtype=np.int32)  # point numbers (the caller has fewer than 2**31 points)
    at = first[:-1].copy()
    rank = np.empty(n, dtype=np.int64)
    for b in range(n):
        rank[idx[b]] = b
    for j in range(n):
        jx, jy, r = q[j, 0], q[j, 1], rank[j]
        for o in range(window.shape[1]):
            for b in range(window[r, o, 0], window[r, o, 1]):
                d = jx - xs[b]
                sq = d * d
                d = jy - ys[b]
                sq = sq + d * d
                k = at[b]
                ranked[k] = j
                at[b] = k + ((sq < r2) & (b != r))
    count = at - first[:-1]
    degree = np.empty(n, dtype=np.int64)
    for b in range(n):
        degree[idx[b]] = count[b]
    return degree, ranked, first, count


@numba.njit(cache=True)
def _strips_rows(idx, ranked, first, count, indptr, indices):  # pragma: no cover (compiled)
    """Copy each rank's row of :func:`_strips_fill` to its point's place in the CSR arrays."""
    for b in range(len(idx)):
        src, dst = first[b], indptr[idx[b]]
        for k in range(count[b]):
            indices[dst + k] = ranked[src + k]


def _csr_of(n: int, indptr: np.ndarray, indices: np.ndarray) -> sp.csr_array:
    """Bool CSR of canonical arrays (rows sorted, distinct, off-diagonal)."""
    from scipy import sparse as sp

    A = sp.csr_array((np.ones(indices.size, dtype=bool), indices, indptr), shape=(n, n))
    A.has_sorted_indices = True
    return A


def proximity_blocks(positions: np.ndarray, r_comm: float) -> np.ndarray:
    """The dense proximity links of B separate groups at once: ``positions`` (B, N, d) → (B, N, N), each group's
    pairs tested as :func:`proximity_links` tests them (the worlds of a batch, :mod:`swarmtrack.sim.batch`)."""
    q = np.asarray(positions, dtype=float)
    r2 = float(r_comm) * float(r_comm)
    A = _squared_distance(q[:, :, None, :], q[:, None, :, :]) < r2
    diag = np.arange(q.shape[1])
    A[:, diag, diag] = False
    return A


@numba.njit(cache=True)
def _proximity_dense(q, r2):  # pragma: no cover (compiled)
    """(N, N) ``‖q_i − q_j‖² < r2`` for ``i ≠ j``, the squared distance summed as :func:`_squared_distance` sums it
    (:func:`proximity_blocks` is the numpy reference; tested equal). ``(q_j − q_i)² = (q_i − q_j)²`` exactly, so each
    pair is computed once for both directions."""
    n, dim = q.shape
    A = np.zeros((n, n), dtype=np.bool_)
    for i in range(n):
        for j in range(i + 1, n):
            d = q[i, 0] - q[j, 0]
            sq = d * d
            for k in range(1, dim):
                d = q[i, k] - q[j, k]
                sq = sq + d * d
            A[i, j] = A[j, i] = sq < r2
    return A


def static_links(kind: str, n: int, edges: Sequence[Sequence[int]] = (), *, sparse: bool | None = None) -> Links:
    """Links of a fixed topology: ``none``, ``line`` (L24 Fig. 1: 1-2-3), ``ring``, ``full`` or ``edges``
    (0-based undirected pairs). Symmetric, no self-loops.

    Sparse from :data:`SPARSE_MIN_UAVS` UAVs on (``sparse=None``), except ``full``, which is always dense: it
    has N(N − 1) links, and CSR would store a 4-byte index per link on top of the row pointers where the dense
    array needs one byte per pair — several times the memory and slower to multiply, for no gain.
    """
    if kind == "proximity":
        raise ValueError("proximity links depend on positions: use proximity_links(positions, r_comm)")
    if kind not in TOPOLOGIES:
        raise ValueError(f"unknown topology {kind!r}; choose one of {', '.join(TOPOLOGIES)}")
    if kind == "full":
        A = np.ones((n, n), dtype=bool)
        np.fill_diagonal(A, False)
        return A
    if kind == "none":
        a = b = np.empty(0, dtype=np.int64)
    elif kind == "line":
        a = np.arange(n - 1)
        b = a + 1
    elif kind == "ring":
        a = np.arange(n)
        b = (a + 1) % n
    else:  # edges
        for e in edges:
            i, j = int(e[0]), int(e[1])
            if not (0 <= i < n and 0 <= j < n) or i == j:
                raise ValueError(f"edge {list(e)} names a missing UAV or a self-loop (UAVs are 0..{n - 1})")
        pairs = np.array([(int(e[0]), int(e[1])) for e in edges], dtype=np.int64).reshape(-1, 2)
        a, b = pairs[:, 0], pairs[:, 1]
    receivers, senders = np.concatenate([a, b]), np.concatenate([b, a])
    if _wants_sparse(n, sparse):
        return _csr(n, receivers, senders)
    A = np.zeros((n, n), dtype=bool)
    A[receivers, senders] = True
    np.fill_diagonal(A, False)
    return A


def _squared_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``Σ_k (a_k − b_k)²`` summed coordinate by coordinate in a fixed order (same rounding in both forms)."""
    d = a[..., 0] - b[..., 0]
    sq = d * d
    for k in range(1, a.shape[-1]):
        d = a[..., k] - b[..., k]
        sq = sq + d * d
    return sq


def _indptr(receivers: np.ndarray, n: int) -> np.ndarray:
    """CSR row pointers of row-major sorted ``receivers``."""
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(receivers, minlength=n), out=indptr[1:])
    return indptr


def _csr(n: int, receivers: np.ndarray, senders: np.ndarray) -> sp.csr_array:
    """Canonical bool CSR of the directed links ``receivers[k] ← senders[k]`` in any order (duplicates and
    self-loops dropped)."""
    receivers = np.asarray(receivers, dtype=np.int64)
    senders = np.asarray(senders, dtype=np.int64)
    keep = receivers != senders
    key = np.unique(receivers[keep] * n + senders[keep])  # sorted row-major, duplicates merged
    rows, cols = np.divmod(key, max(n, 1))
    return _sorted_csr(n, rows, cols)


def _sorted_csr(n: int, receivers: np.ndarray, senders: np.ndarray) -> sp.csr_array:
    """Bool CSR of distinct off-diagonal links already in row-major order."""
    index = np.int32 if n < 2**31 - 1 else np.int64
    from scipy import sparse as sp

    A = sp.csr_array((np.ones(senders.size, dtype=bool), senders.astype(index), _indptr(receivers, n).astype(index)),
                     shape=(n, n))
    A.has_sorted_indices = True
    return A
