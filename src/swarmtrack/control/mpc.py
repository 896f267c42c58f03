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

Condensed over the inputs ``U`` (eq. 2.45: positions ``G U + f`` with f the free response), the cost is
``w ‖G U + f − r̄‖² + R ‖U‖²`` with ``w = Q + m Q_s`` for m active separation terms and r̄ the weighted mean of the
reference and the side-step points, so the Hessian ``2 (w GᵀG + R I)`` changes only with m. Each UAV keeps one
OSQP problem set up once (:class:`FormationQP`); a plan updates q (and, when m changes, the Hessian's values),
warm-starts from the previous solution and applies the first input (control horizon 1, W20 Sec. 5.4.2).
A solve that does not reach OSQP's "solved" falls back to the last setpoint, clipped into the current bounds
(a feasible input), and is counted.
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
    setpoint, per axis)."""

    horizon: int = 5
    period: float = 0.2
    Q: float = 12.0
    R: float = 0.15
    Q_s: float = 6.0
    r_s: float = 5.0
    bound: float = 2.0
    eps: float = 1e-5
    max_iter: int = 4000


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


class FormationQP:
    """One UAV's QP (W20 eqs. 5.30-5.31) over its 2h relative inputs, as a persistent OSQP problem.

    ``minimize ½ Uᵀ P U + qᵀ U`` subject to ``−b ≤ U ≤ b``, ``P = 2 (w GᵀG + R I)``, ``q = 2 w Gᵀ (f − r̄)``.
    Set up once; :meth:`solve` updates q, and P's values (same sparsity) only when w changes.
    """

    def __init__(self, G: np.ndarray, s: MPCSettings):
        self.G, self.R = G, s.R
        n = G.shape[1]
        pattern = sp.csc_matrix(np.triu(G.T @ G + np.eye(n)))
        pattern.sort_indices()
        self._rows, self._cols = pattern.nonzero()  # CSC order after sort_indices: column-major
        order = np.lexsort((self._rows, self._cols))
        self._rows, self._cols = self._rows[order], self._cols[order]
        self.w = s.Q
        P = sp.csc_matrix((self._values(self.w), (self._rows, self._cols)), shape=(n, n))
        self.solver = osqp.OSQP(algebra="builtin")  # the bundled backend (no search for others at set-up)
        self.solver.setup(P, np.zeros(n), sp.identity(n, format="csc"), np.full(n, -s.bound), np.full(n, s.bound),
                          verbose=False, eps_abs=s.eps, eps_rel=s.eps, max_iter=s.max_iter, polishing=False,
                          warm_starting=True)

    def _values(self, w: float) -> np.ndarray:
        H = 2.0 * (w * (self.G.T @ self.G) + self.R * np.eye(self.G.shape[1]))
        return H[self._rows, self._cols]

    def solve(self, f: np.ndarray, r_bar: np.ndarray, w: float):
        """The optimal U (2h,) for free response ``f`` and mean reference ``r̄`` (2h,) at position weight ``w``, the
        OSQP result's status value and iteration count."""
        if w != self.w:
            self.solver.update(Px=self._values(w))
            self.w = w
        self.solver.update(q=2.0 * w * (self.G.T @ (f - r_bar)))
        res = self.solver.solve(raise_error=False)  # a failed solve is a fallback, counted (not an exception)
        return res.x, res.info.status_val, res.info.iter


class MPCController:
    """W20's distributed MPC on every UAV, flying its setpoints with its own position controller.

    ``A``, ``B``: the identified UAV model at period ``settings.period``; ``offsets`` (N, 2) each UAV's place
    ``r_r`` relative to the target; ``target_model``: None follows the model of each UAV's estimate (multi-model),
    a name from :data:`TARGET_MODELS` fixes it (single-model); ``start``: s before which every UAV holds the
    position it had at its first command (W20 Sec. 5.4.4.2: the DMPC starts at t = 20 s).

    Broadcasts each UAV's navigation state (eq. 5.24); plans every ``period`` s; between plans, and every control
    step, the position controller flies the held setpoint.
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
        self.setpoint: np.ndarray | None = None
        self._next_plan = start
        self.avoiding = np.zeros(n)
        self.solves = np.zeros(n)
        self.fallbacks = np.zeros(n)
        self.solve_time = np.zeros(n)  # cumulative wall time of this UAV's solves, s
        self.iterations = np.zeros(n)  # cumulative OSQP iterations
        self.probes = (Probe("setpoint", (2,)), Probe("avoiding", ()), Probe("solves", ()), Probe("fallbacks", ()),
                       Probe("solve_time", ()), Probe("iterations", ()))

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
        w, r_bar = self._separation(nav, inbox, ref)
        ready = np.isfinite(r_bar).all(axis=(1, 2))  # no estimate yet: keep holding
        for i in np.flatnonzero(ready):
            qp = self.qps[i]
            t0 = time.perf_counter()
            U, status, iters = qp.solve(own_free[i], r_bar[i].ravel(), float(w[i]))
            self.solve_time[i] += time.perf_counter() - t0
            self.solves[i] += 1
            self.iterations[i] += iters
            if status == _SOLVED:
                self.setpoint[i] = nav[i, :2] + U[:2]
            else:  # the last setpoint, moved into this plan's bounds: a feasible input
                self.fallbacks[i] += 1
                self.setpoint[i] = nav[i, :2] + np.clip(self.setpoint[i] - nav[i, :2], -s.bound, s.bound)

    def _hold_from(self, nav: np.ndarray) -> None:
        """Before the first plan every UAV holds where it was at its first command."""
        if self.setpoint is None:
            self.setpoint = nav[:, :2].copy()

    def _separation(self, nav: np.ndarray, inbox, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each UAV's position weight ``w = Q + m Q_s`` and mean reference r̄ (N, h, 2) with its m neighbours closer
        than r_s (eqs. 5.24-5.29): neighbour j (as it broadcast, eq. 5.24) propagated at zero input by this UAV's
        model (eq. 5.25), plus the side-step offset of eq. 5.29."""
        s, n = self.s, len(nav)
        self.avoiding = np.zeros(n)
        if s.Q_s == 0:
            return np.full(n, s.Q), ref
        beacons = inbox.payloads["nav"]
        recv, send = inbox.edges()
        delta = nav[recv, :2] - beacons[send, :2]
        close = np.einsum("ij,ij->i", delta, delta) < s.r_s ** 2
        if not close.any():
            return np.full(n, s.Q), ref
        recv, send, delta = recv[close], send[close], delta[close]
        steps = self.cond.free(beacons)[send].reshape(-1, s.horizon, 2) + side_step(delta, s.r_s)[:, None, :]
        m = np.bincount(recv, minlength=n)
        pull = np.zeros_like(ref)
        np.add.at(pull, recv, steps)
        w = s.Q + m * s.Q_s
        self.avoiding = m.astype(float)
        return w, (s.Q * ref + s.Q_s * pull) / w[:, None, None]

    def sample(self) -> dict[str, np.ndarray]:
        n = len(self.offsets)
        return {"setpoint": self.setpoint if self.setpoint is not None else np.full((n, 2), np.nan),
                "avoiding": self.avoiding, "solves": self.solves, "fallbacks": self.fallbacks,
                "solve_time": self.solve_time, "iterations": self.iterations}
