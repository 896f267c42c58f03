"""Compiled fast path of the flocking protocols (numba).

:func:`swarmtrack.control.flocking.flocking_control` is the readable, vectorised *reference*;
:func:`flocking_kernel` (dense ``(N, N)`` neighbour mask) and :func:`flocking_kernel_csr` (CSR links, for
large swarms, see :mod:`swarmtrack.network.links`) compute the same commands and integrals agent by agent,
for all three variants (L24 eq. 1-3, L23 eq. 2-10), the ``active`` mask, the neighbour links and the norm
clip. The arithmetic follows the reference term by term, so the numbers agree to rounding (~1e-15 relative;
only the order of the neighbour sums differs). Per agent i::

    s_ij  = ‖q_i − q_j‖σ,   a_ij = bump(s_ij/‖r_comm‖σ, h) · neighbours[i, j],   a_ii = 0     (L24 Sec. 2)
    c_ij  = a_ij φ(s_ij − ‖d‖σ)/(1 + ε s_ij)                                                 (L24 eq. 1)
    e_int = −Σ_j c_ij (q_i − q_j),   u_d = K_d e_int,   u_v = −K_v Σ_j a_ij (p_i − p_j)      (L23 eq. 7)
    u     = u_d + u_v − k_dt (q_i − q_t) − K_vt (p_i − p_t) [+ K_int E_i] [− K_vint V_i]    (L24 eq. 2-3)

with ``k_dt = K_dt`` (standard, integral) or ``atan(‖q_i − q_t‖/D_dt)`` (tailored), an inactive agent's
``u = −K_vt p_i``, and the integrals ``E += dt·e_int`` (integral, tailored), ``V += dt·(p_i − p_t)``
(tailored) of the active agents. Pairs farther apart than ``r_comm`` have ``a_ij = 0`` and are skipped after
one squared distance.

The dense kernel loops over the O(N²) unordered pairs (each evaluated once, added to both agents that hear
the other); the CSR kernel loops over the stored links only, O(N + links) time and memory. For R receivers, a
subset of the swarm (one UAV's own process), :func:`flocking_kernel_rows` takes their rows (R, N) of a dense mask
and sums, per receiver, its lower senders then its higher ones, as the pair loop does, so that each row is bit for
bit the whole swarm's; the CSR kernel takes the receivers' rows as they are. Converting a dense
mask to CSR (``np.nonzero``) to use one kernel for both was measured 2-5x slower than the dense kernel on
dense input at every size (N = 3: 3 µs vs 10 µs; N = 1,000: 0.8 ms vs 3.6 ms), so both are kept; they share
the pair arithmetic (:func:`_pair_weight`) and the per-agent commands (:func:`_commands`).

The kernels are ``@numba.njit(cache=True, fastmath=False)``, serial, and take C-contiguous arrays;
:func:`flocking_control_compiled` is the drop-in (checked) twin of the reference function and picks the
kernel from the form of the links.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numba
import numpy as np

from swarmtrack.control.flocking import VARIANTS, FlockingGains, FlockingState, _sigma_from_sq
from swarmtrack.network.links import Links, is_sparse, neighbour_lists
from swarmtrack.network.rows import everyone

#: ``variant`` argument of :func:`flocking_kernel`: index in :data:`~swarmtrack.control.flocking.VARIANTS`.
STANDARD, INTEGRAL, TAILORED = (VARIANTS.index(v) for v in ("standard", "integral", "tailored"))

# A pair whose squared distance exceeds r_comm² by this factor has ‖q_ij‖σ/‖r_comm‖σ > 1, hence a_ij = 0.
_CUTOFF_MARGIN = 1.0 + 1e-9


def gain_vector(gains: FlockingGains) -> np.ndarray:
    """The gains as the float64 vector :func:`flocking_kernel` takes::

        [K_d, K_v, K_dt, K_vt, K_int, K_vint, D_dt, eps, h, ‖d‖σ, ‖r_comm‖σ, r_comm², accel_limit]

    (the σ-norms as the reference computes them; ``accel_limit`` ≤ 0 or infinite disables the clip).
    """
    g = gains
    return np.array([g.K_d, g.K_v, g.K_dt, g.K_vt, g.K_int, g.K_vint, g.D_dt, g.eps, g.h,
                     _sigma_from_sq(g.d**2, g.eps), _sigma_from_sq(g.r_comm**2, g.eps), g.r_comm**2,
                     g.accel_limit], dtype=np.float64)


@numba.njit(cache=True, fastmath=False)
def _pair_constants(gains):
    """What the pair terms read of :func:`gain_vector`: ``eps, h, σ(d), σ(r_comm)`` and the squared distance beyond
    which a pair is skipped (r_comm² with :data:`_CUTOFF_MARGIN`)."""
    return gains[7], gains[8], gains[9], gains[10], gains[11] * _CUTOFF_MARGIN


@numba.njit(cache=True, fastmath=False)
def _pair_weight(sq, eps, h, sig_d, sig_r):
    """``(a_ij, c_ij)`` of a pair at squared distance ``sq`` (L24 Sec. 2 bump, L24 eq. 1)."""
    sig = sq / (math.sqrt(1.0 + eps * sq) + 1.0)
    z = sig / sig_r
    if z >= 0.0 and z < h:  # bump a_ij (L24 Sec. 2)
        w = 1.0
    elif z >= h and z <= 1.0:
        w = 0.5 * (1.0 + math.cos(math.pi * (z - h) / (1.0 - h)))
    else:
        return 0.0, 0.0
    s = sig - sig_d
    return w, w * (s / math.sqrt(1.0 + s * s)) / (1.0 + eps * sig)


@numba.njit(cache=True, fastmath=False)
def flocking_kernel(qp, qp_t, neighbours, e_int_integral, v_int_integral, active, gains, variant, dt):
    """Flocking commands ``u`` (N, 2) and the next integrals ``(E, V)`` (N, 2) each; inputs unchanged.

    ``qp`` (N, ≥4): each agent's ``[x, y, vx, vy]``; ``qp_t`` (N, ≥4): the target's, as each agent knows it;
    ``neighbours`` (N, N) bool (diagonal ignored); ``e_int_integral``, ``v_int_integral`` (N, 2): the
    integrals at this step; ``active`` (N,) bool; ``gains`` from :func:`gain_vector`; ``variant`` one of
    :data:`STANDARD`, :data:`INTEGRAL`, :data:`TAILORED`; ``dt`` the forward-Euler step of the integrals.
    """
    eps, h, sig_d, sig_r, cutoff = _pair_constants(gains)
    n = qp.shape[0]
    # Neighbour sums Σ_j a_ij, Σ_j c_ij, Σ_j c_ij q_j, Σ_j a_ij p_j (L24 eq. 1, velocity matching). a_ij and
    # c_ij depend on the distance only, so each unordered pair is evaluated once and added to both agents
    # that hear the other.
    sums = np.zeros((n, 6))
    for i in range(n):
        qx = qp[i, 0]
        qy = qp[i, 1]
        px = qp[i, 2]
        py = qp[i, 3]
        sw = 0.0
        sc = 0.0
        cqx = 0.0
        cqy = 0.0
        wpx = 0.0
        wpy = 0.0
        for j in range(i + 1, n):
            hear_ij = neighbours[i, j]
            hear_ji = neighbours[j, i]
            if not (hear_ij or hear_ji):
                continue
            dx = qx - qp[j, 0]
            dy = qy - qp[j, 1]
            sq = dx * dx + dy * dy
            if sq > cutoff:  # beyond r_comm: a_ij = 0
                continue
            w, c = _pair_weight(sq, eps, h, sig_d, sig_r)
            if hear_ij:
                sw += w
                sc += c
                cqx += c * qp[j, 0]
                cqy += c * qp[j, 1]
                wpx += w * qp[j, 2]
                wpy += w * qp[j, 3]
            if hear_ji:
                sums[j, 0] += w
                sums[j, 1] += c
                sums[j, 2] += c * qx
                sums[j, 3] += c * qy
                sums[j, 4] += w * px
                sums[j, 5] += w * py
        sums[i, 0] += sw
        sums[i, 1] += sc
        sums[i, 2] += cqx
        sums[i, 3] += cqy
        sums[i, 4] += wpx
        sums[i, 5] += wpy
    return _commands(qp, qp_t, sums, e_int_integral, v_int_integral, active, gains, variant, dt)


@numba.njit(cache=True, fastmath=False)
def flocking_kernel_rows(qp, receivers, qp_t, neighbours, e_int_integral, v_int_integral, active, gains, variant, dt):
    """:func:`flocking_kernel` for the swarm's agents ``receivers`` (R,), sorted: ``neighbours`` (R, N) their rows
    of the mask, ``qp`` (N, ≥4) every sender's state, ``qp_t``, the integrals and ``active`` (R, ...) theirs.

    Per receiver i, the pair terms of the senders below i are summed first, then those above, each in sender
    order, and the two sums added: the order in which :func:`flocking_kernel` adds them, so each row is bit for
    bit the whole swarm's. O(R N) time."""
    eps, h, sig_d, sig_r, cutoff = _pair_constants(gains)
    n = qp.shape[0]
    rows = receivers.shape[0]
    sums = np.zeros((rows, 6))
    part = np.zeros(6)
    for r in range(rows):
        i = receivers[r]
        for half in range(2):  # senders j < i (added to i by the pair loop's earlier rows), then j > i
            part[:] = 0.0
            lo, hi = (0, i) if half == 0 else (i + 1, n)
            for j in range(lo, hi):
                if not neighbours[r, j]:
                    continue
                # the pair loop's difference: lower index minus higher
                dx = qp[j, 0] - qp[i, 0] if half == 0 else qp[i, 0] - qp[j, 0]
                dy = qp[j, 1] - qp[i, 1] if half == 0 else qp[i, 1] - qp[j, 1]
                sq = dx * dx + dy * dy
                if sq > cutoff:  # beyond r_comm: a_ij = 0
                    continue
                w, c = _pair_weight(sq, eps, h, sig_d, sig_r)
                part[0] += w
                part[1] += c
                part[2] += c * qp[j, 0]
                part[3] += c * qp[j, 1]
                part[4] += w * qp[j, 2]
                part[5] += w * qp[j, 3]
            for k in range(6):
                sums[r, k] += part[k]
    return _commands(qp[receivers], qp_t, sums, e_int_integral, v_int_integral, active, gains, variant, dt)


@numba.njit(cache=True, fastmath=False)
def flocking_kernel_csr(qp, own, receivers, qp_t, indptr, indices, e_int_integral, v_int_integral, active, gains,
                        variant, dt):
    """:func:`flocking_kernel` over CSR links: receiver r, the swarm's agent ``receivers[r]``, hears
    ``indices[indptr[r]:indptr[r + 1]]`` (a self-link is ignored); ``qp`` (N, ≥4) every sender's state, ``own``
    (R, ≥4) the receivers' (``qp[receivers]``), ``qp_t``, the integrals and ``active`` theirs. Same arguments
    otherwise; O(N + links) time and memory.

    The pair terms are those of :func:`_pair_weight`, computed for a block of receivers' rows at a time in
    vectorised stages (:func:`_row_pair_weights`), and each receiver's are summed in the order of its links
    (:func:`_row_sums`), so the numbers are :func:`flocking_kernel_csr_reference`'s bit for bit (tested), in about 0.7
    of its time on the 10,000-UAV run's crowded steps (the divisions and square roots vectorised; the bump's cosine,
    a libm call, stays one call per link on its slope). Computing each pair's terms once for symmetric links and
    handing them to the other row was measured slower, by the UAVs' numbers (the hand-over's writes fall all over
    the links' arrays) and in the order of the strips (:func:`swarmtrack.network.links._proximity_strips`: the
    terms kept per link cost more memory traffic than the arithmetic they save)."""
    sums = _row_sums(qp, own, receivers, indptr, indices, gains)
    return _commands(own, qp_t, sums, e_int_integral, v_int_integral, active, gains, variant, dt)


#: :func:`_row_sums` computes the pair terms of this many links at a time (whole receivers' rows: at least one row).
_PAIR_BLOCK = 2048


@numba.njit(cache=True, fastmath=False)
def _row_sums(qp, own, receivers, indptr, indices, gains):
    """The neighbour sums ``[Σ a_ij, Σ c_ij, Σ c_ij q_j, Σ a_ij p_j]`` (R, 6) of :func:`flocking_kernel_csr`: the
    pair terms of a block of receivers' rows at a time (about :data:`_PAIR_BLOCK` links, so that a sparse swarm's
    short rows do not each pay the stages' start), then each row's summed in the order of its links."""
    eps, h, sig_d, sig_r, cutoff = _pair_constants(gains)
    n = receivers.shape[0]
    sums = np.empty((n, 6))
    size = _PAIR_BLOCK
    for i in range(n):
        size = max(size, indptr[i + 1] - indptr[i])
    sq, w, c, sig, z = np.empty(size), np.empty(size), np.empty(size), np.empty(size), np.empty(size)
    slope = np.empty(size, dtype=np.int64)
    first = 0
    while first < n:
        last = first + 1  # the block's rows first .. last - 1: as many as fit, at least one
        while last < n and indptr[last + 1] - indptr[first] <= size:
            last += 1
        base = indptr[first]
        for i in range(first, last):
            qx = own[i, 0]
            qy = own[i, 1]
            for k in range(indptr[i], indptr[i + 1]):
                j = indices[k]
                dx = qx - qp[j, 0]
                dy = qy - qp[j, 1]
                sq[k - base] = dx * dx + dy * dy
        _row_pair_weights(sq, w, c, sig, z, slope, indptr[last] - base, eps, h, sig_d, sig_r)
        for i in range(first, last):
            sw = 0.0
            sc = 0.0
            cqx = 0.0
            cqy = 0.0
            wpx = 0.0
            wpy = 0.0
            me = receivers[i]
            for k in range(indptr[i], indptr[i + 1]):
                j = indices[k]
                m = k - base
                if j == me or sq[m] > cutoff:  # a self-link; beyond r_comm: a_ij = 0
                    continue
                wm = w[m]
                cm = c[m]
                sw += wm
                sc += cm
                cqx += cm * qp[j, 0]
                cqy += cm * qp[j, 1]
                wpx += wm * qp[j, 2]
                wpy += wm * qp[j, 3]
            sums[i, 0] = sw
            sums[i, 1] = sc
            sums[i, 2] = cqx
            sums[i, 3] = cqy
            sums[i, 4] = wpx
            sums[i, 5] = wpy
        first = last
    return sums


@numba.njit(cache=True, fastmath=False, error_model="numpy")
def _row_pair_weights(sq, w, c, sig, z, slope, count, eps, h, sig_d, sig_r):
    """:func:`_pair_weight` of the first ``count`` squared distances ``sq`` into ``w`` and ``c`` (``sig``, ``z`` and
    ``slope``: scratch of the same length), in stages the compiler vectorises: the σ-norm, ``z``, the plateau's
    ``a_ij = 1`` and φ; then the bump's cosine for the pairs on its slope (a scalar call each, as :func:`_pair_weight`
    makes it); then ``c_ij``, 0 off the bump (where :func:`_pair_weight` returns ``(0, 0)``, a NaN distance included).
    Each number is computed by the operations :func:`_pair_weight` uses, in its order, so each equals its. (numpy's
    error model: a division by zero would not raise, and none can: the gains' checks keep every divisor positive;
    Python's would test every divisor, which keeps the loops from being vectorised.)"""
    for m in range(count):
        sg = sq[m] / (math.sqrt(1.0 + eps * sq[m]) + 1.0)
        zm = sg / sig_r
        sig[m] = sg
        z[m] = zm
        w[m] = 1.0 if (zm >= 0.0) & (zm < h) else 0.0
        s = sg - sig_d
        c[m] = s / math.sqrt(1.0 + s * s)  # φ(‖q_ij‖σ − ‖d‖σ)
    on_slope = 0
    for m in range(count):
        slope[on_slope] = m
        on_slope += (z[m] >= h) & (z[m] <= 1.0)
    for k in range(on_slope):
        m = slope[k]
        w[m] = 0.5 * (1.0 + math.cos(math.pi * (z[m] - h) / (1.0 - h)))
    for m in range(count):
        cm = w[m] * c[m] / (1.0 + eps * sig[m])
        c[m] = cm if (z[m] >= 0.0) & (z[m] <= 1.0) else 0.0


@numba.njit(cache=True, fastmath=False)
def flocking_kernel_csr_reference(qp, own, receivers, qp_t, indptr, indices, e_int_integral, v_int_integral, active,
                                  gains, variant, dt):
    """:func:`flocking_kernel_csr` link by link through :func:`_pair_weight` (its reference, for the tests)."""
    eps, h, sig_d, sig_r, cutoff = _pair_constants(gains)
    n = receivers.shape[0]
    sums = np.zeros((n, 6))
    for i in range(n):
        qx = own[i, 0]
        qy = own[i, 1]
        sw = 0.0
        sc = 0.0
        cqx = 0.0
        cqy = 0.0
        wpx = 0.0
        wpy = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if j == receivers[i]:
                continue
            dx = qx - qp[j, 0]
            dy = qy - qp[j, 1]
            sq = dx * dx + dy * dy
            if sq > cutoff:  # beyond r_comm: a_ij = 0
                continue
            w, c = _pair_weight(sq, eps, h, sig_d, sig_r)
            sw += w
            sc += c
            cqx += c * qp[j, 0]
            cqy += c * qp[j, 1]
            wpx += w * qp[j, 2]
            wpy += w * qp[j, 3]
        sums[i, 0] = sw
        sums[i, 1] = sc
        sums[i, 2] = cqx
        sums[i, 3] = cqy
        sums[i, 4] = wpx
        sums[i, 5] = wpy
    return _commands(own, qp_t, sums, e_int_integral, v_int_integral, active, gains, variant, dt)


@numba.njit(cache=True, fastmath=False)
def _commands(qp, qp_t, sums, e_int_integral, v_int_integral, active, gains, variant, dt):
    """Commands and next integrals from the neighbour sums ``[Σ a_ij, Σ c_ij, Σ c_ij q_j, Σ a_ij p_j]``
    (L24 eq. 1-3, L23 eq. 7-10); ``qp`` the receivers' own states, row by row with the sums."""
    K_d = gains[0]
    K_v = gains[1]
    K_dt = gains[2]
    K_vt = gains[3]
    K_int = gains[4]
    K_vint = gains[5]
    D_dt = gains[6]
    limit = gains[12]
    clip = math.isfinite(limit) and limit > 0.0
    n = qp.shape[0]
    u = np.empty((n, 2))
    new_e = e_int_integral.copy()
    new_v = v_int_integral.copy()
    for i in range(n):
        qx = qp[i, 0]
        qy = qp[i, 1]
        px = qp[i, 2]
        py = qp[i, 3]
        sw = sums[i, 0]
        sc = sums[i, 1]
        cqx = sums[i, 2]
        cqy = sums[i, 3]
        wpx = sums[i, 4]
        wpy = sums[i, 5]
        ex = -(qx * sc - cqx)  # e_int (L23 eq. 7, a_ij-weighted)
        ey = -(qy * sc - cqy)
        eqx = qx - qp_t[i, 0]
        eqy = qy - qp_t[i, 1]
        epx = px - qp_t[i, 2]
        epy = py - qp_t[i, 3]
        if variant == TAILORED:
            k_dt = math.atan(math.sqrt(eqx * eqx + eqy * eqy) / D_dt)  # L24 eq. 3
        else:
            k_dt = K_dt
        ux = K_d * ex + -K_v * (px * sw - wpx) - k_dt * eqx - K_vt * epx  # L24 eq. 1-2
        uy = K_d * ey + -K_v * (py * sw - wpy) - k_dt * eqy - K_vt * epy
        if variant != STANDARD:
            ux = ux + K_int * e_int_integral[i, 0]  # L23 eq. 8
            uy = uy + K_int * e_int_integral[i, 1]
        if variant == TAILORED:
            ux = ux - K_vint * v_int_integral[i, 0]  # L23 eq. 9
            uy = uy - K_vint * v_int_integral[i, 1]
        if active[i]:
            if variant != STANDARD:
                new_e[i, 0] += dt * ex
                new_e[i, 1] += dt * ey
            if variant == TAILORED:
                new_v[i, 0] += dt * epx
                new_v[i, 1] += dt * epy
        else:  # not chasing yet: hold position
            ux = -K_vt * px
            uy = -K_vt * py
        if clip:
            norm = math.sqrt(ux * ux + uy * uy)
            scale = min(1.0, limit / max(norm, 1e-300))
            ux = ux * scale
            uy = uy * scale
        u[i, 0] = ux
        u[i, 1] = uy
    return u, new_e, new_v


def variant_code(variant: str) -> int:
    if variant not in VARIANTS:
        raise ValueError(f"unknown flocking variant {variant!r}; expected one of {VARIANTS}")
    return VARIANTS.index(variant)


def flocking_control_compiled(
    q: np.ndarray,
    p: np.ndarray,
    q_t: np.ndarray,
    p_t: np.ndarray,
    neighbours: Links,
    state: FlockingState,
    gains: FlockingGains | None = None,
    variant: str = "tailored",
    dt: float = 0.05,
    active: np.ndarray | None = None,
    gain_vec: np.ndarray | None = None,
    receivers: np.ndarray | None = None,
) -> tuple[np.ndarray, FlockingState]:
    """Same arguments, results and equations as :func:`swarmtrack.control.flocking.flocking_control`, through
    :func:`flocking_kernel` (dense ``neighbours``), :func:`flocking_kernel_rows` (the dense rows of a subset
    ``receivers``) or :func:`flocking_kernel_csr` (CSR links); ``gain_vec``, :func:`gain_vector` of ``gains``
    computed once by a caller that calls every step."""
    code = variant_code(variant)
    g = FlockingGains() if gains is None else gains
    q = np.asarray(q, dtype=float)
    qp = np.empty((q.shape[0], 4))
    qp[:, :2] = q
    qp[:, 2:] = p
    if receivers is not None and len(receivers) == len(q):
        receivers = None  # all of them (sorted): the whole swarm
    n = q.shape[0] if receivers is None else len(receivers)
    qp_t = np.empty((n, 4))
    qp_t[:, :2] = q_t
    qp_t[:, 2:] = p_t
    act = np.ones(n, dtype=bool) if active is None else np.ascontiguousarray(active, dtype=bool)
    e_int = np.ascontiguousarray(state.e_int_integral, dtype=float)
    v_int = np.ascontiguousarray(state.v_int_integral, dtype=float)
    gv = gain_vector(g) if gain_vec is None else gain_vec
    if is_sparse(neighbours):
        indptr, senders = neighbour_lists(neighbours)
        rows = everyone(n) if receivers is None else np.asarray(receivers, dtype=np.int64)
        own = qp if receivers is None else qp[rows]
        u, e, v = flocking_kernel_csr(qp, own, rows, qp_t, indptr, senders, e_int, v_int, act, gv, code, float(dt))
    elif receivers is not None:
        u, e, v = flocking_kernel_rows(qp, np.asarray(receivers, dtype=np.int64), qp_t,
                                       np.ascontiguousarray(neighbours, dtype=bool), e_int, v_int, act, gv, code,
                                       float(dt))
    else:
        u, e, v = flocking_kernel(qp, qp_t, np.ascontiguousarray(neighbours, dtype=bool), e_int, v_int, act, gv,
                                  code, float(dt))
    return u, FlockingState(e, v)


def compiled_law(gains: FlockingGains) -> Callable[..., tuple[np.ndarray, FlockingState]]:
    """:func:`flocking_control_compiled` with ``gains``' vector computed once: the law a
    :class:`~swarmtrack.control.flocking.FlockingController` calls every control step."""
    return functools.partial(flocking_control_compiled, gain_vec=gain_vector(gains))


__all__ = ["INTEGRAL", "STANDARD", "TAILORED", "compiled_law", "flocking_control_compiled", "flocking_kernel",
           "flocking_kernel_csr", "flocking_kernel_rows", "gain_vector", "variant_code"]
