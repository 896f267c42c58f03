"""IMM over information filters of different sizes: every UAV runs a bank of M information-form EKFs, one per
target model, with IMM interaction through the states every model shares (L24's future work, Sec. 6).

Each estimation step, for all N UAVs at once (a loop over the M models only):

1. **Interaction** (standard IMM, Bar-Shalom): the models' posteriors are mixed on the common block
   ``[x, y, vx, vy]`` (a 3-D bank's ``[x, y, vx, vy, z, vz]``, :mod:`swarmtrack.models.three_d`;
   :func:`fusion.imm_mix`, weights ``μ_{i|j} = ρ_ij μ_i / c̄_j``). The mixed common block then
   enters model j by :func:`fusion.extend_to_model`: the states model j adds beyond the common block (CT's ω, FS's
   vz, attitude, rates, moments and thrust) are **carried by their conditional on the common block** in model j's
   own posterior, ``x_e ← x_e + G (x0_c − x_c)``, ``G = P_ec P_cc⁻¹``, with the Schur complement
   ``P_ee − G P_ce`` kept, so the mixed covariance stays positive definite. A bigger model contributes to a
   smaller one through its common block only (its extra states are marginalised out). The interaction is the
   identity with one model or an identity Markov matrix, and is then skipped (bit-for-bit the single filters).
2. **Prediction** of every bank member in information form from its mixed prior (:func:`information.predict`).
3. **Measurement information** (L24 eqs. 6-7), exactly as :class:`~swarmtrack.estimation.information
   .InformationEstimator`: the UAV's own range-bearing measurement and what its neighbours send, in the
   position block. ``share: information``: a UAV broadcasts ONE contribution ``(I_i, i_i)``, linearised at its
   combined prediction (the ``μ(k|k−1)``-weighted mean of its bank's predicted positions), and every member of a
   receiver's bank adds the same sum: one message per UAV, as in L24, and the bank members see the same evidence.
   ``share: measurements``: a UAV broadcasts its raw measurement and position, and each bank member linearises
   every received measurement at its own prediction (the filters are then exactly M single-model filters fed the
   same measurements). With the ``position`` update the linearisation point enters only through the converted
   measurement's covariance, so the two agree closely.
4. **Mode probabilities**: each member's likelihood is that of the fused measurements' position-space statistic
   ``z = I⁻¹ i`` (covariance ``I⁻¹``) against its prediction, ``log N(z − x̂⁻[pos]; 0, P⁻[pos, pos] + I⁻¹)``
   (:func:`fusion.log_gaussian`); :func:`fusion.imm_update` (log space) gives ``μ``. A UAV that received no
   measurement keeps ``μ(k|k−1)``. L24's fake ``vz = 0`` measurement of the FS member is its own prior on a
   state the other models lack and is left out of the likelihood.
5. **Output**: :func:`fusion.moment_combine` of the members' common blocks with ``μ``; this is what
   :meth:`view`, the controller and the ``estimate``/``covariance`` probes read.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.estimation import fusion
from swarmtrack.estimation.base import Probe, TargetView
from swarmtrack.estimation.information import (
    FilterDivergence,
    RangeBearingUpdate,
    _inv2,
    add_position_information,
    check_information,
    initial_information,
    predict,
    recover,
    symmetrize,
)
from swarmtrack.estimation.information import position_block as block
from swarmtrack.estimation.predict_kernels import (
    has_kernel,
    model_params,
    position_block,
    position_loglik,
    predict_bank,
)
from swarmtrack.models.base import MotionModel
from swarmtrack.models.three_d import COMMON_3D
from swarmtrack.network.rows import Rows

COMMON = fusion.COMMON
#: The probability that the target keeps its motion model from one step to the next (chosen: 0.98).
STAY = 0.98


class IMMInformationEstimator:
    """A bank of information filters per UAV, one per model in ``models``, combined by an IMM (module docstring).

    ``markov`` (M, M): ``markov[i, j]`` is the probability of switching from model i to model j (rows sum to 1);
    default: ``STAY`` on the diagonal (:func:`fusion.default_markov`). ``share``, ``initial_info`` and
    ``fake_vz_sigma`` as in :class:`~swarmtrack.estimation.information.InformationEstimator`; ``n_uavs`` rows, the
    swarm's UAVs ``rows`` (default: a whole swarm of ``n_uavs``), each bit for bit the whole swarm's given the same
    inputs (:mod:`swarmtrack.network.rows`). ``compiled``: the members' predictions by the numba kernels of
    :mod:`swarmtrack.estimation.predict_kernels` (the same numbers as the numpy reference).
    """

    def __init__(self, models: list[MotionModel], update: RangeBearingUpdate, n_uavs: int, *, label: int = 0,
                 share: str = "information", markov=None, initial_info: float = 1e-6,
                 fake_vz_sigma: float | None = None, rows: Rows | None = None, compiled: bool = False):
        if share not in ("information", "measurements"):
            raise ValueError(f"unknown share mode {share!r}; expected 'information' or 'measurements'")
        M = len(models)
        if M < 1:
            raise ValueError("an IMM needs at least one model")
        rho = fusion.default_markov(M, STAY) if markov is None else np.asarray(markov, dtype=float)
        if rho.shape != (M, M) or not np.isfinite(rho).all() or (rho < 0).any() \
                or not np.allclose(rho.sum(axis=1), 1.0, atol=1e-9):
            raise ValueError(f"markov must be {M} x {M}, non-negative, with rows summing to 1; got {rho.tolist()}")
        self.models, self.rho, self.update_rule, self.share_mode = tuple(models), rho, update, share
        self.index = update.index  # the position states the update observes
        self.common = COMMON_3D if update.dim == 3 else COMMON  # the block every model shares
        self.n, self.label = n_uavs, label
        self.rows = Rows.all(n_uavs) if rows is None else rows
        self._mixing = M > 1 and not np.array_equal(rho, np.eye(M))
        self.compiled = compiled
        self._kernels = [(*model_params(m), np.ascontiguousarray(m.Q, dtype=float))
                         if compiled and has_kernel(m) else None for m in models]
        self.x, self.P = [], []  # per model: (N, n_m), (N, n_m, n_m)
        for model in models:
            x, P = recover(*initial_information(model, n_uavs, initial_info))
            self.x.append(x)
            self.P.append(P)
        self._vz = [(m.VZ_INDEX, 1.0 / fake_vz_sigma**2)
                    if fake_vz_sigma is not None and hasattr(m, "VZ_INDEX") else None for m in models]
        self.mu = np.full((n_uavs, M), 1.0 / M)
        self._mu_pred = self.mu
        self._pred = None  # per model (Y, y, x_pred, predicted position covariance)
        self._own = None
        self._detected = np.zeros(n_uavs)
        self._nis = np.full(n_uavs, np.nan)
        self.loglik = np.full((n_uavs, M), np.nan)
        self.out_x, self.out_P = self._combined()
        self.probes = (Probe("estimate", (self.common,)), Probe("covariance", (self.common, self.common)),
                       Probe("probability", (M,)), Probe("detected", ()), Probe("nis", ()))

    # --- the steps the engine drives -------------------------------------------------------------------------
    def share(self, t: float, nav: np.ndarray, own) -> dict:
        """Interaction, prediction of every bank member, and this UAV's broadcast (module docstring, 1-3)."""
        z, pos, seen = own.of_label(self.label)
        x0, P0, self._mu_pred = self._mix()
        self._pred = [self._predict(m, x, P) for m, x, P in zip(range(len(self.models)), x0, P0, strict=True)]
        positions = np.stack([p[2][:, self.index] for p in self._pred], axis=1)
        xbar, Pbar = fusion.moment_combine(self._mu_pred, positions, np.stack([p[3] for p in self._pred], axis=1))
        u = self.update_rule
        I, i = u.contributions(xbar, pos, z)
        self._nis = _position_nis(u.to_position(z, pos) - xbar, Pbar, I) if u.dim == 2 else \
            u.nis(u.to_position(z, pos), I, xbar, Pbar)
        if not seen.all():  # unseen rows are NaN
            I[~seen] = 0.0
            i[~seen] = 0.0
        self._own = {"info_matrix": I, "info_vector": i, "z": z, "sensor_pos": pos, "seen": seen}
        self._detected = seen.astype(float)
        return self._own if self.share_mode == "information" else {"z": z, "sensor_pos": pos, "seen": seen}

    def fuse(self, t: float, own, inbox) -> None:
        """Every member's update (L24 eq. 7), the likelihoods, the mode probabilities and the output (4-5)."""
        if self.share_mode == "information":
            I = self._own["info_matrix"] + inbox.sum("info_matrix")
            i = self._own["info_vector"] + inbox.sum("info_vector")
        else:
            got = inbox.payloads
            recv, send = inbox.heard()  # own measurement first
        M = len(self.models)
        loglik = np.full((self.n, M), np.nan)
        for m, (model, (Y, y, x_pred, P_pos)) in enumerate(zip(self.models, self._pred, strict=True)):
            if self.share_mode == "measurements":  # each member linearises at its own prediction
                d = self.update_rule.dim
                Ip, ip = self.update_rule.contributions(x_pred[recv][:, self.index], got["sensor_pos"][send],
                                                        got["z"][send])
                I, i = np.zeros((self.n, d, d)), np.zeros((self.n, d))
                np.add.at(I, recv, Ip)
                np.add.at(i, recv, ip)
            Y, y = add_position_information(Y, y, I, i, self.index)
            if self._vz[m] is not None:  # L24's fake vz = 0 measurement, local to the FS member
                k, w_vz = self._vz[m]
                Y[:, k, k] += w_vz
            try:
                check_information(Y, y, t)
            except FilterDivergence as e:
                what = str(e).split(": ", 1)[-1]
                raise FilterDivergence(e.agents, t, f"the {model.name.upper()} model's filter: {what}") from None
            self.x[m], self.P[m] = recover(Y, y)
            x_pos = x_pred[:, self.index]
            loglik[:, m] = _position_loglik_nd(I, i, x_pos, P_pos) if self.update_rule.dim != 2 else \
                (position_loglik if self.compiled else _position_loglik)(I, i, x_pos, P_pos)
        self.loglik = loglik
        self.mu = fusion.imm_update(self._mu_pred, loglik, ~np.isnan(loglik))
        self.out_x, self.out_P = self._combined()

    # --- the IMM's pieces -----------------------------------------------------------------------------------
    def _predict(self, m: int, x: np.ndarray, P: np.ndarray):
        """Member m's prediction in information form and its predicted position covariance ``(Y, y, x_pred,
        P_pos)``: the compiled kernels (:mod:`swarmtrack.estimation.predict_kernels`, then numpy's solve) or the
        numpy reference (:func:`~swarmtrack.estimation.information.predict`), the same numbers."""
        model, kernel = self.models[m], self._kernels[m]
        if kernel is None:
            Y, y, x_pred = predict(model, x, P, self.rows)
            F2 = model.F[self.index] if getattr(model, "linear", False) else model.jacobian(x)[..., self.index, :]
            P_pos = symmetrize(F2 @ P @ np.swapaxes(F2, -1, -2) + model.Q[block(self.index)])
            return Y, y, x_pred, P_pos
        kind, params, F_lin, Q = kernel
        x_pred, F, P_pred = predict_bank(kind, params, F_lin, x, P, Q, self.rows.n // self.rows.worlds)
        n = model.dim
        sol = np.linalg.solve(P_pred, np.concatenate(
            [x_pred[..., None], np.broadcast_to(np.eye(n), P_pred.shape)], axis=-1))  # as predict() solves
        return symmetrize(sol[..., 1:]), sol[..., 0], x_pred, position_block(F, P, Q)

    def _mix(self):
        """Mixed priors of every member (module docstring, 1) and ``μ(k|k−1)``."""
        if not self._mixing:
            return self.x, self.P, fusion.imm_predict(self.mu, self.rho, self.rows.matmul)
        c = self.common
        xc = np.stack([x[:, :c] for x in self.x], axis=1)
        Pc = np.stack([P[:, :c, :c] for P in self.P], axis=1)
        x0c, P0c, mu_pred = fusion.imm_mix(self.mu, self.rho, xc, Pc, matmul=self.rows.matmul)
        x0, P0 = [], []
        for m in range(len(self.models)):
            xm, Pm = fusion.extend_to_model(self.x[m], self.P[m], x0c[:, m], P0c[:, m])
            x0.append(xm)
            P0.append(Pm)
        return x0, P0, mu_pred

    def _combined(self):
        c = self.common
        return fusion.moment_combine(self.mu, np.stack([x[:, :c] for x in self.x], axis=1),
                                     np.stack([P[:, :c, :c] for P in self.P], axis=1))

    def members(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Every bank member's posterior ``(x (N, n_m), P (N, n_m, n_m))``, in model order."""
        return list(zip(self.x, self.P, strict=True))

    # --- what controllers and the recorder read ---------------------------------------------------------------
    def view(self) -> TargetView:
        return TargetView(self.out_x)

    def sample(self) -> dict[str, np.ndarray]:
        return {"estimate": self.out_x, "covariance": self.out_P, "probability": self.mu,
                "detected": self._detected, "nis": self._nis}


def _position_loglik(I: np.ndarray, i: np.ndarray, x_pos: np.ndarray, P_pos: np.ndarray) -> np.ndarray:
    """``log N(I⁻¹ i − x̂⁻[:2]; 0, P⁻[:2, :2] + I⁻¹)`` per UAV; NaN where no measurement arrived (``I`` singular)."""
    det = I[..., 0, 0] * I[..., 1, 1] - I[..., 0, 1] * I[..., 1, 0]
    have = det > 0
    R = _inv2(np.where(have[:, None, None], I, np.eye(2)))
    nu = np.einsum("nab,nb->na", R, i) - x_pos
    out = fusion.log_gaussian(nu, symmetrize(P_pos + R))
    return np.where(have, out, np.nan)


def _position_loglik_nd(I: np.ndarray, i: np.ndarray, x_pos: np.ndarray, P_pos: np.ndarray) -> np.ndarray:
    """:func:`_position_loglik` for a position of any dimension (a 3-D update's): ``I⁻¹`` by a solve where ``I`` is
    positive definite, NaN elsewhere (no measurement arrived)."""
    d = I.shape[-1]
    eig = np.linalg.eigvalsh(I)
    have = eig[..., 0] > 1e-12 * np.maximum(eig[..., -1], 1e-300)
    R = np.linalg.solve(np.where(have[:, None, None], I, np.eye(d)), np.broadcast_to(np.eye(d), I.shape))
    nu = np.einsum("nab,nb->na", R, i) - x_pos
    out = fusion.log_gaussian(nu, symmetrize(P_pos + symmetrize(R)))
    return np.where(have, out, np.nan)


def _position_nis(nu: np.ndarray, P_pos: np.ndarray, I: np.ndarray) -> np.ndarray:
    """``νᵀ (I⁻¹ + P⁻[:2, :2])⁻¹ ν`` of each UAV's own measurement (NaN where it saw nothing)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        S = _inv2(I) + P_pos
        s00, s01, s11 = S[..., 0, 0], S[..., 0, 1], S[..., 1, 1]
        n0, n1 = nu[..., 0], nu[..., 1]
        return (n0 * n0 * s11 - 2.0 * n0 * n1 * s01 + n1 * n1 * s00) / (s00 * s11 - s01 * s01)
