"""What one plan of the raster SM-MPC removes, as terms (IB21 eqs. 46, 48-49; :mod:`swarmtrack.control.sm_mpc_raster`):
the UAV's own footprint at each step for the node of each candidate, and each neighbour footprint eq. 48 keeps at
step κ, *steady* (kept for every candidate) or *varying* (for some only), with their edge lines (the depth's
arithmetic of :func:`raster.depth`), their lags and the window R they span.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from swarmtrack.control import sm_mpc_problem as smp
from swarmtrack.control.sm_mpc_problem import SMMPCSettings
from swarmtrack.estimation import raster as rs


@dataclass
class Scene:
    """One plan's footprints as terms: ``lines`` (F, 4, 4) each footprint's edge lines ``(px, py, nx, ny)`` (a point
    and the inward unit normal, :func:`raster.depth`'s), ``lag`` (F,) the rounds after its step (its term is
    lowered by r that many times), ``terms`` (C, T) the footprints of each candidate (own and varying neighbours',
    −1 padded), ``steady`` (S,) those removed for every candidate, ``window`` R in cells ``(i0, j0, i1, j1)``,
    ``rows`` the rows ``[t0, t1)`` of the per-row intervals (R's and the steady footprints')."""

    lines: np.ndarray
    lag: np.ndarray
    terms: np.ndarray
    steady: np.ndarray
    window: tuple[int, int, int, int]
    rows: tuple[int, int]


def edge_lines(corners: np.ndarray) -> np.ndarray:
    """(F, K, 4) ``(px, py, nx, ny)`` of convex polygons ``corners`` (F, K, 2), inward normals, computed with
    :func:`raster.depth`'s arithmetic (so the depths agree bit for bit)."""
    return _edge_lines(np.ascontiguousarray(corners, dtype=float))


@numba.njit(cache=True)
def _edge_lines(c):
    f, k = c.shape[0], c.shape[1]
    out = np.empty((f, k, 4))
    for q in range(f):
        area = 0.0
        for e in range(k):
            n = (e + 1) % k
            area += c[q, e, 0] * c[q, n, 1] - c[q, n, 0] * c[q, e, 1]
        turn = np.sign(area)
        for e in range(k):
            n = (e + 1) % k
            ex, ey = c[q, n, 0] - c[q, e, 0], c[q, n, 1] - c[q, e, 1]
            norm = math.hypot(ex, ey)
            out[q, e, 0], out[q, e, 1] = c[q, e, 0], c[q, e, 1]
            out[q, e, 2], out[q, e, 3] = turn * -ey / norm, turn * ex / norm
    return out


def scene(grid: rs.Grid, rem: smp.Removals, s: SMMPCSettings) -> Scene:
    """The terms of one plan (eqs. 46, 48-49): the UAV's own footprint at each step for the node of each
    candidate, and each neighbour footprint eq. 48 keeps at step κ, steady or varying (module docstring)."""
    own = np.concatenate(rem.corners)
    kept = np.concatenate(rem.kept) if rem.nb_corners.shape[0] else np.zeros((len(own), 0), dtype=bool)
    lines, lag, terms, steady, box = _assemble(own, np.array([len(c) for c in rem.corners], dtype=np.int64),
                                                kept, np.ascontiguousarray(rem.nb_corners, dtype=float),
                                                len(s.inputs))
    i0, i1 = grid.span(box[1], box[3], 0)
    j0, j1 = grid.span(box[0], box[2], 1)
    t0, t1 = i0, i1
    if len(steady):
        a, b = grid.span(box[4], box[5], 0)
        t0, t1 = (a, b) if t0 >= t1 else (min(t0, a), max(t1, b))
    return Scene(lines, lag, terms, steady, (i0, j0, i1, j1), (t0, t1))


@numba.njit(cache=True)
def _assemble(own, sizes, kept, nb, branch):
    """:func:`scene`'s tables from the own corners of every level ``own`` (Σ n_κ, 4, 2) (``sizes`` n_κ), eq. 48's
    ``kept`` (Σ n_κ, L) and the neighbours' corners ``nb`` (L, h, 4, 2); ``box``: the varying footprints' bounding
    box and the steady ones' y-extent."""
    h, n_nb = len(sizes), kept.shape[1]
    n = sizes[h - 1]
    offs = np.zeros(h + 1, dtype=np.int64)
    for k in range(h):
        offs[k + 1] = offs[k] + sizes[k]
    kind = np.zeros((h, n_nb), dtype=np.int64)  # 0 ignored, 1 steady, 2 varying
    n_st = n_var = 0
    for k in range(h):
        for ell in range(n_nb):
            some, every = False, True
            for q in range(offs[k], offs[k + 1]):
                some = some or kept[q, ell]
                every = every and kept[q, ell]
            if every and sizes[k]:
                kind[k, ell] = 1
                n_st += 1
            elif some:
                kind[k, ell] = 2
                n_var += 1
    total = offs[h] + n_st + n_var
    corners = np.empty((total, 4, 2))
    corners[:offs[h]] = own
    lag = np.empty(total, dtype=np.int64)
    terms = np.full((n, h + n_var), -1, dtype=np.int64)
    steady = np.empty(n_st, dtype=np.int64)
    box = np.array([np.inf, np.inf, -np.inf, -np.inf, np.inf, -np.inf])
    for k in range(h):
        stride = branch ** (h - 1 - k)
        lag[offs[k]:offs[k + 1]] = h - 1 - k
        for cand in range(n):
            terms[cand, k] = offs[k] + cand // stride
    fid, col, st = offs[h], h, 0
    for k in range(h):
        stride = branch ** (h - 1 - k)
        for ell in range(n_nb):
            if kind[k, ell] == 0:
                continue
            corners[fid] = nb[ell, k]
            lag[fid] = h - 1 - k
            if kind[k, ell] == 1:
                steady[st] = fid
                st += 1
            else:
                for cand in range(n):
                    if kept[offs[k] + cand // stride, ell]:
                        terms[cand, col] = fid
                col += 1
            fid += 1
    for q in range(total):
        varying = q < offs[h] or not _is_steady(q, steady)
        for e in range(4):
            x, y = corners[q, e, 0], corners[q, e, 1]
            if varying:
                box[0], box[1], box[2], box[3] = min(box[0], x), min(box[1], y), max(box[2], x), max(box[3], y)
            else:
                box[4], box[5] = min(box[4], y), max(box[5], y)
    return _edge_lines(corners), lag, terms, steady, box


@numba.njit(cache=True)
def _is_steady(q, steady):
    for s in steady:
        if s == q:
            return True
    return False
