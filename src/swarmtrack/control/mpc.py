"""Multi-model distributed MPC for formation tracking (W20 Ch. 5, eqs. 5.18-5.31).

Every UAV i solves its own convex QP each control period T over its next h inputs:

* **UAV model** (eqs. 5.20, 5.32): ``x(l+1) = A x(l) + B s(l)``, state ``[x, y, vx, vy]``, input ``s`` the setpoint of
  the UAV's position controller (Sec. 5.3.2), A and B identified (:mod:`swarmtrack.control.identification`).
* **Input** ``u(l) = s(l) − p(k)``: the setpoint relative to the UAV's position when the plan is made. W20's bounds
  (±2 m, ±10 m) cannot bound absolute setpoints with formation slots 10 m from the origin, and its ``uᵀRu`` would
  then pull every UAV toward the origin; read relative, ``−b ≤ u ≤ b`` keeps each planned setpoint within b metres
  of the UAV (per axis), ``R`` penalises long steps, and "zero input" (eq. 5.25) means "hold position".
* **Reference** (eqs. 5.22-5.23): ``x_r(l) = S x̂_target(l) + r_r``, the target propagated from the UAV's estimate by
  the model the estimate follows now (the T-test winner's, W20 Ch. 4), or by one fixed model.
* **Separation** (eqs. 5.24-5.29): for every neighbour j closer than r_s when the plan is made, the term
  ``Q_s ‖p(l) − x_s(l)‖²`` pulls UAV i toward the side-step point ``x_s(l) = p_j(l) + r_s(Δ)``, ``Δ = p_i − p_j``, with
  j propagated by UAV i's own model at zero input (eq. 5.25) from the state j broadcast (eq. 5.24). Eq. 5.28 prints
  a relative vector ``r + r_s`` where W20 Fig. 5.2 shows a point beside j: we use the point.
* **Cost** (eqs. 5.21, 5.31): ``Σ_{l=1..h} Q ‖p(l) − x_r(l)‖² + Σ_j Q_s ‖p(l) − x_s(l)‖² + Σ_{l=0..h−1} R ‖u(l)‖²``,
  Q, R and Q_s scalars on 2-D positions (positions only are weighted).
* **Input bound the vehicle can fly** (ours, :func:`~swarmtrack.control.identification.vehicle_bound`): W20's ±2 m
  lets the position loop ask for more acceleration than a 5° vehicle gives; ``b = a·T / max_l |Δv_l|``, with
  ``Δv_l`` the velocity change in period l of the identified model's response to a unit relative input, is the
  largest bound whose planned first period the vehicle's per-axis acceleration ``a`` can fly.
* **Separation constraint** (ours, :class:`SeparationConstraint`; off by default, W20 has the cost term only): the
  reciprocal half-plane of a buffered Voronoi cell (Zhou et al. 2017) tightened by the identified model's error tube
  (Mayne et al. 2005) and the navigation error, as an exact-penalty soft constraint (Kerrigan & Maciejowski 2000).

Condensed over the inputs ``U`` (eq. 2.45: positions ``G U + f`` with f the free response), the cost is
``w ‖G U + f − r̄‖² + R ‖U‖²`` with ``w = Q + m Q_s`` for m active separation terms and r̄ the weighted mean of the
reference and the side-step points, so the Hessian ``2 (w GᵀG + R I)`` changes only with m. Each UAV keeps one
OSQP problem set up once (:class:`FormationQP`); a plan updates q (and, when m changes, the Hessian's values),
warm-starts from the previous solution and applies the first input (control horizon 1, W20 Sec. 5.4.2).
A solve that does not reach OSQP's "solved" falls back to the last setpoint, clipped into the current bounds
(a feasible input), and is counted. Without a separation constraint the QP is the one above, exactly; with it each
UAV's problem gets h rows per neighbour (the slots grow to the most neighbours met at once).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import osqp
import scipy.sparse as sp

from swarmtrack.control.position import PositionGains, position_control
from swarmtrack.estimation.base import Probe, TargetView
from swarmtrack.models.kinematic import KINEMATIC, kinematic_motion
from swarmtrack.network.rows import Rows

#: The target models the reference can be propagated with (W20 eq. 5.23: CV, CA or CT).
TARGET_MODELS = KINEMATIC
_SOLVED = osqp.SolverStatus.OSQP_SOLVED


@dataclass(frozen=True)
class MPCSettings:
    """W20 Tables 5.5, 5.9, 5.10: horizon ``h``, period ``T`` s, weights ``Q``, ``R``, ``Q_s`` (scalars on 2-D
    positions), separation radius ``r_s`` m (trigger and side-step offset), input bound ``bound`` m (relative
    setpoint, per axis). ``separation`` (ours): the hard separation d (m) each pair of UAVs closer than r_s keeps
    (:class:`SeparationConstraint`), None: W20's cost term only; ``margins`` (h,) its tightening at l = 1..h, m."""

    horizon: int = 5
    period: float = 0.2
    Q: float = 12.0
    R: float = 0.15
    Q_s: float = 6.0
    r_s: float = 5.0
    bound: float = 2.0
    eps: float = 1e-5
    max_iter: int = 4000
    separation: float | None = None
    margins: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if self.separation is not None and len(self.margins) not in (0, self.horizon):
            raise ValueError(f"margins has {len(self.margins)} entries for a horizon of {self.horizon}")


def prediction_matrices(A: np.ndarray, B: np.ndarray, h: int) -> tuple[np.ndarray, np.ndarray]:
    """W20 eq. 2.45: ``X = Φ x(0) + Γ U`` over l = 1..h, ``Φ`` (4h, 4) the powers of A, ``Γ`` (4h, 2h) block lower
    triangular with blocks ``A^(l−1−m) B``; U is time-major ``[s(0), s(1), ...]``."""
    n, m = B.shape
    Phi = np.zeros((h * n, n))
    Gamma = np.zeros((h * n, h * m))
    power = np.eye(n)
    for l in range(h):
        AlB = power @ B  # A^l B: the effect of s(k) on x(k + l + 1)
        for j in range(h - l):
            Gamma[(j + l) * n:(j + l + 1) * n, j * m:(j + 1) * m] = AlB
        power = A @ power
        Phi[l * n:(l + 1) * n] = power
    return Phi, Gamma


@dataclass(frozen=True)
class Condensed:
    """The positions over the horizon as an affine function of the relative inputs (eq. 2.45 with ``s = p(k) + u``):
    ``positions = G U + free(x0)``; ``free`` is also the zero-input prediction of a neighbour (eq. 5.25)."""

    G: np.ndarray  # (2h, 2h)
    Sphi: np.ndarray  # (2h, 4): positions from the initial state
    Shold: np.ndarray  # (2h, 2): positions from a setpoint held at p(k)

    @classmethod
    def build(cls, A: np.ndarray, B: np.ndarray, h: int) -> Condensed:
        Phi, Gamma = prediction_matrices(A, B, h)
        rows = (np.arange(h)[:, None] * 4 + np.arange(2)).ravel()  # x, y of every step
        G = Gamma[rows]
        return cls(G, Phi[rows], G @ np.tile(np.eye(2), (h, 1)))

    def free(self, x0: np.ndarray) -> np.ndarray:
        """(N, 2h) positions over the horizon at zero relative input (setpoint held at the current position)."""
        return x0 @ self.Sphi.T + x0[:, :2] @ self.Shold.T


def side_step(delta: np.ndarray, r_s: float) -> np.ndarray:
    """W20 eq. 5.29: the offset from UAV j to the point UAV i steps to, by the quadrant of ``Δ = p_i − p_j`` (…, 2):
    (0, r_s) for Δx ≥ 0, Δy ≥ 0; (−r_s, 0) for Δx < 0, Δy ≥ 0; (0, −r_s) for Δx < 0, Δy < 0; (r_s, 0) for Δx ≥ 0,
    Δy < 0 (a quarter turn around j)."""
    right, up = delta[..., 0] >= 0, delta[..., 1] >= 0
    out = np.zeros(delta.shape)
    out[..., 0] = np.where(right & ~up, r_s, np.where(~right & up, -r_s, 0.0))
    out[..., 1] = np.where(right & up, r_s, np.where(~right & ~up, -r_s, 0.0))
    return out


def propagate_target(view: TargetView, fixed: str | None, period: float, h: int) -> np.ndarray:
    """W20 eq. 5.23: each UAV's target estimate propagated over the horizon, (N, h, 2) positions at l = 1..h, by the
    model its estimate follows (``view.model``; CV where unknown) or by ``fixed`` for every UAV. The model's extra
    states come from ``view.motion`` ``[ax, ay, ω]`` (zero where absent)."""
    n = len(view.state)
    motion = np.zeros((n, 3)) if view.motion is None else view.motion
    names = np.full(n, fixed or "cv", dtype=object)
    if fixed is None and view.model is not None:
        names[:] = [m if m in TARGET_MODELS else "cv" for m in view.model]
    tau = period * np.arange(1, h + 1)
    out = np.empty((n, h, 2))
    for name in TARGET_MODELS:
        rows = np.flatnonzero(names == name)
        if len(rows):
            out[rows] = kinematic_motion(view.state[rows, :4], name, motion[rows], tau)[..., :2]
    return out


#: The separation slack's penalty when a plan cannot meet its separation constraint (linear per metre and quadratic
#: per square metre, Kerrigan & Maciejowski 2000): the soft problem is solved only after the hard one failed, and
#: then gives the plan of least violation the weights allow.
SLACK_WEIGHT, SLACK_QUADRATIC = 1e3, 1e3
#: A plan whose first step's slack exceeds this (m) did not meet its separation constraint (counted: ``relaxed``).
SLACK_TOL = 1e-3
_INF = 1e30  # OSQP's infinity (osqp.constant("OSQP_INFTY"))


@dataclass(frozen=True)
class SeparationConstraint:
    """The hard separation ``d`` between two UAVs i and j, kept on their flown positions at the plan instants.

    Buffered Voronoi cells (Zhou, Wang, Bandyopadhyay & Schwager 2017, IEEE RA-L 2(2)): each UAV keeps its
    planned positions on its own side of the bisector of the two UAVs' positions when the plan is made, at least d/2
    from it: ``n·(p_i(l) − m_ij) ≥ d/2 + margin_l``, ``n = (p_i − p_j)/‖p_i − p_j‖``, ``m_ij = (p_i + p_j)/2``. Both
    UAVs plan at the same instant from the same two positions (UAV i's own, which it broadcasts, and j's broadcast,
    W20 eq. 5.24), so their half-planes are disjoint and ``‖p_i − p_j‖ ≥ n·(p_i − p_j) ≥ d``: no plan of the
    neighbour has to be known or predicted, so the neighbours' plan changes cannot break it (where Richards & How
    2007, "Robust distributed model predictive control", Int. J. Control 80(9), exchange plans and plan in sequence).
    ``margin_l`` is the tightening that carries the planned separation over to the flown one (Mayne et al. 2005; the
    constraint tightening of Richards & How 2006, ACC, "Robust stable MPC with constraint tightening"): the model's
    :func:`~swarmtrack.control.identification.error_tube` plus its ``navigation_margin``. The plan's first period is
    flown (control horizon 1), so at the next plan instant the flown positions keep d when (a) the model's one-step
    error stays within its bound, (b) the navigation errors within theirs, (c) both plans met their first step's
    rows. The later steps' margins keep the shifted plan feasible as in tube MPC; the bisector moves with every plan,
    so feasibility is not guaranteed:
    a plan whose hard problem OSQP does not solve is planned again with the constraint softened (a slack per row,
    :data:`SLACK_WEIGHT`), where only the rows that cannot be met give way (the later steps' in practice), and counted
    (``softened``); one whose first step needed slack, where the guarantee is lost, is counted again (``relaxed``)."""

    normal: np.ndarray  # (m, 2): n of each neighbour
    rhs: np.ndarray  # (m, h): d/2 + margin_l + n·m_ij − n·f_l, the lower bound on n·(G_l U)


class FormationQP:
    """One UAV's QP (W20 eqs. 5.30-5.31) over its 2h relative inputs, as a persistent OSQP problem.

    ``minimize ½ Uᵀ P U + qᵀ U`` subject to ``−b ≤ U ≤ b``, ``P = 2 (w GᵀG + R I)``, ``q = 2 w Gᵀ (f − r̄)``.
    With ``slots`` > 0, h rows ``n·G_l U ≥ c_kl`` per neighbour slot (:class:`SeparationConstraint`; a free slot's rows
    are unbounded); ``soft`` adds one slack per row (``n·G_l U + σ_kl ≥ c_kl``, ``σ ≥ 0``, ``SLACK_WEIGHT·σ +
    SLACK_QUADRATIC·σ²`` in the cost), so the rows that can be met are. Set up once; :meth:`solve` updates q, P's
    values (same sparsity) only when w changes, and the separation rows' values only when a slot is in use.
    """

    def __init__(self, G: np.ndarray, s: MPCSettings, slots: int = 0, soft: bool = False):
        self.G, self.R, self.slots, self.soft, self.h = G, s.R, slots, soft, s.horizon
        nu = G.shape[1]
        ns = slots * self.h if soft else 0  # slack variables: one per separation row
        template = np.eye(nu + ns)
        template[:nu, :nu] += G.T @ G
        self._rows, self._cols = _csc_pattern(template, upper=True)
        self.w = s.Q
        n = nu + ns
        P = sp.csc_matrix((self._values(self.w), (self._rows, self._cols)), shape=(n, n))
        if slots:
            dense = self._constraints(np.ones((slots, 2)))
            self._arows, self._acols = _csc_pattern(dense)
            A = sp.csc_matrix((dense[self._arows, self._acols], (self._arows, self._acols)), shape=dense.shape)
        else:  # the box alone: W20's problem
            A = sp.identity(nu, format="csc")
        self._lower = np.concatenate([np.full(nu, -s.bound), np.full(slots * self.h, -_INF), np.zeros(ns)])
        upper = np.concatenate([np.full(nu, s.bound), np.full(slots * self.h + ns, _INF)])
        self._q = np.concatenate([np.zeros(nu), np.full(ns, SLACK_WEIGHT)])
        self.solver = osqp.OSQP(algebra="builtin")  # the bundled backend (no search for others at set-up)
        self.solver.setup(P, self._q, A, self._lower, upper, verbose=False, eps_abs=s.eps, eps_rel=s.eps,
                          max_iter=s.max_iter, polishing=False, warm_starting=True)
        self._active = 0  # slots bounded at the last solve
        self.slack = np.zeros((0, self.h))

    def _values(self, w: float) -> np.ndarray:
        nu = self.G.shape[1]
        H = 2.0 * SLACK_QUADRATIC * np.eye(nu + (self.slots * self.h if self.soft else 0))
        H[:nu, :nu] = 2.0 * (w * (self.G.T @ self.G) + self.R * np.eye(nu))
        return H[self._rows, self._cols]

    def _constraints(self, normal: np.ndarray) -> np.ndarray:
        """The dense constraint matrix for the slots' normals (slots, 2): the box, the separation rows, the slacks."""
        nu, h, k = self.G.shape[1], self.h, self.slots
        ns = k * h if self.soft else 0
        A = np.zeros((nu + k * h + ns, nu + ns))
        A[:nu, :nu] = np.eye(nu)
        G = self.G.reshape(h, 2, nu)
        for j in range(k):
            rows = nu + j * h + np.arange(h)
            A[rows, :nu] = np.einsum("a,lau->lu", normal[j], G)
            if self.soft:
                A[rows, nu + rows - nu] = 1.0
                A[nu + k * h + rows - nu, nu + rows - nu] = 1.0
        return A

    def solve(self, f: np.ndarray, r_bar: np.ndarray, w: float, separation: SeparationConstraint | None = None):
        """The optimal U (2h,) for free response ``f`` and mean reference ``r̄`` (2h,) at position weight ``w``, the
        OSQP result's status value and iteration count; :attr:`slack` (m, h) then holds each separation row's slack
        (zeros unless soft)."""
        if w != self.w:
            self.solver.update(Px=self._values(w))
            self.w = w
        nu = self.G.shape[1]
        self._q[:nu] = 2.0 * w * (self.G.T @ (f - r_bar))
        m = 0 if separation is None else len(separation.normal)
        if m or self._active:
            lower = self._lower.copy()
            if m:
                assert separation is not None and m <= self.slots, "more neighbours than slots: rebuild the QP"
                normal = np.zeros((self.slots, 2))
                normal[:m] = separation.normal
                lower[nu:nu + m * self.h] = separation.rhs.ravel()
                A = self._constraints(normal)
                self.solver.update(q=self._q, l=lower, Ax=A[self._arows, self._acols])
            else:
                self.solver.update(q=self._q, l=lower)
            self._active = m
        else:
            self.solver.update(q=self._q)
        res = self.solver.solve(raise_error=False)  # a failed solve is a fallback, counted (not an exception)
        self.slack = np.zeros((m, self.h))
        if self.soft and m and res.x is not None:
            self.slack = res.x[nu:nu + m * self.h].reshape(m, self.h)
        U = res.x if not self.soft or res.x is None else res.x[:nu]
        return U, res.info.status_val, res.info.iter


def _csc_pattern(M: np.ndarray, upper: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Row and column indices of the nonzeros of ``M`` (its upper triangle with ``upper``) in CSC order
    (column-major): the order OSQP takes a matrix's values in."""
    pattern = sp.csc_matrix(np.triu(M) if upper else M)
    pattern.sort_indices()
    rows, cols = pattern.nonzero()
    order = np.lexsort((rows, cols))
    return rows[order], cols[order]


class MPCController:
    """W20's distributed MPC on every UAV, flying its setpoints with its own position controller.

    ``A``, ``B``: the identified UAV model at period ``settings.period``; ``offsets`` (N, 2) each UAV's place
    ``r_r`` relative to the target; ``target_model``: None follows the model of each UAV's estimate (multi-model),
    a name from :data:`TARGET_MODELS` fixes it (single-model); ``start``: s before which every UAV holds the
    position it had at its first command (W20 Sec. 5.4.4.2: the DMPC starts at t = 20 s).

    Broadcasts each UAV's navigation state (eq. 5.24); plans every ``period`` s; between plans, and every control
    step, the position controller flies the held setpoint. With ``settings.separation`` each UAV's plan also keeps
    the :class:`SeparationConstraint` with every neighbour closer than r_s (probes, cumulative counts: ``softened``,
    its plans whose hard constraint could not be met and was softened; ``relaxed``, those whose first step needed
    the slack).
    """

    def __init__(self, A: np.ndarray, B: np.ndarray, offsets: np.ndarray, settings: MPCSettings, *,
                 target_model: str | None = None, start: float = 0.0, gains: PositionGains | None = None,
                 rows: Rows | None = None):
        self.s, self.target_model, self.start = settings, target_model, start
        self.rows = rows or Rows.all(len(offsets))
        self.gains = gains or PositionGains()
        self.offsets = np.asarray(offsets, dtype=float)
        n = len(self.offsets)
        self.cond = Condensed.build(np.asarray(A, dtype=float), np.asarray(B, dtype=float), settings.horizon)
        self.qps = [FormationQP(self.cond.G, settings) for _ in range(n)]
        self._softs: dict[int, FormationQP] = {}  # the soft-constrained problems, made when first needed
        self.setpoint: np.ndarray | None = None
        self._next_plan = start
        self.avoiding = np.zeros(n)
        self.solves = np.zeros(n)
        self.fallbacks = np.zeros(n)
        self.solve_time = np.zeros(n)  # cumulative wall time of this UAV's solves, s
        self.iterations = np.zeros(n)  # cumulative OSQP iterations
        self.softened = np.zeros(n)  # cumulative plans whose hard separation problem was infeasible: softened
        self.relaxed = np.zeros(n)  # of those, the plans whose first step needed slack (the guarantee lost)
        self.probes: tuple[Probe, ...] = (Probe("setpoint", (2,)), Probe("avoiding", ()), Probe("solves", ()),
                                          Probe("fallbacks", ()), Probe("solve_time", ()), Probe("iterations", ()))
        if settings.separation is not None:
            self.probes += (Probe("softened", ()), Probe("relaxed", ()))

    def broadcast(self, t: float, nav: np.ndarray) -> dict:
        """Beacon: own position and velocity (W20 eq. 5.24)."""
        return {"nav": nav}

    def command(self, t: float, nav: np.ndarray, view: TargetView, inbox, dt: float) -> np.ndarray:
        self._hold_from(nav)
        if t >= self._next_plan - 1e-9:
            self.plan(nav, view, inbox)
            self._next_plan = t + self.s.period
        assert self.setpoint is not None  # _hold_from made it
        return position_control(self.setpoint, nav, self.gains)

    def plan(self, nav: np.ndarray, view: TargetView, inbox) -> None:
        """One MPC step of every UAV (each from its own state, estimate and inbox)."""
        s, h = self.s, self.s.horizon
        self._hold_from(nav)
        assert self.setpoint is not None  # _hold_from made it
        ref = propagate_target(view, self.target_model, s.period, h) + self.offsets[:, None, :]  # (N, h, 2)
        own_free = self.rows.rowwise(self.cond.free, nav)
        close = self._close(nav, inbox)
        w, r_bar = self._separation(close, inbox, ref)
        bounds = self._constraints(close, nav, inbox, own_free)
        ready = np.isfinite(r_bar).all(axis=(1, 2))  # no estimate yet: keep holding
        for i in map(int, np.flatnonzero(ready)):
            cons = bounds.get(i)
            if cons is not None and len(cons.normal) > self.qps[i].slots:  # more neighbours than ever: more slots
                self.qps[i] = FormationQP(self.cond.G, s, slots=len(cons.normal))
            t0 = time.perf_counter()
            args = (own_free[i], r_bar[i].ravel(), float(w[i]))
            U, status, iters = self.qps[i].solve(*args, cons)
            if cons is not None and status != _SOLVED:  # the separation constraint cannot be met: softened
                U, status, more = self._soft(i).solve(*args, cons)
                iters += more  # the guarantee is lost when the first step's rows, which are flown, needed slack
                self.softened[i] += 1
                self.relaxed[i] += status == _SOLVED and bool((self._softs[i].slack[:, 0] > SLACK_TOL).any())
            self.solve_time[i] += time.perf_counter() - t0
            self.solves[i] += 1
            self.iterations[i] += iters
            if status == _SOLVED:
                self.setpoint[i] = nav[i, :2] + U[:2]
            else:  # the last setpoint, moved into this plan's bounds: a feasible input
                self.fallbacks[i] += 1
                self.setpoint[i] = nav[i, :2] + np.clip(self.setpoint[i] - nav[i, :2], -s.bound, s.bound)

    def _soft(self, i: int) -> FormationQP:
        """UAV i's soft-constrained problem (slack on the separation rows), as many slots as its hard one."""
        soft = self._softs.get(i)
        if soft is None or soft.slots < self.qps[i].slots:
            soft = self._softs[i] = FormationQP(self.cond.G, self.s, slots=self.qps[i].slots, soft=True)
        return soft

    def _hold_from(self, nav: np.ndarray) -> None:
        """Before the first plan every UAV holds where it was at its first command."""
        if self.setpoint is None:
            self.setpoint = nav[:, :2].copy()

    def _close(self, nav: np.ndarray, inbox) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """``(receiver rows, senders, Δ = p_i − p_j)`` of every neighbour closer than r_s as it broadcast (eq. 5.24);
        None when there is none, or when collision avoidance is off (``Q_s = 0``)."""
        if self.s.Q_s == 0:
            return None
        beacons = inbox.payloads["nav"]
        recv, send = inbox.edges()
        delta = nav[recv, :2] - beacons[send, :2]
        close = np.einsum("ij,ij->i", delta, delta) < self.s.r_s ** 2
        if not close.any():
            return None
        return recv[close], send[close], delta[close]

    def _separation(self, close, inbox, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each UAV's position weight ``w = Q + m Q_s`` and mean reference r̄ (N, h, 2) with its m neighbours closer
        than r_s (eqs. 5.24-5.29): neighbour j (as it broadcast, eq. 5.24) propagated at zero input by this UAV's
        model (eq. 5.25), plus the side-step offset of eq. 5.29."""
        s, n = self.s, len(ref)
        self.avoiding = np.zeros(n)
        if close is None:
            return np.full(n, s.Q), ref
        recv, send, delta = close
        beacons = inbox.payloads["nav"]
        steps = self.cond.free(beacons)[send].reshape(-1, s.horizon, 2) + side_step(delta, s.r_s)[:, None, :]
        m = np.bincount(recv, minlength=n)
        pull = np.zeros_like(ref)
        np.add.at(pull, recv, steps)
        w = s.Q + m * s.Q_s
        self.avoiding = m.astype(float)
        return w, (s.Q * ref + s.Q_s * pull) / w[:, None, None]

    def _constraints(self, close, nav: np.ndarray, inbox, own_free: np.ndarray) -> dict[int, SeparationConstraint]:
        """Each UAV's :class:`SeparationConstraint` with its neighbours closer than r_s (by receiver row), none
        without ``separation``: the unit normal ``n`` of ``Δ = p_i − p_j`` (two UAVs at the same point: the one of
        higher number takes +x, the other −x) and the bounds ``d/2 + margin_l + n·m_ij − n·f_l`` on ``n·G_l U``."""
        s = self.s
        if s.separation is None or close is None:
            return {}
        recv, send, delta = close
        beacons = inbox.payloads["nav"]
        dist = np.sqrt(np.einsum("ij,ij->i", delta, delta))
        normal = np.where(dist[:, None] > 1e-9, delta / np.maximum(dist, 1e-300)[:, None], 0.0)
        same = dist <= 1e-9
        normal[same, 0] = np.where(self.rows.uavs[recv[same]] > send[same], 1.0, -1.0)
        mid = 0.5 * (nav[recv, :2] + beacons[send, :2])
        margins = np.asarray(s.margins) if s.margins else np.zeros(s.horizon)
        free = own_free[recv].reshape(-1, s.horizon, 2)
        rhs = (0.5 * s.separation + margins[None, :] + np.einsum("ka,ka->k", normal, mid)[:, None]
               - np.einsum("ka,kla->kl", normal, free))
        return {int(i): SeparationConstraint(normal[recv == i], rhs[recv == i]) for i in np.unique(recv)}

    def sample(self) -> dict[str, np.ndarray]:
        n = len(self.offsets)
        return {"setpoint": self.setpoint if self.setpoint is not None else np.full((n, 2), np.nan),
                "avoiding": self.avoiding, "solves": self.solves, "fallbacks": self.fallbacks,
                "solve_time": self.solve_time, "iterations": self.iterations,
                **({"softened": self.softened, "relaxed": self.relaxed} if self.s.separation is not None else {})}
