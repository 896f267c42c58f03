"""Flocking protocols for double-integrator agents chasing a target (L24 Sec. 2, L23 Sec. 2).

Three variants share one function, :func:`flocking_control`:

``"standard"``
    Olfati-Saber protocol ``u = u_d + u_v + u_t`` (L24 eq. 1-2, L23 eq. 2-6).
``"integral"``
    standard + ``K_int ∫ e_int dt`` (L24 text below eq. 2, L23 eq. 7-8).
``"tailored"``
    integral + ``-K_vint ∫ (p_i - p_t) dt`` (L23 eq. 9) and the constant target gain ``K_dt`` replaced by the
    dynamic gain ``atan(‖q_i - q_t‖ / D_dt)`` (L24 eq. 3, L23 eq. 10).

Everything is vectorised over agents. With dense ``(N, N)`` neighbour masks the neighbour sums are
reductions over the pair axis (``Σ_j c_ij (x_i - x_j) = x_i Σ_j c_ij - (C x)_i``), so no array larger than
``(N, N)`` is built; with sparse (CSR) links (:mod:`swarmtrack.network.links`, large swarms) the pair terms
are computed per stored link and summed per receiver, in O(N + links) memory. Both give the same numbers to
rounding.

The commands can be computed for R receivers, a subset of the swarm's N UAVs (one UAV's own process), from their
rows of the links (R, N) and every sender's beacon: the same numbers, bit for bit, as the whole swarm's rows.

Conventions
-----------
* ``a_ij`` weighting is applied consistently to every neighbour sum, including ``e_int``: the papers write
  ``e_int`` as a plain sum over ``N_i`` (L23 eq. 7), but since ``N_i`` is itself "agents within ``r_comm``"
  the bump weight is the smooth version of that set and keeps ``e_int`` continuous when a neighbour
  enters or leaves the range. With ``a_ij`` weighting ``e_int,i = -u_d,i / K_d``.
* Integrals use forward Euler: the control at step k uses the integrals accumulated up to step k, and the
  returned state holds ``I(k+1) = I(k) + dt * integrand(k)``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from swarmtrack.control.gains import FlockingGains
from swarmtrack.network.links import Links, edge_list, is_sparse

__all__ = [
    "VARIANTS",
    "FlockingGains",
    "FlockingState",
    "bump",
    "flocking_control",
    "inter_agent_distances",
    "phi",
    "sigma_norm",
]

VARIANTS = ("standard", "integral", "tailored")


def sigma_norm(z: np.ndarray, eps: float) -> np.ndarray:
    """σ-norm ``‖z‖σ = (√(1 + ε‖z‖²) − 1) / ε`` of vectors ``z`` of shape ``(..., m)`` → ``(...)``.

    L24 Sec. 2 / L23 below eq. 3; differentiable everywhere, including ``z = 0`` (gradient
    ``z / √(1 + ε‖z‖²)``), unlike the Euclidean norm.
    """
    z = np.asarray(z, dtype=float)
    return _sigma_from_sq(np.sum(z * z, axis=-1), eps)


def _sigma_from_sq(sq: np.ndarray | float, eps: float) -> np.ndarray:
    """σ-norm from the squared Euclidean norm (numerically stable form of the same expression)."""
    sq = np.asarray(sq, dtype=float)
    # (√(1+εs) − 1)/ε == s / (√(1+εs) + 1): no cancellation for small s.
    return sq / (np.sqrt(1.0 + eps * sq) + 1.0)


def phi(z: np.ndarray | float) -> np.ndarray:
    """Action function ``φ(z) = z / √(1 + z²)`` (L24 Sec. 2, L23 eq. 3): odd, bounded in (−1, 1)."""
    z = np.asarray(z, dtype=float)
    return z / np.sqrt(1.0 + z * z)


def bump(z: np.ndarray | float, h: float) -> np.ndarray:
    """Bump function ``a_ij(z)`` (L24 Sec. 2, L23 eq. 4).

    1 on ``[0, h)``, ``½[1 + cos(π (z − h)/(1 − h))]`` on ``[h, 1]``, 0 otherwise (also for ``z < 0``).
    Continuous (and C¹) in z; ``h ∈ (0, 1)``.
    """
    z = np.asarray(z, dtype=float)
    out = np.zeros_like(z)
    out[(z >= 0.0) & (z < h)] = 1.0
    mid = (z >= h) & (z <= 1.0)
    if np.any(mid):
        out[mid] = 0.5 * (1.0 + np.cos(np.pi * (z[mid] - h) / (1.0 - h)))
    return out


@dataclass(frozen=True)
class FlockingState:
    """Integrator state of the flocking controller, one row per agent.

    ``e_int_integral`` (N, 2) = ∫ e_int dt (L23 eq. 8);
    ``v_int_integral`` (N, 2) = ∫ (p_i − p_t) dt (L23 eq. 9).
    """

    e_int_integral: np.ndarray
    v_int_integral: np.ndarray

    @classmethod
    def zeros(cls, n: int) -> FlockingState:
        return cls(np.zeros((n, 2)), np.zeros((n, 2)))


def inter_agent_distances(q: np.ndarray) -> np.ndarray:
    """Euclidean distance matrix ``(N, N)`` of positions ``q`` ``(N, 2)``."""
    q = np.asarray(q, dtype=float)
    dx = q[:, 0, None] - q[None, :, 0]
    dy = q[:, 1, None] - q[None, :, 1]
    return np.hypot(dx, dy)


def _pair_weights(
    q: np.ndarray, neighbours: np.ndarray, gains: FlockingGains
) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(w, c)``: bump weights ``a_ij`` (masked, zero diagonal) and the distance-regulator
    coefficients ``c_ij = a_ij φ(‖q_ij‖σ − ‖d‖σ)/(1 + ε‖q_ij‖σ)`` (L24 eq. 1), both ``(N, N)``."""
    eps = gains.eps
    dx = q[:, 0, None] - q[None, :, 0]
    dy = q[:, 1, None] - q[None, :, 1]
    sig = _sigma_from_sq(dx * dx + dy * dy, eps)
    w = bump(sig / _sigma_from_sq(gains.r_comm**2, eps), gains.h)
    mask = np.asarray(neighbours, dtype=bool)
    w *= mask
    np.fill_diagonal(w, 0.0)
    return w, _regulator_coefficients(w, sig, gains)


def _regulator_coefficients(w: np.ndarray, sig: np.ndarray, gains: FlockingGains) -> np.ndarray:
    """``c_ij = a_ij φ(‖q_ij‖σ − ‖d‖σ)/(1 + ε‖q_ij‖σ)`` (L24 eq. 1) from ``a_ij`` and ``‖q_ij‖σ``."""
    return w * phi(sig - _sigma_from_sq(gains.d**2, gains.eps)) / (1.0 + gains.eps * sig)


def _laplacian_apply(c: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``Σ_j c_ij (x_i − x_j)`` for all i, as ``x_i Σ_j c_ij − (C x)_i``."""
    return x * c.sum(axis=1)[:, None] - c @ x


def _dense_neighbour_terms(
    q: np.ndarray, p: np.ndarray, neighbours: np.ndarray, gains: FlockingGains, receivers: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """``(e_int, Σ_j a_ij (p_i − p_j))`` (L23 eq. 7, L24 velocity matching) over an ``(N, N)`` mask; for the rows
    (R, N) of the swarm's UAVs ``receivers``, in the swarm's shape with the other rows empty (the products then
    take the whole swarm's path: :mod:`swarmtrack.network.rows`)."""
    if receivers is not None:
        full = np.zeros((q.shape[0], q.shape[0]), dtype=bool)
        full[receivers] = neighbours
        e_int, dp = _dense_neighbour_terms(q, p, full, gains)
        return e_int[receivers], dp[receivers]
    w, c = _pair_weights(q, neighbours, gains)
    return -_laplacian_apply(c, q), _laplacian_apply(w, p)


def _sparse_neighbour_terms(
    q: np.ndarray, p: np.ndarray, links: Links, gains: FlockingGains, receivers: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Same as :func:`_dense_neighbour_terms` for CSR links: ``a_ij``, ``c_ij`` per stored link (receiver i,
    sender j), summed per receiver; O(N + links) memory."""
    own_q, own_p = (q, p) if receivers is None else (q[receivers], p[receivers])
    i, j = edge_list(links)
    dq = own_q[i] - q[j]
    sig = _sigma_from_sq(dq[:, 0] * dq[:, 0] + dq[:, 1] * dq[:, 1], gains.eps)
    w = bump(sig / _sigma_from_sq(gains.r_comm**2, gains.eps), gains.h)
    c = _regulator_coefficients(w, sig, gains)
    e_int = -_edge_laplacian_apply(c, (i, j), own_q, q)
    return e_int, _edge_laplacian_apply(w, (i, j), own_p, p)


def _edge_laplacian_apply(c: np.ndarray, edges: tuple[np.ndarray, np.ndarray], own: np.ndarray,
                          x: np.ndarray) -> np.ndarray:
    """``Σ_j c_ij (x_i − x_j)`` for every receiver i, with ``c`` given per directed link ``edges = (i, j)``, the
    receivers' own ``own`` (R, d) and the senders' ``x`` (N, d)."""
    i, j = edges
    n = own.shape[0]
    out = own * np.bincount(i, weights=c, minlength=n)[:, None]
    for k in range(x.shape[1]):
        out[:, k] -= np.bincount(i, weights=c * x[j, k], minlength=n)
    return out


def _clip_norm(u: np.ndarray, limit: float) -> np.ndarray:
    if not np.isfinite(limit) or limit <= 0.0:
        return u
    n = np.linalg.norm(u, axis=1)
    scale = np.minimum(1.0, limit / np.maximum(n, 1e-300))
    return u * scale[:, None]


def flocking_control(
    q: np.ndarray,
    p: np.ndarray,
    q_t: np.ndarray,
    p_t: np.ndarray,
    neighbours: np.ndarray,
    state: FlockingState,
    gains: FlockingGains | None = None,
    variant: str = "tailored",
    dt: float = 0.05,
    active: np.ndarray | None = None,
    receivers: np.ndarray | None = None,
) -> tuple[np.ndarray, FlockingState]:
    """Flocking acceleration commands for N agents (or R of them, ``receivers``) and the updated integrator state
    (pure function).

    Parameters
    ----------
    q, p : (N, 2)
        Each agent's own position and velocity (the beacons of every sender).
    q_t, p_t : (R, 2) or (2,)
        Target position and velocity as *each* receiver knows it (its own estimate; a (2,) array is broadcast).
    neighbours : (R, N) bool array or CSR links
        ``neighbours[r, j]``: receiver r receives agent j's state (its own ignored). The bump ``a_ij`` on
        ``‖q_i − q_j‖σ/‖r_comm‖σ`` additionally zeroes agents beyond r_comm. Sparse links
        (:func:`swarmtrack.network.links.proximity_links` for large swarms) give the same numbers to
        rounding without any ``(N, N)`` array.
    state : FlockingState
        Integrals at this step.
    gains : FlockingGains, default ``FlockingGains()``.
    variant : ``"standard"`` | ``"integral"`` | ``"tailored"``
        standard: ``u = u_d + u_v + u_t`` (L24 eq. 1-2, L23 eq. 2-6), with
        ``u_d = −K_d Σ a_ij (q_i − q_j) φ(‖q_ij‖σ − ‖d‖σ)/(1 + ε‖q_ij‖σ)``, ``u_v = −K_v Σ a_ij (p_i − p_j)``,
        ``u_t = −K_dt (q_i − q_t) − K_vt (p_i − p_t)``.
        integral: standard + ``K_int ∫ e_int dt``, ``e_int = Σ a_ij (q_j − q_i) φ(·)/(1 + ε‖·‖σ)``
        (L23 eq. 7-8; a_ij-weighted, see module docstring).
        tailored: integral − ``K_vint ∫ (p_i − p_t) dt`` (L23 eq. 9), with ``K_dt`` replaced by
        ``atan(‖q_i − q_t‖/D_dt)`` (L24 eq. 3, L23 eq. 10).
    dt : float
        Step used for the forward-Euler integrals.
    active : (N,) bool, optional
        Agents not yet chasing (e.g. before the filter has converged) only hold position,
        ``u = −K_vt p_i``, and their integrals do not accumulate. Default: all active.
    receivers : (R,) int, optional
        The agents (sorted, 0-based) the commands are for: the rows of ``neighbours``, ``q_t``, ``p_t``, ``state``
        and ``active``; their own states are ``q[receivers]``, ``p[receivers]``. Default: all N. Each row is bit
        for bit the whole swarm's.

    Returns
    -------
    u : (N, 2)
        Commanded accelerations, norm-clipped to ``gains.accel_limit``.
    new_state : FlockingState
        Integrals at the next step.
    """
    if variant not in VARIANTS:
        raise ValueError(f"unknown flocking variant {variant!r}; expected one of {VARIANTS}")
    g = FlockingGains() if gains is None else gains
    q_s = np.asarray(q, dtype=float)
    p_s = np.asarray(p, dtype=float)
    if receivers is not None and len(receivers) == len(q_s):
        receivers = None  # all of them (sorted): the whole swarm
    q, p = (q_s, p_s) if receivers is None else (q_s[receivers], p_s[receivers])
    n = q.shape[0]
    q_t = np.broadcast_to(np.asarray(q_t, dtype=float), (n, 2))
    p_t = np.broadcast_to(np.asarray(p_t, dtype=float), (n, 2))

    # e_int,i = Σ_j c_ij (q_j − q_i) = −Σ_j c_ij (q_i − q_j)   (L23 eq. 7, a_ij-weighted)
    neighbour_terms = _sparse_neighbour_terms if is_sparse(neighbours) else _dense_neighbour_terms
    e_int, p_disagreement = neighbour_terms(q_s, p_s, neighbours, g, receivers)
    u_d = g.K_d * e_int  # L24 eq. 1 distance regulator: −K_d Σ c_ij (q_i − q_j)
    u_v = -g.K_v * p_disagreement  # L24 velocity matching
    eq = q - q_t
    ep = p - p_t
    if variant == "tailored":
        k_dt = np.arctan(np.linalg.norm(eq, axis=1) / g.D_dt)[:, None]  # L24 eq. 3
    else:
        k_dt = g.K_dt
    u = u_d + u_v - k_dt * eq - g.K_vt * ep  # L24 eq. 1-2
    if variant in ("integral", "tailored"):
        u = u + g.K_int * state.e_int_integral  # L23 eq. 8
    if variant == "tailored":
        u = u - g.K_vint * state.v_int_integral  # L23 eq. 9

    if active is None:
        act = np.ones(n, dtype=bool)
    else:
        act = np.asarray(active, dtype=bool)
        u = np.where(act[:, None], u, -g.K_vt * p)

    new_e = state.e_int_integral.copy()
    new_v = state.v_int_integral.copy()
    if variant in ("integral", "tailored"):
        new_e[act] += dt * e_int[act]
    if variant == "tailored":
        new_v[act] += dt * ep[act]
    new_state = replace(state, e_int_integral=new_e, v_int_integral=new_v)
    return _clip_norm(u, g.accel_limit), new_state


class FlockingController:
    """Onboard flocking (L24 Sec. 2): each UAV beacons its own navigation state and follows its own estimate of
    the target, holding position until ``chase_after`` seconds (the first filter iterations, L24 Sec. 4).
    ``n_uavs`` rows: the whole swarm, or the receivers of its inboxes (:attr:`Inbox.receivers`, one UAV's own
    process), whose rows are bit for bit the whole swarm's.

    ``law``: the control law, :func:`flocking_control` (the numpy reference) or its compiled twin
    (:func:`swarmtrack.control.kernels.compiled_law`, same numbers to rounding); the builder picks it.
    """

    probes = ()

    def __init__(self, gains: FlockingGains, variant: str, n_uavs: int, chase_after: float, *,
                 law: Callable = flocking_control):
        self.gains, self.variant, self.chase_after = gains, variant, chase_after
        self.state = FlockingState.zeros(n_uavs)
        self._control = law

    def broadcast(self, t: float, nav: np.ndarray) -> dict:
        """Beacon: own position and velocity (what ``a_ij`` and the velocity consensus need)."""
        return {"nav": nav}

    def command(self, t: float, nav: np.ndarray, view, inbox, dt: float) -> np.ndarray:
        """Acceleration command (R, 2): UAV i uses beacon j only where its inbox has a link from j."""
        # row j of the beacons is UAV j's own navigation state (row receivers[r]: this UAV's own); the pair terms
        # read row j only where the link i <- j delivered it
        beacons = inbox.payloads["nav"]
        receivers = None if len(inbox.receivers) == len(beacons) else inbox.receivers
        # t counts physics ticks and chase_after estimation steps: their float products can differ by an ulp;
        # a UAV whose estimator has no estimate of the target (a multi-target tracker with no track) holds position
        target = view.state
        active = (t >= self.chase_after - 1e-9) & np.isfinite(target[:, :4]).all(axis=1)
        u, self.state = self._control(beacons[:, :2], beacons[:, 2:4], target[:, :2], target[:, 2:4], inbox.links,
                                      self.state, self.gains, self.variant, dt, active=active, receivers=receivers)
        return u

    def sample(self) -> dict[str, np.ndarray]:
        return {}
