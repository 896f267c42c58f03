"""Onboard code of the UAVs, batched over the swarm.

Row i of every array here belongs to UAV i's own computer. Its inputs are only: UAV i's own navigation
solution, UAV i's own measurement, and the messages the channel delivered to UAV i (a link mask row and
the broadcast payloads, or their delivered sums). This module must not import :mod:`swarmtrack.sim.world`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.control.flocking import FlockingGains, FlockingState, flocking_control
from swarmtrack.estimation.information import (
    RangeBearingUpdate,
    add_position_information,
    check_information,
    initial_information,
    predict,
    recover,
)
from swarmtrack.models.base import MotionModel
from swarmtrack.network.channel import Channel


@dataclass
class Broadcast:
    """What every UAV sends after measuring: its information contribution (L24 eq. 6) and, for
    ``share: measurements``, its raw measurement and the navigation position it was taken from."""

    info_matrix: np.ndarray  # (N, 2, 2)
    info_vector: np.ndarray  # (N, 2)
    z: np.ndarray  # (N, 2) [range, bearing]
    sensor_pos: np.ndarray  # (N, 2)
    seen: np.ndarray  # (N,) False: no measurement this step, zero information


def _masked(b: Broadcast) -> Broadcast:
    """Zero the information of UAVs that saw nothing (their measurement rows are NaN)."""
    if not b.seen.all():
        b.info_matrix[~b.seen] = 0.0
        b.info_vector[~b.seen] = 0.0
    return b


class OnboardEstimators:
    """One information-form EKF per UAV (L24 Sec. 3) or a single fusion centre (``centralized``)."""

    def __init__(self, model: MotionModel, update: RangeBearingUpdate, n_uavs: int, *, share: str = "information",
                 centralized: bool = False, initial_info: float = 1e-6, fake_vz_sigma: float | None = None,
                 compiled: bool = False):
        self.model, self.update_rule, self.share, self.centralized = model, update, share, centralized
        self.n = n_uavs
        n_filters = 1 if centralized else n_uavs
        Y, y = initial_information(model, n_filters, initial_info)
        self.x, self.P = recover(Y, y)
        # the compiled CV kernels (estimation.kernels) compute the same cycle as the numpy reference
        self.compiled = compiled and model.name == "cv" and update.mode == "position" and not centralized
        if self.compiled:
            self._Y, self._y, self._q = Y, y, np.ascontiguousarray(np.diag(model.Q))
        self._x_pred = self.x
        self._Y_pred, self._y_pred = Y, y
        self._vz = None
        if fake_vz_sigma is not None and hasattr(model, "VZ_INDEX"):
            self._vz = (model.VZ_INDEX, 1.0 / fake_vz_sigma**2)

    def predict_and_measure(self, nav_pos: np.ndarray, z: np.ndarray, seen: np.ndarray | None = None) -> Broadcast:
        """Predict (L24 Sec. 3.1) and compute this UAV's own contribution (L24 eq. 6) for broadcast; a UAV that
        did not see the target (``seen`` False) contributes zero information."""
        seen = np.ones(len(z), dtype=bool) if seen is None else seen
        if self.compiled:
            from swarmtrack.estimation import kernels

            self._x_pred = kernels.cv_predicted_position(self.x, self.model.dt)
            u = self.update_rule
            I, i = kernels.cv_position_contributions(self._x_pred, np.ascontiguousarray(nav_pos),
                                                     np.ascontiguousarray(z), u.sigma_range, u.sigma_bearing,
                                                     u.min_range)
            return _masked(Broadcast(I, i, z, nav_pos, seen))
        self._Y_pred, self._y_pred, self._x_pred = predict(self.model, self.x, self.P)
        x_pos = self._x_pred[:, :2]
        if self.centralized:  # the fusion centre linearises everything at its own prediction
            x_pos = np.broadcast_to(x_pos, nav_pos.shape)
        I, i = self.update_rule.contributions(x_pos, nav_pos, z)
        return _masked(Broadcast(I, i, z, nav_pos, seen))

    def fuse(self, own: Broadcast, links: np.ndarray, t: float) -> None:
        """Update (L24 eq. 7): own information plus what the links delivered."""
        if self.centralized:
            I = own.info_matrix.sum(axis=0, keepdims=True)
            i = own.info_vector.sum(axis=0, keepdims=True)
        elif self.share == "information":
            I = own.info_matrix + Channel.sum_received(links, own.info_matrix)
            i = own.info_vector + Channel.sum_received(links, own.info_vector)
        else:  # raw measurements: each UAV linearises every received measurement at its own prediction
            heard = (links | np.eye(self.n, dtype=bool)) & own.seen[None, :]
            Ipair, ipair = self.update_rule.contributions(
                self._x_pred[:, None, :2], own.sensor_pos[None, :, :], own.z[None, :, :])
            I = np.where(heard[..., None, None], Ipair, 0.0).sum(axis=1)  # where: unseen rows are NaN
            i = np.where(heard[..., None], ipair, 0.0).sum(axis=1)
        if self.compiled:
            from swarmtrack.estimation import kernels

            flags = kernels.cv_cycle(self._Y, self._y, self.x, self.P, self.model.dt, self._q,
                                     np.ascontiguousarray(I), np.ascontiguousarray(i))
            kernels.check_flags(flags, t)
            return
        Y, y = add_position_information(self._Y_pred, self._y_pred, I, i)
        if self._vz is not None:  # L24's fake vz = 0 measurement, local to every filter
            k, w_vz = self._vz
            Y[:, k, k] += w_vz
        check_information(Y, y, t)
        self.x, self.P = recover(Y, y)

    def estimates(self) -> tuple[np.ndarray, np.ndarray]:
        """Every UAV's current estimate (N, n) and covariance (N, n, n)."""
        if self.centralized:
            return (np.broadcast_to(self.x, (self.n, self.model.dim)),
                    np.broadcast_to(self.P, (self.n, self.model.dim, self.model.dim)))
        return self.x, self.P


class OnboardFlocking:
    """Tailored Olfati-Saber flocking (L24 Sec. 2) that follows each UAV's own target estimate.

    ``compiled``: the numba kernel :func:`swarmtrack.control.kernels.flocking_kernel` instead of the numpy
    reference :func:`~swarmtrack.control.flocking.flocking_control` (same numbers to rounding)."""

    def __init__(self, gains: FlockingGains, variant: str, n_uavs: int, chase_after: float, *,
                 compiled: bool = False):
        self.gains, self.variant, self.chase_after = gains, variant, chase_after
        self.state = FlockingState.zeros(n_uavs)
        self.compiled = compiled
        if compiled:
            from swarmtrack.control import kernels

            self._control = kernels.flocking_control_compiled
            self._extra = {"gain_vec": kernels.gain_vector(gains)}
        else:
            self._control, self._extra = flocking_control, {}

    def command(self, nav: np.ndarray, beacon_links: np.ndarray, target_est: np.ndarray, t: float,
                dt: float) -> np.ndarray:
        """Acceleration command (N, 2). ``nav`` rows are broadcast as beacons: UAV i uses row j only if
        ``beacon_links[i, j]``; ``target_est`` (N, 4) is each UAV's own estimate of the target."""
        active = np.full(nav.shape[0], t >= self.chase_after)
        u, self.state = self._control(nav[:, :2], nav[:, 2:4], target_est[:, :2], target_est[:, 2:4], beacon_links,
                                      self.state, self.gains, self.variant, dt, active=active, **self._extra)
        return u
