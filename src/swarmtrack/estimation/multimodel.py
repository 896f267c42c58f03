"""Multi-model distributed EKF: one covariance-form EKF per UAV, each with its own target model, and fusion of the
models' estimates across the team (W20 Ch. 4).

Per estimation step every UAV i
1. predicts with its own model (W20 eqs. 4.7-4.9) and broadcasts its raw measurement with its pose data;
2. stacks its own and its neighbours' measurements (block-diagonal R, their number changing every step; W20 eqs.
   4.17-4.22) and updates (eqs. 4.10-4.13). The update is computed through the sum of the measurements'
   position-block information (the second lines of W20 eqs. 4.3-4.4): equal to the stacked update, at a cost that
   does not grow with the number of measurements. It yields the innovation, its covariance, the likelihood of the
   stacked innovation (eq. 4.31, m the stacked dimension) and the posterior residual (eq. 4.28);
3. broadcasts its posterior on the states every model shares, ``[x, y, vx, vy]``, its likelihood and its last n
   residuals (W20 Sec. 4.3.4), and fuses what it received into its output (:mod:`swarmtrack.estimation.fusion`):
   T-test selection, the thesis' IMM weighting, the standard IMM with mixing, or max-likelihood fusion. Except with
   mixing, each UAV keeps its own posterior for its next step (W20 Sec. 4.3.4).

A filter starts from its first measurement (``x̂0 = [h⁻¹(z0); 0]``, CT ``ω0 = 1e-5``, ``P0``; W20 Table 4.1) and uses
its own measurements alone for the first ``solo_steps`` steps (W20 Fig. 4.11) before sharing. When no UAV a UAV
hears from measured the target, the T-test has no residual (W20 Sec. 4.5): the output follows the occlusion policy
(the last T-test winner, eq. 4.38; the least trace of the position covariance, 4.39; or the smallest largest
eigenvalue of it, 4.40).

Residuals are normalised per measurement: ``ε = (1/η) Σ_l ν⁺_lᵀ R_l⁻¹ ν⁺_l`` over the η measurements a UAV stacked.
With W20's ``R = r I`` this is the thesis' ``‖z − h(x̂⁺)‖²`` divided by ``r η``: the same ranking between
candidates that stacked the same number of measurements, comparable between those that did not, and unit-free for a
range-bearing sensor.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.estimation import fusion
from swarmtrack.estimation.base import Probe, TargetView
from swarmtrack.estimation.information import FilterDivergence, positive_definite, symmetrize
from swarmtrack.estimation.kalman import ekf_predict
from swarmtrack.estimation.multimodel_compiled import CompiledStep
from swarmtrack.models.base import MotionModel
from swarmtrack.network.rows import Rows

FUSIONS = ("ttest", "imm-thesis", "imm", "ml", "none")
OCCLUSION_POLICIES = ("last", "trace", "eigenvalue")
COMMON = fusion.COMMON
_LOG_2PI = float(np.log(2.0 * np.pi))
#: W20 Table 4.3's diagonal: the probability that a filter stays the best.
W20_STAY = 0.99


def _statistic(n: int, parts):
    """Σ Hᵀ R⁻¹ H, Σ Hᵀ R⁻¹ ν, Σ νᵀ R⁻¹ ν, Σ log det R and the count per receiver over ``parts`` of measurements
    ``(rows, (ν, H, R⁻¹, log det R))``."""
    I = np.zeros((n, 2, 2))  # Σ Hᵀ R⁻¹ H
    b = np.zeros((n, 2))  # Σ Hᵀ R⁻¹ ν
    s = np.zeros(n)  # Σ νᵀ R⁻¹ ν
    logdet_r = np.zeros(n)
    count = np.zeros(n)
    for rows, (nu, H, Rinv, ld) in parts:
        HtRi = np.swapaxes(H, -1, -2) @ Rinv
        np.add.at(I, rows, HtRi @ H)
        np.add.at(b, rows, np.einsum("eab,eb->ea", HtRi, nu))
        np.add.at(s, rows, np.einsum("ea,eab,eb->e", nu, Rinv, nu))
        np.add.at(logdet_r, rows, ld)
        np.add.at(count, rows, 1.0)
    return I, b, s, logdet_r, count


def _position_solve(I: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``I⁻¹ b`` and ``sym(I⁻¹)`` by one solve."""
    sol = np.linalg.solve(I, np.concatenate([b[..., None], np.broadcast_to(np.eye(2), I.shape)], axis=-1))
    return sol[..., 0], symmetrize(sol[..., 1:])


class _Bank:
    """The filters of the UAVs ``idx`` (rows) that share one model: ``x`` (n, d), ``P`` (n, d, d); ``rows``: which
    of the swarm's filters of that model they are (in a batch of worlds, of every world's)."""

    def __init__(self, model: MotionModel, idx: np.ndarray, P0: np.ndarray, x0_hidden: np.ndarray, rows: Rows):
        self.model, self.idx, self.rows = model, idx, rows
        self.P0, self.x0_hidden = P0, x0_hidden
        self.x = np.zeros((len(idx), model.dim))
        self.P = np.broadcast_to(P0, (len(idx), model.dim, model.dim)).copy()

    def predict(self) -> None:
        """``x(k|k-1)``, ``P(k|k-1)`` (W20 eqs. 4.7-4.9)."""
        self.x, self.P = ekf_predict(self.model, self.x, self.P, self.rows)


class MultiModelEstimator:
    """W20's multi-model distributed EKF for the target labelled ``label``.

    ``models``: one motion model per UAV (any assignment); ``measurement``: a model of
    :mod:`swarmtrack.estimation.measurements`; ``fusion`` one of :data:`FUSIONS`; ``occlusion`` one of
    :data:`OCCLUSION_POLICIES`; ``window`` the T-test's n; ``markov`` the (N, N) switching matrix of the IMM kinds
    (rows sum to 1); ``P0`` per model name, (d, d); ``x0_hidden`` per model name, the initial states after
    ``[x, y]`` (zeros, CT's ω0 = 1e-5); ``compiled``: the step compiled
    (:class:`~swarmtrack.estimation.multimodel_compiled.CompiledStep`: every UAV's prediction, update and message in
    one call, the T-test in one), where it applies (models with a compiled prediction, the camera or range-bearing
    sensor), instead of this class's numpy reference; the same numbers (tests hold them equal).

    Built for a subset of the swarm's UAVs (one UAV's own process): ``models`` are theirs, ``team`` (N,) the names
    of every UAV's model (the candidates a UAV fuses and names in its view) and ``rows`` which UAVs they are; every
    row is bit for bit the whole swarm's given the same inputs. Candidates (``winner``, the columns of
    ``probability``, ``markov``) are numbered by the swarm's UAVs either way.

    A batch of B worlds (:mod:`swarmtrack.sim.batch`) is ``rows`` over ``B·N`` UAVs with ``team`` one world's N
    names: UAV ``u`` is candidate ``u mod N`` of world ``u div N``, and fuses its own world's candidates only (the
    team state, ``winner`` and ``probability``, is kept per world, numbered as in the world alone).
    """

    def __init__(self, models: list[MotionModel], measurement, *, label: int = 0, fusion_rule: str = "ttest",
                 occlusion: str = "last", window: int = 10, solo_steps: int = 100,
                 markov: np.ndarray | list | None = None,
                 P0: dict[str, np.ndarray], x0_hidden: dict[str, np.ndarray] | None = None, compiled: bool = False,
                 team: tuple[list[str], Rows] | None = None):
        if fusion_rule not in FUSIONS:
            raise ValueError(f"unknown fusion {fusion_rule!r}; expected one of {FUSIONS}")
        if occlusion not in OCCLUSION_POLICIES:
            raise ValueError(f"unknown occlusion policy {occlusion!r}; expected one of {OCCLUSION_POLICIES}")
        n = len(models)
        names = [m.name for m in models]
        self.team, self.rows = (names, Rows.all(n)) if team is None else team
        self.n, self.label, self.measurement = n, label, measurement
        self.fusion, self.occlusion, self.window, self.solo_steps = fusion_rule, occlusion, window, solo_steps
        self.model_names = self.team  # of every candidate, by the swarm's UAVs
        n_team = len(self.team)
        self._worlds = self.rows.worlds
        self._world, self._candidate = np.divmod(self.rows.uavs, n_team)  # each row's world and candidate number
        self.rho = fusion.default_markov(n_team, W20_STAY) if markov is None else np.asarray(markov, dtype=float)
        x0_hidden = x0_hidden or {}
        self._banks = []
        for name in dict.fromkeys(names):
            idx = np.flatnonzero([m == name for m in names])
            model = models[idx[0]]
            hidden = np.asarray(x0_hidden.get(name, np.zeros(model.dim - 2)), dtype=float)
            members = np.flatnonzero(np.tile(np.asarray(self.team) == name, self._worlds))  # the swarm's filters
            rows = Rows(np.searchsorted(members, self.rows.uavs[idx]), len(members), self._worlds)
            self._banks.append(_Bank(model, idx, np.asarray(P0[name], dtype=float), hidden, rows))
        self._k = 0
        self.initialised = np.zeros(n, dtype=bool)
        self._all_started = False  # every filter started (no fresh filter can come)
        self._x_pos = np.zeros((n, 2))  # each filter's predicted position, where measurements are linearised
        self._windows = np.full((n, window + 1), np.nan)  # eq. 4.24 sums n + 1 residuals
        self._loglik = np.full(n, np.nan)
        self._nis = np.full(n, np.nan)
        self._measured = np.zeros(n, dtype=bool)
        self._detected = np.zeros(n)
        self._mu = np.full((n, n_team), 1.0 / n_team)  # UAV i's probabilities of the team's filters
        self._winner = np.full(n, -1)
        self.switches = np.zeros(n, dtype=np.int64)
        self.out_x = np.full((n, COMMON), np.nan)
        self.out_P = np.full((n, COMMON, COMMON), np.nan)
        self._own = None
        self._posterior = self._common()
        self._team_motion = np.zeros((n, 3))  # the [ax, ay, ω] of the filters each UAV heard from (publish/combine)
        self._names = np.asarray([*self.team, None], dtype=object)  # each candidate's model name; [-1]: none
        self._view: TargetView | None = None  # view() of this step (publish and combine change it)
        self.probes = (Probe("estimate", (COMMON,)), Probe("covariance", (COMMON, COMMON)),
                       Probe("own_estimate", (COMMON,)), Probe("detected", ()), Probe("measured", ()),
                       Probe("nis", ()), Probe("winner", ()), Probe("switches", ()))
        if fusion_rule in ("imm-thesis", "imm"):
            self.probes += (Probe("probability", (n_team,)),)
        self._fast = CompiledStep.of(self) if compiled else None  # None: this class's numpy reference
        self.compiled = self._fast is not None

    # --- the steps the engine drives -------------------------------------------------------------------------
    def share(self, t: float, nav: np.ndarray, own) -> dict:
        """Predict every filter (W20 eqs. 4.7-4.9) and broadcast this UAV's raw measurement and pose data (after the
        first ``solo_steps`` steps; before, nobody shares)."""
        self._k += 1
        if self._fast is not None:
            self._own = self._fast.share(own)
        else:
            for bank in self._banks:
                bank.predict()
                self._x_pos[bank.idx] = bank.x[:, :2]
            self._own = self.measurement.payload(own, self.label)
        self._detected = self._own["seen"].astype(float)
        if self._sharing:
            return self._own
        return {**self._own, "seen": np.zeros(self.n, dtype=bool)}

    @property
    def _sharing(self) -> bool:
        return self._k > self.solo_steps

    def fuse(self, t: float, own, inbox) -> None:
        """Stack own and delivered measurements and update (W20 eqs. 4.3-4.4, 4.10-4.13); start filters that have
        none from their first measurement (Table 4.1)."""
        if self._fast is not None:
            self._fast.fuse(t, inbox)
            return
        mine, got = self._own, inbox.payloads
        recv, send = self._heard(inbox)
        own_rows, has, fresh = self._start_fresh(recv, send, got)
        upd = has & ~fresh
        self._loglik = np.full(self.n, np.nan)  # each step's own arrays: publish() sends them as they are
        self._nis = np.full(self.n, np.nan)
        self._measured = upd
        if upd.any():
            self._update(upd, mine, own_rows, got, recv, send, t)

    @staticmethod
    def _heard(inbox) -> tuple[np.ndarray, np.ndarray]:
        """``(receivers, senders)`` of the delivered messages that carry a measurement."""
        recv, send = inbox.edges()
        keep = inbox.payloads["seen"][send]
        return recv[keep], send[keep]

    def _start_fresh(self, recv, send, got) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Start the filters that have a measurement (their own, or delivered ``recv`` ← ``send``) for the first
        time; returns the rows that measured, which have a measurement and which started now."""
        mine = self._own
        own_rows = np.flatnonzero(mine["seen"])
        has = np.zeros(self.n, dtype=bool)
        has[own_rows] = True
        has[recv] = True
        fresh = has & ~self.initialised
        if fresh.any():
            self._start(fresh, mine, own_rows, got, recv, send)
        return own_rows, has, fresh

    def _start(self, fresh, mine, own_rows, got, recv, send) -> None:
        """``x̂0 = [h⁻¹(z0); 0]``, ``P0`` from each fresh filter's first measurement, its own before a neighbour's."""
        pos = np.full((self.n, 2), np.nan)
        nb = fresh[recv]
        first = np.unique(recv[nb], return_index=True)  # lowest-index sender of each receiver
        pos[first[0]] = self.measurement.position(got, send[nb][first[1]])
        mine_fresh = own_rows[fresh[own_rows]]
        pos[mine_fresh] = self.measurement.position(mine, mine_fresh)
        for bank in self._banks:
            rows = np.flatnonzero(fresh[bank.idx])
            if len(rows):
                bank.x[rows] = np.concatenate([pos[bank.idx[rows]], np.broadcast_to(
                    bank.x0_hidden, (len(rows), len(bank.x0_hidden)))], axis=1)
                bank.P[rows] = bank.P0
        self.initialised = self.initialised | fresh
        self._all_started = bool(self.initialised.all())

    def _update(self, upd, mine, own_rows, got, recv, send, t) -> None:
        n = self.n
        own_rows = own_rows[upd[own_rows]]
        pick = upd[recv]
        recv, send = recv[pick], send[pick]
        parts = [(own_rows, self.measurement.terms(self._x_pos[own_rows], mine, own_rows)),
                 (recv, self.measurement.terms(self._x_pos[recv], got, send))]
        I, b, s, logdet_r, count = _statistic(n, parts)
        rows = np.flatnonzero(upd)
        I, b, s, logdet_r, count = I[rows], b[rows], s[rows], logdet_r[rows], count[rows]
        # the measurements' sufficient statistic in position space: ν_pos = I⁻¹ b with covariance I⁻¹
        nu_pos, R_pos = _position_solve(I, b)
        w = self._windows = self._windows.copy()
        for bank in self._banks:
            local = np.flatnonzero(upd[bank.idx])
            if not len(local):
                continue
            at = np.searchsorted(rows, bank.idx[local])
            loglik, nis, eps = self._bank_update(bank, local, at, nu_pos, R_pos, I, b, s, logdet_r, count, t)
            uav = bank.idx[local]
            self._loglik[uav], self._nis[uav] = loglik, nis
            w[uav, :-1] = w[uav, 1:]
            w[uav, -1] = eps

    def _bank_update(self, bank, local, at, nu_pos, R_pos, I, b, s, logdet_r, count, t):
        """Update the filters ``local`` of ``bank`` from their rows ``at`` of the position-space statistic. Returns
        the stacked log-likelihood (eq. 4.31), the NIS and the per-measurement posterior residual (eq. 4.28) of
        each."""
        x, P = bank.x[local], bank.P[local]
        R_pos, nu, Ia = R_pos[at], nu_pos[at], I[at]
        S = symmetrize(P[:, :2, :2] + R_pos)  # innovation covariance Υ (eq. 4.30), position form
        K = np.swapaxes(np.linalg.solve(S, P[:, :2, :]), -1, -2)  # eq. 4.10 by a solve
        x_new = x + np.einsum("nab,nb->na", K, nu)  # eq. 4.12
        A = np.broadcast_to(np.eye(bank.model.dim), P.shape).copy()
        A[:, :, :2] -= K
        P_new = symmetrize(A @ P @ np.swapaxes(A, -1, -2) + K @ R_pos @ np.swapaxes(K, -1, -2))  # Joseph form
        self._check(bank, local, np.isfinite(x_new).all(axis=-1) & positive_definite(P_new), t)
        bank.x[local], bank.P[local] = x_new, P_new
        # ν_posᵀ S⁻¹ ν_pos and det S in closed form (2 x 2): the NIS and log N(ν_pos; 0, S)
        s00, s01, s11 = S[:, 0, 0], S[:, 0, 1], S[:, 1, 1]
        det_s = s00 * s11 - s01 * s01
        quad = (nu[:, 0] ** 2 * s11 - 2.0 * nu[:, 0] * nu[:, 1] * s01 + nu[:, 1] ** 2 * s00) / det_s
        det_i = Ia[:, 0, 0] * Ia[:, 1, 1] - Ia[:, 0, 1] * Ia[:, 1, 0]
        m = 2.0 * count[at]
        # eq. 4.31 for the stacked innovation, from its position-space statistic (see the module docstring); the
        # 2 x 2 quadratic forms written out (einsum's order of summation changes with the number of rows)
        n0, n1 = nu[:, 0], nu[:, 1]
        nin = n0 * (Ia[:, 0, 0] * n0 + Ia[:, 0, 1] * n1) + n1 * (Ia[:, 1, 0] * n0 + Ia[:, 1, 1] * n1)
        loglik = (-0.5 * quad - 0.5 * np.log(det_s) - _LOG_2PI - 0.5 * (s[at] - nin)
                  + (1.0 - 0.5 * m) * _LOG_2PI - 0.5 * np.log(det_i) - 0.5 * logdet_r[at])
        d0, d1 = x_new[:, 0] - x[:, 0], x_new[:, 1] - x[:, 1]  # ν⁺ = ν − H δ (eq. 4.28), summed in R⁻¹ weight
        ia01 = 0.5 * (Ia[:, 0, 1] + Ia[:, 1, 0])
        eps = (s[at] - 2.0 * (d0 * b[at, 0] + d1 * b[at, 1])
               + (d0 * d0 * Ia[:, 0, 0] + 2.0 * d0 * d1 * ia01 + d1 * d1 * Ia[:, 1, 1]))
        return loglik, quad, eps / count[at]

    def _check(self, bank: _Bank, local: np.ndarray, ok: np.ndarray, t: float) -> None:
        """Raise :class:`FilterDivergence` naming the UAVs, the model and the time where ``ok`` is False."""
        if ok.all():
            return
        raise FilterDivergence(self.rows.uavs[bank.idx[local[~ok]]], t, f"the {bank.model.name.upper()} filter's "
                               "covariance is not positive definite or not finite")

    def publish(self, t: float) -> dict:
        """Broadcast the posterior on ``[x, y, vx, vy]``, the likelihood and the residual window (W20 Sec. 4.3.4)."""
        self._view = None
        # what sample() records as own_estimate (before any mixing); the compiled step made them in fuse()
        x, P, motion = (*self._common(), self._motion()) if self._fast is None else self._fast.message
        self._posterior = x, P
        self._team_motion = self.rows.widen(motion)  # by the swarm's UAVs, as the view reads it
        if not self._sharing or self.fusion == "none":
            self.out_x, self.out_P = x, P
            self._winner = np.where(self.initialised, self._candidate, -1)
            return {}
        return {"x": x, "P": P, "loglik": self._loglik, "measured": self._measured, "started": self.initialised,
                "window": self._windows, "motion": motion}

    def _common(self) -> tuple[np.ndarray, np.ndarray]:
        x = np.full((self.n, COMMON), np.nan)
        P = np.full((self.n, COMMON, COMMON), np.nan)
        for bank in self._banks:
            ok = self.initialised[bank.idx]
            x[bank.idx[ok]] = bank.x[ok, :COMMON]
            P[bank.idx[ok]] = bank.P[ok, :COMMON, :COMMON]
        return x, P

    def _motion(self) -> np.ndarray:
        """(N, 3) each filter's states beyond ``[x, y, vx, vy]`` as ``[ax, ay, ω]`` (CA: ax, ay; CT: ω; else 0)."""
        out = np.zeros((self.n, 3))
        for bank in self._banks:
            cols = {"ca": [0, 1], "ct": [2]}.get(bank.model.name)
            if cols:
                out[np.ix_(bank.idx, cols)] = bank.x[:, COMMON:COMMON + len(cols)]
        return out

    def combine(self, t: float, inbox) -> None:
        """Fuse the candidates each UAV received (itself and the neighbours whose messages arrived) into its output."""
        self._view = None
        got = inbox.payloads
        self._team_motion = got["motion"]
        if self._fast is not None and self.fusion == "ttest":
            self._fast.combine_ttest(inbox)
            return
        n, n_team, own = self.n, len(self.team), self._candidate
        recv, send = inbox.edges()
        valid = np.zeros((n, n_team), dtype=bool)
        valid[recv, send % n_team] = got["started"][send]
        valid[np.arange(n), own] = self.initialised
        X, P = self._candidates(got["x"]), self._candidates(got["P"])
        evidence = valid & self._candidates(got["measured"])
        if self.fusion == "ttest":
            winner = self._select(valid, evidence, got)
            self._set_output(winner, got["x"], got["P"])
            return
        if self.fusion == "ml":
            live = np.flatnonzero(self.initialised)
            self.out_x[live], self.out_P[live] = fusion.ml_fuse(X[live], P[live], valid[live], own[live])
            self._note(np.where(self.initialised, own, -1))
            return
        # IMM: probabilities (eqs. 4.32-4.34), combination (4.35); with mixing, each filter restarts from its mix
        mu_pred = fusion.imm_predict(self._mu, self.rho, self.rows.matmul)
        loglik = self._candidates(got["loglik"])
        self._mu = fusion.imm_update(mu_pred, loglik, evidence)
        live = np.flatnonzero(self.initialised)
        w = np.where(valid, self._mu, 0.0)
        self.out_x[live], self.out_P[live] = fusion.moment_combine(w[live], X[live], P[live])
        self._note(np.where(self.initialised, np.argmax(w, axis=1), -1))
        if self.fusion == "imm":
            self._mix(valid, X, P)

    def _candidates(self, a: np.ndarray) -> np.ndarray:
        """(n, N, ...) per row, what its world's N candidates sent, from ``a`` (rows.n, ...) by the swarm's UAVs."""
        if self._worlds == 1:
            return np.broadcast_to(a, (self.n, *a.shape))
        return a.reshape(self._worlds, -1, *a.shape[1:])[self._world]

    def _sender(self, candidate: np.ndarray) -> np.ndarray:
        """The swarm's UAV that is candidate ``candidate`` (per row) of each row's world."""
        return candidate if self._worlds == 1 else self._world * len(self.team) + candidate

    def _select(self, valid, evidence, got) -> np.ndarray:
        """T-test winner (eqs. 4.23-4.28); where no candidate measured this step, the occlusion policy (4.38-4.40)."""
        score = self._candidates(fusion.window_score(got["window"]))
        winner = fusion.ttest_select(score, valid)
        occluded = self.initialised & ~evidence.any(axis=1)
        if occluded.any():
            rows = np.flatnonzero(occluded)
            if self.occlusion == "last":
                last = self._winner[rows]
                keep = (last >= 0) & valid[rows, np.maximum(last, 0)]
                winner[rows[keep]] = last[keep]
            else:
                Ppos = self._candidates(got["P"][:, :2, :2])[rows]
                pick = fusion.select_least_trace if self.occlusion == "trace" else fusion.select_least_max_eigenvalue
                winner[rows] = pick(Ppos, valid[rows])
        return winner

    def _note(self, winner: np.ndarray) -> None:
        """The filter each UAV's output uses now (T-test winner, most probable filter, or its own), and the count
        of changes (W20 Fig. 4.9)."""
        self.switches += (winner >= 0) & (self._winner >= 0) & (winner != self._winner)
        self._winner = winner

    def _set_output(self, winner: np.ndarray, x: np.ndarray, P: np.ndarray) -> None:
        self._note(winner)
        ok = winner >= 0
        sender = self._sender(np.maximum(winner, 0))
        self.out_x = np.where(ok[:, None], x[sender], np.nan)
        self.out_P = np.where(ok[:, None, None], P[sender], np.nan)

    def _mix(self, valid, X, P) -> None:
        """Standard IMM interaction: each UAV's filter restarts from the mix of the team's posteriors on the common
        states, the states its model adds carried by their conditional on them (:func:`fusion.extend_to_model`)."""
        x0, P0, _ = fusion.imm_mix(self._mu, self.rho, X, P, valid, matmul=self.rows.matmul)
        rows = np.arange(self.n)
        x0, P0 = x0[rows, self._candidate], P0[rows, self._candidate]  # UAV i mixes for its own filter only
        for bank in self._banks:
            rows = np.flatnonzero(self.initialised[bank.idx])
            if len(rows):
                uav = bank.idx[rows]
                bank.x[rows], bank.P[rows] = fusion.extend_to_model(bank.x[rows], bank.P[rows], x0[uav], P0[uav])

    # --- what controllers, the gimbal and the recorder read ------------------------------------------------------
    def view(self) -> TargetView:
        """Each UAV's output estimate ``[x, y, vx, vy]`` (NaN before its filter started), with the model and the
        extra states of the filter it uses now (T-test winner, most probable filter, or its own)."""
        if self._view is None:
            ok = self._winner >= 0
            motion = self._team_motion[self._sender(np.maximum(self._winner, 0))]
            self._view = TargetView(self.out_x, model=self._names[self._winner],
                                    motion=np.where(ok[:, None], motion, 0.0))
        return self._view

    def sample(self) -> dict[str, np.ndarray]:
        own = self._posterior[0]
        out = {"estimate": self.out_x, "covariance": self.out_P, "own_estimate": own, "detected": self._detected,
               "measured": self._measured.astype(float), "nis": self._nis, "winner": self._winner + 1.0,
               "switches": self.switches.astype(float)}
        if self.fusion in ("imm-thesis", "imm"):
            out["probability"] = self._mu
        return out
