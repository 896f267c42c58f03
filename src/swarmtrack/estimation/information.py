"""Extended Kalman filter in information form, batched over agents (L24 Sec. 3, eqs. 4-7; L23 eqs. 11-18).

State of a bank of filters: information matrix ``Y = P⁻¹`` (..., n, n) and information vector ``y = P⁻¹ x``
(..., n). The sensors of this project observe the target's planar position (the first two states of every
model), so a measurement's information is a 2 x 2 block ``I`` and a 2-vector ``i`` added to the top-left of
``Y`` and ``y``; contributions are kept in that compact form and fused by plain sums (L24 eq. 7).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from swarmtrack.estimation.base import Probe, TargetView
from swarmtrack.models.base import MotionModel
from swarmtrack.network.links import neighbour_sum
from swarmtrack.network.messages import Outbox
from swarmtrack.network.rows import Rows
from swarmtrack.sensors.range_bearing import polar_model, position_covariance, to_position, wrap_angle

if TYPE_CHECKING:
    from swarmtrack.estimation.information_compiled import CompiledCycle
    from swarmtrack.estimation.sharing import Chi2Gate

UPDATES = ("position", "polar")
#: The position states a planar update observes, ``[x, y]`` (a slice: the position block is a view).
PLANAR = slice(0, 2)


def position_block(index) -> tuple:
    """The rows and columns selecting the position block of a matrix (``M[..., rows, cols]``): ``index`` a slice
    (:data:`PLANAR`) or an array of states (a 3-D update's ``[x, y, z]``)."""
    if isinstance(index, slice):
        return index, index
    ix = np.asarray(index)
    return ix[:, None], ix[None, :]


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
    #: The states it observes and their number (the position block of every planar model).
    index: ClassVar[slice] = PLANAR
    dim: ClassVar[int] = 2
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


    @staticmethod
    def to_position(z: np.ndarray, sensor_pos: np.ndarray) -> np.ndarray:
        """The position a measurement implies (:func:`~swarmtrack.sensors.range_bearing.to_position`)."""
        return to_position(z, sensor_pos)

    @staticmethod
    def nis(q: np.ndarray, I: np.ndarray, x_pos: np.ndarray, P_pos: np.ndarray) -> np.ndarray:
        """:func:`position_nis` (closed-form 2 x 2)."""
        return position_nis(q, I, x_pos, P_pos)


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


def predict(model: MotionModel, x: np.ndarray, P: np.ndarray, rows: Rows | None = None):
    """Prediction in information form from the posterior moments (L24 Sec. 3.1; linear case: ``∇f = F``).

    ``Y(k|k-1) = (∇f P ∇fᵀ + Q)⁻¹`` and ``y(k|k-1) = Y(k|k-1) f(x)``, both from one solve against
    ``P(k|k-1)``. ``x, P`` come from :func:`recover`; ``rows``: the swarm's UAVs they are (a subset's
    prediction is bit for bit the whole swarm's, :meth:`~swarmtrack.network.rows.Rows.rowwise`). Returns
    ``Y_pred, y_pred, x_pred``.
    """
    F = model.jacobian(x)
    x_pred = model.f(x) if rows is None else rows.rowwise(model.f, x)
    P_pred = symmetrize(F @ P @ np.swapaxes(F, -1, -2) + model.Q)
    n = model.dim
    sol = np.linalg.solve(P_pred, np.concatenate(
        [x_pred[..., None], np.broadcast_to(np.eye(n), P_pred.shape)], axis=-1))
    return symmetrize(sol[..., 1:]), sol[..., 0], x_pred


def add_position_information(Y: np.ndarray, y: np.ndarray, I: np.ndarray, i: np.ndarray, index=PLANAR):
    """Update (L24 eq. 7) with fused position-block information ``I`` (..., d, d), ``i`` (..., d) at the states
    ``index`` (the update's: :data:`PLANAR`, or a 3-D update's ``[x, y, z]``); returns new arrays."""
    Y = Y.copy()
    y = y.copy()
    rows, cols = position_block(index)
    Y[..., rows, cols] += I
    y[..., index] += i
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


class NeighbourSum:
    """What a UAV does with its neighbours' contributions: add all of them (L24 eq. 7). The χ²-gate
    (:class:`swarmtrack.estimation.sharing.Chi2Gate`) is the other choice."""

    probes: tuple[Probe, ...] = ()

    def reset(self) -> None:
        """Start a step (a gate's counts)."""

    def current(self, est: InformationEstimator, inbox) -> tuple[np.ndarray, np.ndarray]:
        """The delivered contributions' sums ``I (N, d, d), i (N, d)``, late parts as if current."""
        return inbox.sums("info_matrix", "info_vector")

    def part(self, part, rows: np.ndarray, prior) -> tuple[np.ndarray, np.ndarray]:
        """The sums of one ``part`` of an inbox restricted to the sending ``rows`` (time-stamped fusion, which fuses
        each part at the step it was taken; ``prior()`` gives each receiver's predicted position and its covariance
        for that step, which a gate reads)."""
        got = part.payloads
        return (neighbour_sum(part.links, got["info_matrix"] * rows[:, None, None], part.receivers),
                neighbour_sum(part.links, got["info_vector"] * rows[:, None], part.receivers))

    def sample(self) -> dict[str, np.ndarray]:
        return {}


class InformationSharing:
    """L24's sharing: each UAV broadcasts its own contribution ``I_i, i_i`` (eq. 6) and adds what its links deliver
    (eq. 7), all of it or what ``neighbours`` (a gate) lets through."""

    centralized = False
    #: The update adds position-block information only (:meth:`contributions`), the form the compiled cycle takes.
    additive = True

    def __init__(self, neighbours: NeighbourSum | Chi2Gate | None = None):
        self.neighbours = NeighbourSum() if neighbours is None else neighbours

    def filters(self, n_uavs: int) -> int:
        return n_uavs

    def outbox(self, own: dict) -> dict:
        return own

    def contributions(self, est: InformationEstimator, inbox) -> tuple[np.ndarray, np.ndarray]:
        """The position-block information each filter adds this step (L24 eq. 7)."""
        I_n, i_n = self.neighbours.current(est, inbox)
        return est.own["info_matrix"] + I_n, est.own["info_vector"] + i_n

    def information(self, est: InformationEstimator, inbox) -> tuple[np.ndarray, np.ndarray]:
        """Each filter's information after this step's measurements (L24 eq. 7)."""
        return add_position_information(est.Y_pred, est.y_pred, *self.contributions(est, inbox), est.index)


class MeasurementSharing(InformationSharing):
    """Each UAV broadcasts its raw measurement and the position it was taken from, and linearises its own and every
    delivered one at its own prediction."""

    def outbox(self, own: dict) -> dict:
        return {"z": own["z"], "sensor_pos": own["sensor_pos"], "seen": own["seen"]}

    def contributions(self, est: InformationEstimator, inbox) -> tuple[np.ndarray, np.ndarray]:
        """Per link, then per receiver: the information of every measurement it heard, its own first."""
        got = inbox.payloads
        recv, send = inbox.heard()  # own measurement first
        d = est.update_rule.dim
        Ipair, ipair = est.update_rule.contributions(est.x_pred[recv][:, est.index], got["sensor_pos"][send],
                                                     got["z"][send])
        I = np.zeros((est.n, d, d))
        i = np.zeros((est.n, d))
        np.add.at(I, recv, Ipair)
        np.add.at(i, recv, ipair)
        return I, i


class FusionCentre(InformationSharing):
    """The centralized baseline: one filter that receives every UAV's measurement (not onboard)."""

    centralized = True

    def filters(self, n_uavs: int) -> int:
        return 1

    def contributions(self, est: InformationEstimator, inbox) -> tuple[np.ndarray, np.ndarray]:
        return (est.own["info_matrix"].sum(axis=0, keepdims=True),
                est.own["info_vector"].sum(axis=0, keepdims=True))


class NumpyCycle:
    """The reference predict-update cycle of the information filter (numpy, every model and update). The compiled
    twin for the CV and FS models is :class:`swarmtrack.estimation.information_compiled.CompiledCycle`."""

    def start(self, Y: np.ndarray, y: np.ndarray) -> None:
        """The initial information (the compiled cycle keeps it)."""

    def share(self, est: InformationEstimator, z: np.ndarray, pos: np.ndarray, seen: np.ndarray) -> dict:
        """Predict (L24 Sec. 3.1) and each UAV's own contribution (L24 eq. 6)."""
        est.Y_pred, est.y_pred, est.x_pred = predict(est.model, est.x, est.P, est.rows)
        return est.measured(z, pos, seen, est.x, est.P, est.x_pred)

    def fuse(self, est: InformationEstimator, inbox, t: float) -> None:
        est.x, est.P = est.update(*est.sharing.information(est, inbox), t)


class InformationEstimator:
    """One information-form EKF per UAV (L24 Sec. 3), or the sharing's single fusion centre (the baseline). Follows
    the object its sensor labels ``label``.

    Composed of strategies the builder picks: ``sharing`` (what a UAV broadcasts and how it fuses what arrives:
    :class:`InformationSharing` of L24 eqs. 6-7, with a gate or not; :class:`MeasurementSharing`;
    :class:`FusionCentre`; covariance intersection, :class:`swarmtrack.estimation.sharing.CovarianceIntersection`)
    and ``cycle`` (the numpy reference :class:`NumpyCycle`, or the compiled cycle of the CV and FS models with the
    position update, same numbers). Late data fused at its time stamp is
    :class:`swarmtrack.estimation.refilter.RefilteringEstimator`.

    ``n_uavs`` rows, the swarm's UAVs ``rows`` (default: a whole swarm of ``n_uavs``); a subset's rows are bit for
    bit the whole swarm's, given the same inputs (:mod:`swarmtrack.network.rows`).
    """

    def __init__(self, model: MotionModel, update: RangeBearingUpdate, n_uavs: int, *, label: int = 0,
                 sharing: InformationSharing | None = None, cycle: NumpyCycle | CompiledCycle | None = None,
                 initial_info: float = 1e-6, fake_vz_sigma: float | None = None, rows: Rows | None = None):
        self.model, self.update_rule = model, update
        self.index = update.index  # the position states it observes
        self.sharing = InformationSharing() if sharing is None else sharing
        self.cycle = NumpyCycle() if cycle is None else cycle
        self.n, self.label = n_uavs, label
        self.rows = Rows.all(n_uavs) if rows is None else rows
        Y, y = initial_information(model, self.sharing.filters(n_uavs), initial_info)
        self.x, self.P = recover(Y, y)
        self.cycle.start(Y, y)
        self.x_pred = self.x
        self.Y_pred, self.y_pred = Y, y
        self.vz = None
        if fake_vz_sigma is not None and hasattr(model, "VZ_INDEX"):
            self.vz = (model.VZ_INDEX, 1.0 / fake_vz_sigma**2)
        # this step's own message: share() makes it before any reader (fuse) runs
        self.own: Outbox = None  # type: ignore[assignment]
        self._detected = np.zeros(n_uavs)
        self.nis = np.full(n_uavs, np.nan)
        # the rows of F that predict the position, for the NIS: constant for the linear models and for FS (whose
        # position rows are x' = x + dt·vx, y' = y + dt·vy); CT's depend on the state
        self.F2 = (model.F[self.index] if getattr(model, "linear", False) else  # type: ignore[attr-defined]  # linear
                   model.jacobian(model.initial_state())[self.index] if model.name == "fs" else None)
        self.Q2 = model.Q[position_block(self.index)]
        self.probes = (Probe("estimate", (model.dim,)), Probe("covariance", (model.dim, model.dim)),
                       Probe("detected", ()), Probe("nis", ()), *self.gate.probes)

    @property
    def centralized(self) -> bool:
        return self.sharing.centralized

    @property
    def gate(self) -> NeighbourSum | Chi2Gate:
        """What the filter does with its neighbours' contributions (a fusion centre's sums all it hears)."""
        return self.sharing.neighbours

    def share(self, t: float, nav: np.ndarray, own) -> dict:
        """Predict (L24 Sec. 3.1) and compute this UAV's own contribution (L24 eq. 6) for broadcast; a UAV that
        did not detect its target contributes zero information."""
        self.gate.reset()
        self.own = self.cycle.share(self, *own.of_label(self.label))
        return self.sharing.outbox(self.own)

    def measured(self, z: np.ndarray, pos: np.ndarray, seen: np.ndarray, x: np.ndarray, P: np.ndarray,
                 x_pred: np.ndarray) -> dict:
        """Each UAV's own contribution (L24 eq. 6) linearised at ``x_pred``, predicted from the posterior ``x, P``
        (the fusion centre linearises every measurement at its one prediction), and its NIS."""
        x_pos = x_pred[:, self.index]
        x_pos = np.broadcast_to(x_pos, pos.shape) if self.centralized else x_pos
        I, i = self.update_rule.contributions(x_pos, pos, z)
        self.nis = self._own_nis(z, pos, I, x, P, x_pred)
        return self.contribution(I, i, z, pos, seen)

    def contribution(self, I, i, z, pos, seen) -> dict:
        """The outbox row of each UAV: zero information and a NaN NIS where it saw nothing."""
        if not seen.all():  # unseen rows are NaN
            I[~seen] = 0.0
            i[~seen] = 0.0
            self.nis[~seen] = np.nan
        self._detected = seen.astype(float)
        return {"info_matrix": I, "info_vector": i, "z": z, "sensor_pos": pos, "seen": seen}

    def predicted_position_covariance(self, x: np.ndarray, P: np.ndarray) -> np.ndarray:
        """Position block (..., d, d) of ``P(k|k−1) = F P Fᵀ + Q`` predicted from the posterior ``x, P``."""
        F = self.F2 if self.F2 is not None else self.model.jacobian(x)[..., self.index, :]
        return F @ P @ np.swapaxes(F, -1, -2) + self.Q2

    def _own_nis(self, z: np.ndarray, pos: np.ndarray, I: np.ndarray, x: np.ndarray, P: np.ndarray,
                 x_pred: np.ndarray) -> np.ndarray:
        """Normalised innovation squared of each UAV's own measurement (N,), in position form whatever the update:
        ``ν = q(z) − x̂(k|k−1)[pos]``, ``S = I⁻¹ + P(k|k−1)[pos, pos]`` with ``I`` the measurement's position-block
        information (``R⁻¹`` of the converted measurement; ``HᵀR⁻¹H`` of the polar one, equal to first order),
        predicted from the posterior ``x, P`` to ``x_pred``. χ²(d) for a consistent filter (d = 2 in the plane, 3 in
        3-D); NaN where the UAV saw nothing."""
        u = self.update_rule
        return u.nis(u.to_position(z, pos), I, x_pred[..., self.index], self.predicted_position_covariance(x, P))

    def fuse(self, t: float, own, inbox) -> None:
        """Update (L24 eq. 7): own information plus what the links delivered, as the sharing fuses it."""
        self.cycle.fuse(self, inbox, t)

    def update(self, Y: np.ndarray, y: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The posterior from the information after the measurements (L24 eq. 7), with L24's fake vz = 0
        measurement (FS; local to every filter, never shared) and a divergence check."""
        if self.vz is not None:
            k, w_vz = self.vz
            Y[:, k, k] += w_vz
        check_information(Y, y, t)
        return recover(Y, y)

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
        return {"estimate": x, "covariance": P, "detected": self._detected, "nis": self.nis, **self.gate.sample()}
