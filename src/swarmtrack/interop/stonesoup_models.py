"""The two state orderings, and the models that cross between Stone Soup and swarmtrack (for
:mod:`swarmtrack.interop.stonesoup`).

**The ordering convention.** Stone Soup interleaves each axis' position and velocity, ``[x, vx, y, vy, …]`` (its
``CombinedLinearGaussianTransitionModel`` of two ``ConstantVelocity``, its ``ConstantTurn`` ``[x, vx, y, vy, ω]``);
swarmtrack puts positions first, ``[x, y, vx, vy, …]`` (``models/base.py``; CT is ``[x, y, vx, vy, ω]``, W20 eq. 2.39
is the same model in Stone Soup's order). Every state of a model with n ≥ 4 states maps by the permutation
:func:`permutation` ``[0, 2, 1, 3, 4, …, n − 1]`` (it is its own inverse): the first four states are the common
block every model shares (:data:`swarmtrack.estimation.fusion.COMMON`), the states after them (CT's ω, …) keep their
places. A Stone Soup model used as an IMM mode must follow it: its first four states are ``[x, vx, y, vy]``.

**Transition models.** :func:`motion_model` gives the swarmtrack :class:`~swarmtrack.models.base.MotionModel` (``f``,
``jacobian``, ``Q`` in swarmtrack's order) that :func:`swarmtrack.estimation.kalman.ekf_predict` takes, for one
prediction interval: a linear Stone Soup model through its matrix; Stone Soup's ``ConstantTurn`` through swarmtrack's
CT (:class:`swarmtrack.models.ct.ConstantTurn`, the same ``f`` with the analytic Jacobian instead of Stone Soup's
finite differences, and Stone Soup's ``Q``); any other through its ``function`` and ``jacobian``; and
:class:`SwarmtrackTransitionModel`, a swarmtrack model wrapped for Stone Soup, as itself.

**Measurement models.** :func:`linearise` gives a measurement's predicted value, its Jacobian in swarmtrack's order
and its noise: a linear model through its matrix; ``CartesianToBearingRange`` (unrotated) through swarmtrack's
analytic range-bearing model (:func:`swarmtrack.sensors.range_bearing.polar_model`, rows reordered to Stone Soup's
``[bearing, range]``); any other through its ``function`` and ``jacobian`` (the EKF linearisation of Stone Soup's
``ExtendedKalmanUpdater``).
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass, field

import numpy as np
from stonesoup.base import Property
from stonesoup.models.base import LinearModel, TimeVariantModel
from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
from stonesoup.models.transition.nonlinear import ConstantTurn as StoneSoupConstantTurn
from stonesoup.models.transition.nonlinear import GaussianTransitionModel
from stonesoup.types.angle import Bearing
from stonesoup.types.array import CovarianceMatrix, StateVector, StateVectors
from stonesoup.types.state import State

from swarmtrack.estimation.fusion import COMMON
from swarmtrack.models.base import LinearMotionModel, MotionModel
from swarmtrack.models.ct import ConstantTurn
from swarmtrack.sensors.range_bearing import polar_model

#: How far a prediction interval may be from a wrapped swarmtrack model's ``dt``: a ``timedelta``'s resolution, s.
DT_TOLERANCE = 1e-6


def permutation(n: int) -> np.ndarray:
    """Indices taking an n-state vector from one ordering to the other (either way): ``[0, 2, 1, 3, 4, …]``."""
    if n < COMMON:
        raise ValueError(f"a model of {n} states cannot hold the common block [x, vx, y, vy] (needs {COMMON})")
    return np.r_[[0, 2, 1, 3], np.arange(COMMON, n)].astype(int)


def stone_soup_order(model: MotionModel) -> np.ndarray:
    """Indices taking a state of ``model`` to Stone Soup's order, ``x_stonesoup = x[order]`` (the inverse is
    ``np.argsort(order)``): :func:`permutation` for a planar model; for a 3-D one
    (:mod:`swarmtrack.models.three_d`), its planar states in the planar convention followed by the altitude's,
    ``[x, vx, y, vy, (planar hidden), z, vz, (az)]``, the order of Stone Soup's combined models (its 2-D
    ``ConstantTurn`` or two ``ConstantVelocity``, then the altitude's)."""
    planar = getattr(model, "planar_index", None)
    if planar is None:
        return permutation(model.dim)
    return np.r_[planar[permutation(len(planar))], model.vertical_index].astype(int)


def reorder(x: np.ndarray, P: np.ndarray | None = None):
    """``x`` (n,) and, if given, ``P`` (n, n) in the other ordering (an exact permutation, no arithmetic)."""
    x = np.asarray(x, dtype=float).reshape(-1)
    p = permutation(x.size)
    if P is None:
        return x[p]
    return x[p], np.asarray(P, dtype=float)[np.ix_(p, p)]


def seconds(time_interval) -> float | None:
    return None if time_interval is None else time_interval.total_seconds()


class SwarmtrackTransitionModel(GaussianTransitionModel, TimeVariantModel):
    """A swarmtrack motion model (:func:`swarmtrack.models.make_model`: CV, CA, CT, FS) as a Stone Soup transition
    model, in Stone Soup's state order (module docstring): ``x' = f(x) + w``, ``w ~ N(0, Q)``.

    swarmtrack's models are discrete with a fixed period ``dt``: a ``time_interval`` other than ``dt`` (beyond
    :data:`DT_TOLERANCE`) is refused, and ``None`` means ``dt``. Its Jacobian is the model's analytic one.
    """

    model: MotionModel = Property(doc="The swarmtrack motion model (its f, analytic Jacobian, Q and dt).")

    @property
    def ndim_state(self) -> int:
        return self.model.dim

    def _check(self, time_interval) -> None:
        dt = seconds(time_interval)
        if dt is not None and abs(dt - self.model.dt) > DT_TOLERANCE:
            raise ValueError(f"the swarmtrack {self.model.name.upper()} model has a fixed period dt = "
                             f"{self.model.dt} s; it cannot predict over {dt} s")

    def function(self, state, noise=False, time_interval=None, **kwargs):
        self._check(time_interval)
        p = permutation(self.ndim_state)
        sv = np.asarray(state.state_vector, dtype=float)  # (n, k)
        out = StateVectors(self.model.f(sv[p].T).T[p])
        if isinstance(noise, bool) or noise is None:
            noise = self.rvs(num_samples=sv.shape[1], time_interval=time_interval) if noise else 0
        return out + noise

    def jacobian(self, state, time_interval=None, **kwargs):
        self._check(time_interval)
        p = permutation(self.ndim_state)
        x = np.asarray(state.state_vector, dtype=float).reshape(-1)
        return self.model.jacobian(x[p])[np.ix_(p, p)]

    def covar(self, time_interval=None, **kwargs):
        self._check(time_interval)
        p = permutation(self.ndim_state)
        return CovarianceMatrix(np.asarray(self.model.Q)[np.ix_(p, p)])


@dataclass(frozen=True)
class _LinearMode(LinearMotionModel):
    """A linear Stone Soup model over one interval, in swarmtrack's order."""

    name: str = "stonesoup-linear"
    matrix: np.ndarray | None = field(default=None, repr=False)

    @property
    def F(self) -> np.ndarray:
        return self.matrix


@dataclass(frozen=True)
class _StoneSoupMode(MotionModel):
    """Any other Stone Soup transition model over one interval, in swarmtrack's order: its ``function`` and
    ``jacobian`` (one state at a time; the IMM predicts one state per model)."""

    name: str = "stonesoup"
    source: object = field(default=None, repr=False)
    interval: datetime.timedelta | None = None

    def _state(self, x: np.ndarray) -> State:
        return State(StateVector(reorder(x)))

    def f(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        out = [reorder(np.asarray(self.source.function(self._state(row), time_interval=self.interval), dtype=float))
               for row in x.reshape(-1, x.shape[-1])]
        return np.reshape(out, x.shape)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        p = permutation(x.shape[-1])
        out = [np.asarray(self.source.jacobian(self._state(row), time_interval=self.interval), dtype=float)[
            np.ix_(p, p)] for row in x.reshape(-1, x.shape[-1])]
        return np.reshape(out, x.shape + (x.shape[-1],))


def motion_model(model, time_interval) -> MotionModel:
    """The swarmtrack motion model that predicts like the Stone Soup transition ``model`` over ``time_interval``
    (a ``timedelta``), in swarmtrack's order (module docstring)."""
    if isinstance(model, SwarmtrackTransitionModel):
        model._check(time_interval)
        return model.model
    if time_interval is None:
        raise ValueError(f"{type(model).__name__} needs a prediction interval: give the prior and the prediction "
                         "timestamps")
    n = model.ndim_state
    p = permutation(n)
    Q = np.asarray(model.covar(time_interval=time_interval), dtype=float)[np.ix_(p, p)]
    dt = seconds(time_interval)
    names = tuple(f"s{i}" for i in range(n))
    if type(model) is StoneSoupConstantTurn:  # the same f; swarmtrack's analytic Jacobian
        return ConstantTurn(dt=dt, Q=Q)
    if isinstance(model, LinearModel):
        F = np.asarray(model.matrix(time_interval=time_interval), dtype=float)[np.ix_(p, p)]
        return _LinearMode(dt=dt, Q=Q, state_names=names, matrix=F)
    return _StoneSoupMode(dt=dt, Q=Q, state_names=names, source=model, interval=time_interval)


def _bearing_range(model) -> bool:
    """Whether ``model`` is an unrotated planar ``CartesianToBearingRange`` (swarmtrack's analytic model applies)."""
    return type(model) is CartesianToBearingRange and not np.any(np.asarray(model.rotation_offset, dtype=float))


def linearise(model, x: np.ndarray):
    """A measurement ``model`` at the state ``x`` (n,) in swarmtrack's order: ``h`` (a Stone Soup ``StateVector``,
    its angles typed, so that ``z − h`` wraps them), ``H`` (m, n) in swarmtrack's order and ``R`` (m, m).

    The model is defined on the whole state (``ndim_state == n``) or on the common block (``ndim_state == 4``: a model
    with more states is measured through its first four, ``H`` zero on the rest).
    """
    n = x.size
    m_dim = model.ndim_state
    if m_dim not in (n, COMMON):
        raise ValueError(f"measurement model {type(model).__name__} is defined on {m_dim} states; an IMM model of {n} "
                         f"states takes one defined on all its states or on the common block ({COMMON})")
    xs = reorder(x)[:m_dim]  # Stone Soup's order
    if _bearing_range(model):
        ix, iy = (int(i) for i in model.mapping[:2])
        sensor = np.asarray(model.translation_offset, dtype=float).reshape(-1)[:2]
        (rho, beta), H_rb = polar_model(xs[[ix, iy]], sensor)  # swarmtrack's [ρ, β] and ∂[ρ, β]/∂(x, y)
        h = StateVector([Bearing(beta), rho])
        H_s = np.zeros((2, m_dim))
        H_s[:, [ix, iy]] = H_rb[::-1]
    elif isinstance(model, LinearModel):
        H_s = np.asarray(model.matrix(), dtype=float)
        h = StateVector(H_s @ xs)
    else:
        state = State(StateVector(xs))
        h = model.function(state)
        H_s = np.asarray(model.jacobian(state), dtype=float)
    H = np.zeros((H_s.shape[0], n))
    H[:, :m_dim] = H_s
    return h, H[:, permutation(n)], np.asarray(model.covar(), dtype=float)
