"""The information filter's compiled cycle: the numba kernels of :mod:`swarmtrack.estimation.kernels` for the CV
and FS models with the position update, and of :mod:`swarmtrack.estimation.kernels_3d` for CV in 3-D with the
range-bearing-elevation update; the same numbers as :class:`~swarmtrack.estimation.information.NumpyCycle` (tests
hold them equal). The builder picks it (:func:`compiled_cycle`)."""

from __future__ import annotations

import numpy as np

from swarmtrack.estimation import kernels, kernels_3d
from swarmtrack.estimation.information import InformationEstimator, InformationSharing, RangeBearingUpdate
from swarmtrack.models.base import MotionModel

#: Models with a compiled cycle (with the ``position`` update).
COMPILED_MODELS = ("cv", "fs", "cv3d")


class CompiledCycle:
    """Predict, contributions and NIS (one compiled pass each), and predict-update in one kernel, in place."""

    def __init__(self, model: MotionModel):
        self._q = np.ascontiguousarray(np.diag(model.Q))

    def start(self, Y: np.ndarray, y: np.ndarray) -> None:
        self._Y, self._y = Y, y

    def share(self, est: InformationEstimator, z: np.ndarray, pos: np.ndarray, seen: np.ndarray) -> dict:
        u = est.update_rule
        if est.model.name == "cv3d":  # the whole predicted state, as the numpy cycle's (the NIS reads its position)
            est.x_pred = est.model.f(est.x)
            x_pos = np.ascontiguousarray(est.x_pred[:, est.index])
            I, i = kernels_3d.cv3d_position_contributions(x_pos, pos, z, u.sigma_range, u.sigma_bearing,
                                                          u.sigma_elevation, u.min_range, u.own_sigma**2)
            est.nis = est._own_nis(z, pos, I, est.x, est.P, est.x_pred)
            return est.contribution(I, i, z, pos, seen)
        est.x_pred = kernels.cv_predicted_position(est.x, est.model.dt)
        I, i = kernels.cv_position_contributions(est.x_pred, pos, z, u.sigma_range, u.sigma_bearing, u.min_range,
                                                 u.own_sigma**2)
        est.nis = kernels.position_nis(z, pos, est.x_pred[:, :2], est.P, est.F2, est.Q2, I)
        return est.contribution(I, i, z, pos, seen)

    def fuse(self, est: InformationEstimator, inbox, t: float) -> None:
        I, i = est.sharing.contributions(est, inbox)
        I, i, m = np.ascontiguousarray(I), np.ascontiguousarray(i), est.model
        if m.name == "cv3d":
            flags = kernels_3d.cv3d_cycle(est.x, est.P, m.dt, self._q, I, i)
        elif m.name == "fs":
            w_vz = 0.0 if est.vz is None else est.vz[1]
            flags = kernels.fs_cycle(est.x, est.P, m.dt, self._q, I, i, m.mass, m.Ixx, m.Iyy, m.g, w_vz)
        else:
            flags = kernels.cv_cycle(self._Y, self._y, est.x, est.P, m.dt, self._q, I, i)
        kernels.check_flags(flags, t)


def compiled_cycle(model: MotionModel, update: RangeBearingUpdate, sharing: InformationSharing) -> CompiledCycle | None:
    """The compiled cycle where one exists (CV, FS and CV in 3-D with the position update, an additive decentralized
    sharing: not the fusion centre, not covariance intersection), else None (the numpy reference)."""
    if model.name in COMPILED_MODELS and update.mode == "position" and not sharing.centralized and sharing.additive:
        return CompiledCycle(model)
    return None
