"""The multi-model EKF's compiled step: :class:`~swarmtrack.estimation.multimodel.MultiModelEstimator`'s share, fuse
and (T-test) combine, each one call of :mod:`swarmtrack.estimation.multimodel_kernels` over every UAV's filters
(every world's, in a batch), on the estimator's own state; the same numbers as the estimator's numpy reference
(``compiled=False``; tests hold them equal).

The estimator's banks keep one model's filters each; here they move into one array padded to the largest model's
dimension, bank after bank, and each bank's ``x`` and ``P`` become views of it. So what stays numpy (a filter's
start from its first measurement, the IMM and maximum-likelihood fusions and the IMM's mixing) works on the same
filters, in place.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.estimation.base import TargetView
from swarmtrack.estimation.information import FilterDivergence
from swarmtrack.estimation.measurements import CameraFrameMeasurement, RangeBearingMeasurement
from swarmtrack.estimation.multimodel_kernels import (
    CA_MOTION,
    CAMERA,
    CT_MOTION,
    EIGENVALUE,
    LAST,
    NO_MOTION,
    RANGE_BEARING,
    TRACE,
    combine_ttest,
    fuse_step,
    links_of,
    share_step,
)
from swarmtrack.estimation.predict_kernels import has_kernel, model_params

#: The occlusion policies by the kernels' numbers.
_POLICIES = {"last": LAST, "trace": TRACE, "eigenvalue": EIGENVALUE}
#: Each model's extra states as ``[ax, ay, ω]`` (the reference's ``_motion``).
_MOTION = {"ca": CA_MOTION, "ct": CT_MOTION}


class CompiledStep:
    """The compiled step of the estimator ``est`` (:meth:`of`), holding its filters (module docstring)."""

    @classmethod
    def of(cls, est) -> CompiledStep | None:
        """The compiled step of ``est``, or None where it does not apply: a model without a compiled prediction
        (:func:`~swarmtrack.estimation.predict_kernels.has_kernel`), a measurement other than the camera's or the
        range-bearing sensor's."""
        if not all(has_kernel(bank.model) for bank in est._banks):
            return None
        if type(est.measurement) not in (CameraFrameMeasurement, RangeBearingMeasurement):
            return None
        return cls(est)

    def __init__(self, est):
        self.est = est
        banks, n = est._banks, est.n
        D = max(bank.model.dim for bank in banks)
        self.X, self.P = np.zeros((n, D)), np.zeros((n, D, D))
        bank_of = np.empty(n, dtype=np.int64)  # per row of X
        self.pos = np.empty(n, dtype=np.int64)  # each UAV row's row of X
        kind = np.empty(len(banks), dtype=np.int64)
        params, F, Q = np.zeros((len(banks), 5)), np.zeros((len(banks), D, D)), np.zeros((len(banks), D, D))
        dim, n_whole = np.empty(len(banks), dtype=np.int64), np.empty(len(banks), dtype=np.int64)
        motion = np.full(n, NO_MOTION, dtype=np.int64)
        start = 0
        for k, bank in enumerate(banks):
            m, d = len(bank.idx), bank.model.dim
            rows = slice(start, start + m)
            self.X[rows, :d], self.P[rows, :d, :d] = bank.x, bank.P
            bank.x, bank.P = self.X[rows, :d], self.P[rows, :d, :d]  # views: the reference's methods work on them
            bank_of[rows], self.pos[bank.idx] = k, np.arange(start, start + m)
            kind[k], params[k], F_k = model_params(bank.model)
            F[k, :d, :d] = F_k if F_k.size else 0.0
            Q[k, :d, :d] = bank.model.Q
            dim[k], n_whole[k] = d, bank.rows.n // bank.rows.worlds
            motion[bank.idx] = _MOTION.get(bank.model.name, NO_MOTION)
            start += m
        self.models = (bank_of, kind, params, F, Q, n_whole, dim)
        self.dim, self.motion = dim[bank_of[self.pos]], motion
        label = np.asarray(est.label, dtype=np.int64)  # one, or per row (a batch's worlds' targets)
        self.label = np.ascontiguousarray(label if label.ndim else np.full(n, label))
        self.team = (len(est.team), np.ascontiguousarray(est._world, dtype=np.int64))
        self.camera = isinstance(est.measurement, CameraFrameMeasurement)
        if self.camera:
            Rinv, logdet = est.measurement.noise()
            self.meas = (CAMERA, np.ascontiguousarray(Rinv), float(logdet), 0.0)
        else:
            m = est.measurement
            w = np.array([1.0 / m.sigma_range**2, 1.0 / m.sigma_bearing**2])
            self.meas = (RANGE_BEARING, np.diag(w), float(-np.log(w).sum()), float(m.min_range))
        self.policy = _POLICIES[est.occlusion]
        self.no_fresh = np.zeros(n, dtype=bool)
        self.message = None  # what publish() sends, made by fuse()
        self.cold = True  # the T-test's kernel not called yet

    def _aux(self, payload: dict) -> np.ndarray:
        """A payload's pose data as the kernels take it: the camera's ``[A | b]`` (n, 2, 3), the range-bearing
        sensor's position as (n, 1, d)."""
        return payload["frame"] if self.camera else payload["sensor_pos"][:, None, :]

    def share(self, own) -> dict:
        """Predict every filter and return each row's payload (W20 eqs. 4.7-4.9; the measurement's ``payload``)."""
        aux = own.frame if self.camera else own.sensor_pos[:, None, :]
        z, aux, seen = share_step((own.owner, own.z, aux, own.label), self.label, self.X, self.P, self.models)
        return {"z": z, "frame": aux, "seen": seen} if self.camera else {"z": z, "sensor_pos": aux[:, 0], "seen": seen}

    def fuse(self, t: float, inbox) -> None:
        """Start the filters measured for the first time (the reference's numpy, until all have started), update the
        others, and make the message :meth:`publish <swarmtrack.estimation.multimodel.MultiModelEstimator.publish>`
        sends."""
        est, got = self.est, inbox.payloads
        fresh = self.no_fresh
        if not est._all_started:
            fresh = est._start_fresh(*est._heard(inbox), got)[2]
        mine = est._own
        state = (self.X, self.P, self.pos, self.dim, self.motion, est.initialised, est._windows)
        est._loglik, est._nis, est._measured, est._windows, (ok, all_ok), self.message = fuse_step(
            self.meas, (mine["z"], self._aux(mine), mine["seen"]), (got["z"], self._aux(got), got["seen"]),
            links_of(inbox.links), self.team, state, fresh)
        if not all_ok:
            for bank in est._banks:  # the first bank with a diverged filter, as the reference raises
                bad = bank.idx[~ok[bank.idx]]
                if len(bad):
                    raise FilterDivergence(est.rows.uavs[bad], t, f"the {bank.model.name.upper()} filter's "
                                           "covariance is not positive definite or not finite")
        if self.cold and est.fusion == "ttest":
            self._warm(inbox)

    def _warm(self, inbox) -> None:
        """Call the T-test's kernel once on this step's message, its result thrown away: its first real call comes
        after the solo steps, and a live UAV's warm-up (:mod:`swarmtrack.onboard.warm`) runs fewer steps, so that
        call would load numba's cache in the middle of the run, late."""
        est, (x, P, motion) = self.est, self.message
        combine_ttest((x, P, est._measured, est.initialised, est._windows, motion), links_of(inbox.links), self.team,
                      (est._candidate, est.initialised, est._winner), self.policy, est.switches.copy())
        self.cold = False

    def combine_ttest(self, inbox) -> None:
        """The T-test's winner of each UAV, its output, the switch count and the view (the reference's ``combine``
        of ``fusion: ttest`` and ``view``)."""
        est, got = self.est, inbox.payloads
        est._winner, est.out_x, est.out_P, motion = combine_ttest(
            (got["x"], got["P"], got["measured"], got["started"], got["window"], got["motion"]),
            links_of(inbox.links), self.team, (est._candidate, est.initialised, est._winner), self.policy,
            est.switches)
        est._view = TargetView(est.out_x, model=est._names[est._winner], motion=motion)
