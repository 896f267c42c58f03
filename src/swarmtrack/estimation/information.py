"""Extended Kalman filter in information form, batched over agents (L24 Sec. 3, eqs. 4-7; L23 eqs. 11-18).

State of a bank of filters: information matrix ``Y = P⁻¹`` (..., n, n) and information vector ``y = P⁻¹ x``
(..., n). The sensors of this project observe the target's planar position (the first two states of every
model), so a measurement's information is a 2 x 2 block ``I`` and a 2-vector ``i`` added to the top-left of
``Y`` and ``y``; contributions are kept in that compact form and fused by plain sums (L24 eq. 7).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.estimation.base import Probe, TargetView
from swarmtrack.models.base import MotionModel
from swarmtrack.sensors.range_bearing import polar_model, position_covariance, to_position, wrap_angle

UPDATES = ("position", "polar")
#: Models with a compiled cycle in :mod:`swarmtrack.estimation.kernels` (with the ``position`` update).
COMPILED_MODELS = ("cv", "fs")


class FilterDivergence(RuntimeError):
    """An information filter lost positive definiteness or produced non-finite numbers."""

    def __init__(self, agents: np.ndarray, t: float, what: str):
        self.agents = [int(a) for a in np.atleast_1d(agents)]
        self.t = float(t)
        names = ", ".join(f"UAV {a + 1}" for a in self.agents)
        super().__init__(f"estimator diverged at t = {t:.2f} s on {names}: {what}")


@dataclass(frozen=True)
class RangeBearingUpdate:
    """How a range-bearing measurement enters the filter.

    ``position``: converted to the position it implies, with the paper's covariance
    ``R_i = Λ diag(σr², ρ̂²σβ²) Λᵀ`` evaluated at the predicted range and bearing (L24 Sec. 4, L23 eq. 20).
    ``polar``: the EKF update on ``[ρ, β]`` with ``R = diag(σr², σβ²)`` and wrapped bearing innovation
    (L24 eq. 6). The two agree to first order.
    """

    sigma_range: float
    sigma_bearing: float
    mode: str = "position"
    min_range: float = 0.05
    #: The std (m, per axis) of the UAV's own navigation position, which the measurement is taken from: added to
    #: the converted measurement's covariance (``R + σ²I``) and, to first order, to the polar one
    #: (``diag(σr² + σ², σβ² + σ²/ρ̂²)``, since the rows of ``H`` are orthogonal with norms 1 and 1/ρ̂).
    own_sigma: float = 0.0

    def contributions(self, x_pos: np.ndarray, sensor_pos: np.ndarray, z: np.ndarray):
        """Local measurement information ``(I, i)`` (L24 eq. 6), restricted to the position block.

        ``x_pos`` is the predicted target position each contribution is linearised at, ``sensor_pos`` the
        measuring UAV's own navigation position, ``z = [range, bearing]``; all broadcast together.
        Returns ``I (..., 2, 2)`` and ``i (..., 2)``.
        """
        rel = x_pos - sensor_pos
        if self.mode == "position":
            rho = np.maximum(np.hypot(rel[..., 0], rel[..., 1]), self.min_range)
            beta = np.arctan2(rel[..., 1], rel[..., 0])
            R = position_covariance(rho, beta, self.sigma_range, self.sigma_bearing)
            if self.own_sigma:
                R[..., 0, 0] += self.own_sigma**2
                R[..., 1, 1] += self.own_sigma**2
            I = _inv2(R)
            i = np.einsum("...ab,...b->...a", I, to_position(z, sensor_pos))
            return I, i
        h, H = polar_model(x_pos, sensor_pos, min_range=self.min_range)
        nu = z - h
        nu[..., 1] = wrap_angle(nu[..., 1])
        own = self.own_sigma**2
        rho2 = np.maximum(np.sum(rel * rel, axis=-1), self.min_range**2)
        w = np.stack(np.broadcast_arrays(1.0 / (self.sigma_range**2 + own), 1.0 / (self.sigma_bearing**2 + own / rho2)),
                     axis=-1)
        HtW = np.swapaxes(H, -1, -2) * w[..., None, :]
        I = HtW @ H
        i = np.einsum("...ab,...b->...a", HtW, nu + np.einsum("...ab,...b->...a", H, x_pos))
        return I, i


def _inv2(R: np.ndarray) -> np.ndarray:
    """Closed-form inverse of symmetric 2 x 2 blocks (well conditioned here: R is SPD by construction)."""
    a, b, d = R[..., 0, 0], R[..., 0, 1], R[..., 1, 1]
    det = a * d - b * b
    out = np.empty_like(R)
    out[..., 0, 0] = d / det
    out[..., 1, 1] = a / det
    out[..., 0, 1] = out[..., 1, 0] = -b / det
    return out


def position_nis(q: np.ndarray, I: np.ndarray, x_pos: np.ndarray, P_pos: np.ndarray) -> np.ndarray:
    """``νᵀ S⁻¹ ν`` (...,) of position measurements ``q`` (..., 2) with information ``I`` (..., 2, 2) against a
    predicted position ``x_pos`` with covariance ``P_pos``: ``ν = q − x_pos``, ``S = I⁻¹ + P_pos`` (χ²(2) when
    consistent). Closed-form 2 x 2 algebra: it runs every step for every UAV and link."""
    a, b, d = I[..., 0, 0], I[..., 0, 1], I[..., 1, 1]
    det_i = a * d - b * b
    s00 = d / det_i + P_pos[..., 0, 0]
    s01 = -b / det_i + P_pos[..., 0, 1]
    s11 = a / det_i + P_pos[..., 1, 1]
    nu = q - x_pos
    n0, n1 = nu[..., 0], nu[..., 1]
    return (n0 * n0 * s11 - 2.0 * n0 * n1 * s01 + n1 * n1 * s00) / (s00 * s11 - s01 * s01)


def symmetrize(M: np.ndarray) -> np.ndarray:
    return 0.5 * (M + np.swapaxes(M, -1, -2))


def initial_information(model: MotionModel, n_filters: int, information: float = 1e-6):
    """Near-zero initial information (no prior, L24 Sec. 3.1): ``Y = εI`` on ``[x, y, vx, vy]``, a weak
    prior on the model's hidden states (:meth:`MotionModel.initial_information_diagonal`), ``y = Y x0``."""
    Y = np.broadcast_to(np.diag(model.initial_information_diagonal(information)),
                        (n_filters, model.dim, model.dim)).copy()
    y = Y @ model.initial_state()
    return Y, y


def recover(Y: np.ndarray, y: np.ndarray):
    """State and covariance from information, by solving ``Y [x P] = [y I]`` (inverse of L24 eq. 4)."""
    n = Y.shape[-1]
    rhs = np.concatenate([y[..., None], np.broadcast_to(np.eye(n), Y.shape)], axis=-1)
    sol = np.linalg.solve(Y, rhs)
    return sol[..., 0], symmetrize(sol[..., 1:])


def predict(model: MotionModel, x: np.ndarray, P: np.ndarray):
    """Prediction in information form from the posterior moments (L24 Sec. 3.1; linear case: ``∇f = F``).

    ``Y(k|k-1) = (∇f P ∇fᵀ + Q)⁻¹`` and ``y(k|k-1) = Y(k|k-1) f(x)``, both from one solve against
    ``P(k|k-1)``. ``x, P`` come from :func:`recover`. Returns ``Y_pred, y_pred, x_pred``.
    """
    F = model.jacobian(x)
    x_pred = model.f(x)
    P_pred = symmetrize(F @ P @ np.swapaxes(F, -1, -2) + model.Q)
    n = model.dim
    sol = np.linalg.solve(P_pred, np.concatenate(
        [x_pred[..., None], np.broadcast_to(np.eye(n), P_pred.shape)], axis=-1))
    return symmetrize(sol[..., 1:]), sol[..., 0], x_pred


def add_position_information(Y: np.ndarray, y: np.ndarray, I: np.ndarray, i: np.ndarray):
    """Update (L24 eq. 7) with fused position-block information; returns new arrays."""
    Y = Y.copy()
    y = y.copy()
    Y[..., :2, :2] += I
    y[..., :2] += i
    return Y, y


def positive_definite(M: np.ndarray) -> np.ndarray:
    """(...,) whether each symmetric matrix of ``M`` (..., n, n) is finite and positive definite (one batched
    Cholesky; the eigenvalues only when it fails, to find which)."""
    good = np.isfinite(M).all(axis=(-1, -2))
    M = np.where(good[..., None, None], M, np.eye(M.shape[-1]))
    try:
        np.linalg.cholesky(M)
        return good
    except np.linalg.LinAlgError:
        return good & (np.linalg.eigvalsh(M)[..., 0] > 0.0)


def check_information(Y: np.ndarray, y: np.ndarray, t: float) -> None:
    """Raise :class:`FilterDivergence` naming the agents whose information is non-finite or not PD."""
    finite = np.isfinite(Y).all(axis=(-1, -2)) & np.isfinite(y).all(axis=-1)
    if not finite.all():
        raise FilterDivergence(np.flatnonzero(~finite), t, "non-finite information")
    pd = positive_definite(Y)
    if not pd.all():
        raise FilterDivergence(np.flatnonzero(~pd), t, "information matrix is not positive definite")


class InformationEstimator:
    """One information-form EKF per UAV (L24 Sec. 3) or, with ``centralized``, a single fusion centre over every
    UAV's measurement (the baseline). Follows the object its sensor labels ``label``.

    ``share: information``: each UAV broadcasts its own contribution ``I_i, i_i`` (L24 eq. 6) and adds what its
    links deliver (eq. 7). ``share: measurements``: each UAV broadcasts its raw measurement and the position it
    was taken from, and linearises every received one at its own prediction. ``compiled``: the numba kernels
    (:mod:`swarmtrack.estimation.kernels`, same numbers as the numpy reference) for the CV and FS models with the
    position update.
    """

    def __init__(self, model: MotionModel, update: RangeBearingUpdate, n_uavs: int, *, label: int = 0,
                 share: str = "information", centralized: bool = False, initial_info: float = 1e-6,
                 fake_vz_sigma: float | None = None, compiled: bool = False, gating: str = "none",
                 gate_probability: float = 0.999):
        self.model, self.update_rule, self.share_mode, self.centralized = model, update, share, centralized
        self.gating, self.gate_probability = gating, gate_probability
        self.n, self.label = n_uavs, label
        n_filters = 1 if centralized else n_uavs
        Y, y = initial_information(model, n_filters, initial_info)
        self.x, self.P = recover(Y, y)
        self.compiled = compiled and model.name in COMPILED_MODELS and update.mode == "position" and \
            not centralized and gating != "ci"
        if self.compiled:
            self._Y, self._y, self._q = Y, y, np.ascontiguousarray(np.diag(model.Q))
        self._x_pred = self.x
        self._Y_pred, self._y_pred = Y, y
        self._vz = None
        if fake_vz_sigma is not None and hasattr(model, "VZ_INDEX"):
            self._vz = (model.VZ_INDEX, 1.0 / fake_vz_sigma**2)
        self._own = None
        self._detected = np.zeros(n_uavs)
        self._nis = np.full(n_uavs, np.nan)
        # the rows of F that predict the position, for the NIS: constant for the linear models and for FS (whose
        # position rows are x' = x + dt·vx, y' = y + dt·vy); CT's depend on the state
        self._F2 = model.F[:2] if getattr(model, "linear", False) else \
            model.jacobian(model.initial_state())[:2] if model.name == "fs" else None
        self._Q2 = model.Q[:2, :2]
        self.probes = (Probe("estimate", (model.dim,)), Probe("covariance", (model.dim, model.dim)),
                       Probe("detected", ()), Probe("nis", ()))
        self._gated = np.zeros(n_uavs)
        self._rejected = np.zeros(n_uavs)
        self._delivered = np.zeros(n_uavs)
        self._threshold = -2.0 * np.log1p(-gate_probability)  # the χ²(2) quantile (χ²(2) is exponential, mean 2)
        if gating == "chi2":  # whom each UAV gated: how many it left out, how many left each one's out, of how many
            self.probes += (Probe("gated", ()), Probe("rejected", ()), Probe("delivered", ()))

    def share(self, t: float, nav: np.ndarray, own) -> dict:
        """Predict (L24 Sec. 3.1) and compute this UAV's own contribution (L24 eq. 6) for broadcast; a UAV that
        did not detect its target contributes zero information."""
        self._reset_gate_counts()
        z, pos, seen = own.of_label(self.label)
        if self.compiled:
            from swarmtrack.estimation import kernels

            self._x_pred = kernels.cv_predicted_position(self.x, self.model.dt)
            u = self.update_rule
            I, i = kernels.cv_position_contributions(self._x_pred, pos, z, u.sigma_range, u.sigma_bearing,
                                                     u.min_range, u.own_sigma**2)
            self._nis = kernels.position_nis(z, pos, self._x_pred[:, :2], self.P, self._F2, self._Q2, I)
            self._own = self._contribution(I, i, z, pos, seen)
        else:
            self._Y_pred, self._y_pred, self._x_pred = predict(self.model, self.x, self.P)
            self._own = self._measured(z, pos, seen, self.x, self.P, self._x_pred)
        return self._own if self.share_mode == "information" or self.centralized else {
            "z": z, "sensor_pos": pos, "seen": seen}

    def _measured(self, z: np.ndarray, pos: np.ndarray, seen: np.ndarray, x: np.ndarray, P: np.ndarray,
                  x_pred: np.ndarray) -> dict:
        """Each UAV's own contribution (L24 eq. 6) linearised at ``x_pred``, predicted from the posterior ``x, P``
        (the fusion centre linearises every measurement at its one prediction), and its NIS."""
        x_pos = np.broadcast_to(x_pred[:, :2], pos.shape) if self.centralized else x_pred[:, :2]
        I, i = self.update_rule.contributions(x_pos, pos, z)
        self._nis = self._own_nis(z, pos, I, x, P, x_pred)
        return self._contribution(I, i, z, pos, seen)

    def _contribution(self, I, i, z, pos, seen) -> dict:
        """The outbox row of each UAV: zero information and a NaN NIS where it saw nothing."""
        if not seen.all():  # unseen rows are NaN
            I[~seen] = 0.0
            i[~seen] = 0.0
            self._nis[~seen] = np.nan
        self._detected = seen.astype(float)
        return {"info_matrix": I, "info_vector": i, "z": z, "sensor_pos": pos, "seen": seen}

    def predicted_position_covariance(self, x: np.ndarray, P: np.ndarray) -> np.ndarray:
        """Position block (..., 2, 2) of ``P(k|k−1) = F P Fᵀ + Q`` predicted from the posterior ``x, P``."""
        F = self._F2 if self._F2 is not None else self.model.jacobian(x)[..., :2, :]
        return F @ P @ np.swapaxes(F, -1, -2) + self._Q2

    def _own_nis(self, z: np.ndarray, pos: np.ndarray, I: np.ndarray, x: np.ndarray, P: np.ndarray,
                 x_pred: np.ndarray) -> np.ndarray:
        """Normalised innovation squared of each UAV's own measurement (N,), in position form whatever the update:
        ``ν = q(z) − x̂(k|k−1)[:2]``, ``S = I⁻¹ + P(k|k−1)[:2, :2]`` with ``I`` the measurement's position-block
        information (``R⁻¹`` of the converted measurement; ``HᵀR⁻¹H`` of the polar one, equal to first order),
        predicted from the posterior ``x, P`` to ``x_pred``. χ²(2) for a consistent filter; NaN where the UAV saw
        nothing."""
        return position_nis(to_position(z, pos), I, x_pred[..., :2], self.predicted_position_covariance(x, P))

    def fuse(self, t: float, own, inbox) -> None:
        """Update (L24 eq. 7): own information plus what the links delivered."""
        mine = self._own
        if self.centralized:  # the baseline's centre receives every measurement
            I = mine["info_matrix"].sum(axis=0, keepdims=True)
            i = mine["info_vector"].sum(axis=0, keepdims=True)
        elif self.share_mode == "information":
            if self.gating == "ci":
                self._fuse_ci(t, inbox)
                return
            I_n, i_n = self._neighbour_information(inbox)
            I = mine["info_matrix"] + I_n
            i = mine["info_vector"] + i_n
        else:
            I, i = self._received_measurements(inbox)
        if self.compiled:
            from swarmtrack.estimation import kernels

            I, i, m = np.ascontiguousarray(I), np.ascontiguousarray(i), self.model
            if m.name == "fs":
                w_vz = 0.0 if self._vz is None else self._vz[1]
                flags = kernels.fs_cycle(self.x, self.P, m.dt, self._q, I, i, m.mass, m.Ixx, m.Iyy, m.g, w_vz)
            else:
                flags = kernels.cv_cycle(self._Y, self._y, self.x, self.P, m.dt, self._q, I, i)
            kernels.check_flags(flags, t)
            return
        self.x, self.P = self._update(*add_position_information(self._Y_pred, self._y_pred, I, i), t)

    def _update(self, Y: np.ndarray, y: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The posterior from the information after the measurements (L24 eq. 7), with L24's fake vz = 0
        measurement (FS; local to every filter, never shared) and a divergence check."""
        if self._vz is not None:
            k, w_vz = self._vz
            Y[:, k, k] += w_vz
        check_information(Y, y, t)
        return recover(Y, y)

    def _reset_gate_counts(self) -> None:
        if self.gating == "chi2":
            self._gated[:] = 0.0
            self._rejected[:] = 0.0
            self._delivered[:] = 0.0

    def _neighbour_information(self, inbox):
        """The sums of what the links delivered (L24 eq. 7), without the contributions the χ²-gate leaves out
        (:func:`swarmtrack.estimation.gating.chi2_gate`, against this step's prediction); late parts as if
        current."""
        if self.gating != "chi2":
            return inbox.sum("info_matrix"), inbox.sum("info_vector")
        x_pos, P_pos = self._x_pred[..., :2], self.predicted_position_covariance(self.x, self.P)
        I, i = 0.0, 0.0
        for part in inbox.parts():
            I_p, i_p = self.gate(part.links, part.payloads, x_pos, P_pos)
            I, i = I + I_p, i + i_p
        return I, i

    def gate(self, links, payloads: dict, x_pos: np.ndarray, P_pos: np.ndarray):
        """χ²-gated sums of one part of an inbox, counting the links (the ``gated``, ``rejected`` and ``delivered``
        probes: per receiver the contributions it left out; per sender how many receivers left its out, and got
        it)."""
        from swarmtrack.estimation.gating import chi2_gate

        I, i, recv, send, ok = chi2_gate(links, payloads, x_pos, P_pos, self._threshold, self.n)
        np.add.at(self._gated, recv[~ok], 1.0)
        np.add.at(self._rejected, send[~ok], 1.0)
        np.add.at(self._delivered, send, 1.0)
        return I, i

    def _fuse_ci(self, t: float, inbox) -> None:
        """Own measurement by eq. 7, then every neighbour's contribution by covariance intersection."""
        from swarmtrack.estimation.gating import covariance_intersection

        Y, y = add_position_information(self._Y_pred, self._y_pred, self._own["info_matrix"],
                                        self._own["info_vector"])
        for part in inbox.parts():
            Y, y = covariance_intersection(Y, y, part.links, part.payloads)
        self.x, self.P = self._update(Y, y, t)

    def _received_measurements(self, inbox):
        """Raw measurements: each UAV linearises its own and every delivered measurement at its own prediction
        and sums their information (per link, then per receiver)."""
        got = inbox.payloads
        recv, send = inbox.heard()  # own measurement first
        Ipair, ipair = self.update_rule.contributions(self._x_pred[recv, :2], got["sensor_pos"][send],
                                                      got["z"][send])
        I = np.zeros((self.n, 2, 2))
        i = np.zeros((self.n, 2))
        np.add.at(I, recv, Ipair)
        np.add.at(i, recv, ipair)
        return I, i

    def estimates(self) -> tuple[np.ndarray, np.ndarray]:
        """Every UAV's current estimate (N, n) and covariance (N, n, n)."""
        if self.centralized:
            return (np.broadcast_to(self.x, (self.n, self.model.dim)),
                    np.broadcast_to(self.P, (self.n, self.model.dim, self.model.dim)))
        return self.x, self.P

    def view(self) -> TargetView:
        return TargetView(self.estimates()[0][:, :4])

    def sample(self) -> dict[str, np.ndarray]:
        x, P = self.estimates()
        out = {"estimate": x, "covariance": P, "detected": self._detected, "nis": self._nis}
        if self.gating == "chi2":
            out.update(gated=self._gated.copy(), rejected=self._rejected.copy(), delivered=self._delivered.copy())
        return out
