"""swarmtrack's IMM inside Stone Soup, and a swarmtrack run as Stone Soup ground truths and tracks
(``pip install swarmtrack[stonesoup]``; ``docs/stonesoup.md``).

Stone Soup has no Gaussian IMM. :class:`IMMPredictor` and :class:`IMMUpdater` are one: a Stone Soup
``Predictor``/``Updater`` pair over :class:`IMMState` (a ``GaussianState``: the combined estimate of the common block
``[x, vx, y, vy]``, with every model's own state and the model probabilities) or :class:`IMMInformationState` (the
same in information form), usable wherever Stone Soup takes a predictor and an updater (its hypothesisers, data
associators and trackers). The numbers are swarmtrack's (``estimation/fusion.py``, ``estimation/kalman.py``), the
standard IMM cycle (Bar-Shalom; W20 Sec. 4.3.2):

1. interaction: :func:`~swarmtrack.estimation.fusion.imm_mix` of the models' common blocks with the Markov matrix
   (``transition_matrix[i, j]`` = P(model i → model j), rows sum to 1), each model's mixed prior completed by
   :func:`~swarmtrack.estimation.fusion.extend_to_model` (the states a model adds beyond the common block, CT's ω, are
   carried by their conditional on it), so the models may have different sizes;
2. every model's EKF prediction, :func:`~swarmtrack.estimation.kalman.ekf_predict`, from its mixed prior;
3. every model's EKF update, :func:`~swarmtrack.estimation.kalman.ekf_update` (Joseph form), with its likelihood
   :func:`~swarmtrack.estimation.fusion.log_gaussian` of the innovation;
4. the model probabilities, :func:`~swarmtrack.estimation.fusion.imm_update` (log space), and the output, the
   moment-matched :func:`~swarmtrack.estimation.fusion.moment_combine` of the common blocks.

States are in Stone Soup's order (``[x, vx, y, vy, …]``); the arithmetic runs in swarmtrack's (``[x, y, vx, vy, …]``),
by the permutation of :mod:`swarmtrack.interop.stonesoup_models`, which also says how each kind of transition and
measurement model is evaluated. The information form is a representation at the boundary: an
:class:`IMMInformationState` prior is turned into moments by solves (:func:`swarmtrack.estimation.information.recover`)
and the results back by solves, so its estimates equal the Gaussian form's to rounding.

:func:`truth_paths` and :func:`estimate_tracks` turn a swarmtrack :class:`~swarmtrack.sim.recorder.Recording` into
Stone Soup ``GroundTruthPath``s and ``Track``s (``stonesoup_runs.py``), so that Stone Soup's metric generators (OSPA,
GOSPA, SIAP) run on swarmtrack output. This module is also the ``stonesoup.plugins`` entry point ``swarmtrack``:
``from stonesoup.plugins.swarmtrack import IMMPredictor``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from stonesoup.base import Property
from stonesoup.models.measurement import MeasurementModel
from stonesoup.models.transition import TransitionModel
from stonesoup.predictor.base import Predictor
from stonesoup.types.array import CovarianceMatrix, StateVector
from stonesoup.types.prediction import (
    GaussianMeasurementPrediction,
    GaussianStatePrediction,
    InformationStatePrediction,
    Prediction,
)
from stonesoup.types.state import GaussianState, InformationState, State, StateMutableSequence
from stonesoup.types.update import GaussianStateUpdate, InformationStateUpdate, Update
from stonesoup.updater.base import Updater

from swarmtrack.estimation import fusion, kalman
from swarmtrack.estimation.information import recover, symmetrize
from swarmtrack.interop.stonesoup_models import (
    SwarmtrackTransitionModel,
    linearise,
    motion_model,
    permutation,
    reorder,
)
from swarmtrack.interop.stonesoup_runs import estimate_tracks, truth_paths

try:  # Stone Soup's cache of a predictor's calls on one prior (its hypothesisers predict a track once per detection)
    from stonesoup.predictor._utils import predict_lru_cache
except ImportError:  # pragma: no cover - a Stone Soup without it: no cache
    def predict_lru_cache():
        return lambda f: f

__all__ = ["IMMInformationState", "IMMInformationStatePrediction", "IMMInformationStateUpdate", "IMMPredictor",
           "IMMState", "IMMStatePrediction", "IMMStateUpdate", "IMMUpdater", "SwarmtrackTransitionModel",
           "estimate_tracks", "truth_paths"]

COMMON = fusion.COMMON
#: How far from 1 the model probabilities and the Markov matrix's rows may sum.
SUM_TOLERANCE = 1e-9


# --- the states -------------------------------------------------------------------------------------------------


def _check_probabilities(p, what: str, n: int | None = None) -> np.ndarray:
    p = np.asarray(p, dtype=float).reshape(-1)
    if (n is not None and p.size != n) or not np.isfinite(p).all() or (p < 0).any() \
            or abs(p.sum() - 1.0) > SUM_TOLERANCE:
        size = f"{n} " if n is not None else ""
        raise ValueError(f"{what} must be {size}non-negative probabilities summing to 1; got {p.tolist()}")
    return p


class IMMState(GaussianState):
    """An IMM's state: the moment-matched combination of its models' common blocks (``state_vector``, ``covar``:
    ``[x, vx, y, vy]``, :func:`~swarmtrack.estimation.fusion.moment_combine`), every model's own Gaussian state
    (``model_states``, each of its model's size, Stone Soup's order) and the model probabilities. Build one from the
    models' states with :meth:`from_model_states`."""

    model_states: Sequence[GaussianState] = Property(doc="Every model's own state, in the transition models' order.")
    model_probabilities: np.ndarray = Property(doc="The probability of each model (sums to 1).")

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.model_probabilities = _check_probabilities(self.model_probabilities, "model_probabilities",
                                                        len(self.model_states))

    @classmethod
    def from_model_states(cls, model_states, model_probabilities, timestamp=None, **kwargs):
        """An IMM state whose combined estimate is the models' (``timestamp``: the models' if not given)."""
        timestamp = timestamp if timestamp is not None else model_states[0].timestamp
        mu = _check_probabilities(model_probabilities, "model_probabilities", len(model_states))
        return _imm_state(cls, *_moments(model_states), mu, timestamp, **kwargs)


class IMMInformationState(InformationState):
    """An IMM's state in information form: the combined common block as ``state_vector`` (``y = Y x``) and
    ``precision`` (``Y = P⁻¹``), every model's own :class:`~stonesoup.types.state.InformationState` and the model
    probabilities. Build one with :meth:`from_model_states`."""

    model_states: Sequence[InformationState] = Property(
        doc="Every model's own state in information form, in the transition models' order.")
    model_probabilities: np.ndarray = Property(doc="The probability of each model (sums to 1).")

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.model_probabilities = _check_probabilities(self.model_probabilities, "model_probabilities",
                                                        len(self.model_states))

    @classmethod
    def from_model_states(cls, model_states, model_probabilities, timestamp=None, **kwargs):
        """An IMM state in information form whose combined estimate is the models' (``model_states``: Gaussian or
        information states)."""
        timestamp = timestamp if timestamp is not None else model_states[0].timestamp
        mu = _check_probabilities(model_probabilities, "model_probabilities", len(model_states))
        return _imm_state(cls, *_moments(model_states), mu, timestamp, **kwargs)


class IMMStatePrediction(Prediction, IMMState):
    """An :class:`IMMState` predicted by :class:`IMMPredictor` (its ``model_probabilities`` are ``μ(k|k−1)``)."""


class IMMStateUpdate(Update, IMMState):
    """An :class:`IMMState` updated by :class:`IMMUpdater`."""


class IMMInformationStatePrediction(Prediction, IMMInformationState):
    """An :class:`IMMInformationState` predicted by :class:`IMMPredictor`."""


class IMMInformationStateUpdate(Update, IMMInformationState):
    """An :class:`IMMInformationState` updated by :class:`IMMUpdater`."""


def _to_information(x: np.ndarray, P: np.ndarray):
    """``(y, Y)`` with ``Y = P⁻¹``, ``y = P⁻¹ x``: one solve of ``P [y Y] = [x I]`` (as ``information.predict``)."""
    sol = np.linalg.solve(P, np.column_stack([x, np.eye(x.size)]))
    return sol[:, 0], symmetrize(sol[:, 1:])


def _moments_of(state) -> tuple[np.ndarray, np.ndarray]:
    """A Stone Soup state's mean and covariance in swarmtrack's order (an information state's by a solve)."""
    if isinstance(state, InformationState):
        x, P = recover(np.asarray(state.precision, dtype=float)[None],
                       np.asarray(state.state_vector, dtype=float).reshape(1, -1))
        return reorder(x[0], P[0])
    if isinstance(state, GaussianState):
        return reorder(state.state_vector, state.covar)
    raise TypeError(f"an IMM model state must be a GaussianState or an InformationState, not {type(state).__name__}")


def _moments(model_states):
    pairs = [_moments_of(s) for s in model_states]
    return [x for x, _ in pairs], [P for _, P in pairs]


def _combine(mu: np.ndarray, xs: list, Ps: list):
    """The moment-matched common block (:func:`fusion.moment_combine`, W20 eq. 4.35), swarmtrack's order."""
    x, P = fusion.moment_combine(mu[None], np.stack([x[:COMMON] for x in xs])[None],
                                 np.stack([P[:COMMON, :COMMON] for P in Ps])[None])
    return x[0], P[0]


def _stonesoup_state(kind: type, x: np.ndarray, P: np.ndarray, timestamp, **kwargs):
    """A Stone Soup state of ``kind`` (Gaussian or information) from swarmtrack-ordered moments."""
    xs, Ps = reorder(x, P)
    if issubclass(kind, InformationState):
        y, Y = _to_information(xs, Ps)
        return kind(StateVector(y), precision=Y, timestamp=timestamp, **kwargs)
    return kind(StateVector(xs), CovarianceMatrix(Ps), timestamp=timestamp, **kwargs)


#: For each IMM state type: the type of its models' states, as a plain state, a prediction and an update.
_MODEL_KINDS = {
    IMMState: GaussianState, IMMStatePrediction: GaussianStatePrediction, IMMStateUpdate: GaussianStateUpdate,
    IMMInformationState: InformationState, IMMInformationStatePrediction: InformationStatePrediction,
    IMMInformationStateUpdate: InformationStateUpdate,
}


def _imm_state(kind: type, xs: list, Ps: list, mu: np.ndarray, timestamp, **kwargs):
    """An IMM state of ``kind`` from every model's swarmtrack-ordered moments; ``kwargs`` (``prior``,
    ``hypothesis`` …) go to the combined state only."""
    model_kind = _MODEL_KINDS[kind]
    extra = {"hypothesis": kwargs["hypothesis"]} if "hypothesis" in kwargs else {}
    models = [_stonesoup_state(model_kind, x, P, timestamp, **extra) for x, P in zip(xs, Ps, strict=True)]
    x, P = _combine(mu, xs, Ps)
    return _stonesoup_state(kind, x, P, timestamp, model_states=models, model_probabilities=mu, **kwargs)


def _imm_prior(prior):
    """The IMM state a prior is (the last state of a track), or a clear error."""
    if isinstance(prior, StateMutableSequence) and not isinstance(prior, State):
        prior = prior.state
    if not isinstance(prior, (IMMState, IMMInformationState)):
        raise TypeError(f"the IMM needs an IMMState or IMMInformationState (IMMState.from_model_states), not "
                        f"{type(prior).__name__}")
    return prior


# --- the predictor --------------------------------------------------------------------------------------------


class IMMPredictor(Predictor):
    """swarmtrack's IMM prediction as a Stone Soup predictor: interaction (mixing) and every model's prediction
    (module docstring, steps 1-2). ``transition_models`` are Stone Soup transition models, one per IMM model, each
    with the common block ``[x, vx, y, vy]`` first and of any size (a 4-state CV and a 5-state CT ``[x, vx, y, vy,
    ω]``); ``transition_matrix[i, j]`` is the probability of switching from model i to model j (rows sum to 1).
    A prior :class:`IMMState` gives an :class:`IMMStatePrediction`, an :class:`IMMInformationState` an
    :class:`IMMInformationStatePrediction`."""

    transition_model = None
    transition_models: Sequence[TransitionModel] = Property(
        doc="One Stone Soup transition model per IMM model, in Stone Soup's order with [x, vx, y, vy] first.")
    transition_matrix: np.ndarray = Property(
        doc="The Markov matrix: transition_matrix[i, j] = P(model i → model j); rows sum to 1.")

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        M = len(self.transition_models)
        if M < 1:
            raise ValueError("an IMM needs at least one transition model")
        for model in self.transition_models:
            permutation(model.ndim_state)  # at least the common block
        rho = np.asarray(self.transition_matrix, dtype=float)
        if rho.shape != (M, M) or not np.isfinite(rho).all() or (rho < 0).any() \
                or not np.allclose(rho.sum(axis=1), 1.0, rtol=0.0, atol=SUM_TOLERANCE):
            raise ValueError(f"transition_matrix must be {M} x {M}, non-negative, with rows summing to 1; "
                             f"got {rho.tolist()}")
        self.transition_matrix = rho

    def _model_moments(self, prior):
        xs, Ps = _moments(prior.model_states)
        M = len(self.transition_models)
        if len(xs) != M:
            raise ValueError(f"the prior has {len(xs)} model states; the predictor has {M} transition models")
        for m, (x, model) in enumerate(zip(xs, self.transition_models, strict=True)):
            if x.size != model.ndim_state:
                raise ValueError(f"model {m}: the prior's state has {x.size} states, its transition model "
                                 f"{type(model).__name__} {model.ndim_state}")
        return xs, Ps, _check_probabilities(prior.model_probabilities, "the prior's model_probabilities", M)

    @predict_lru_cache()
    def predict(self, prior, timestamp=None, control_input=None, **kwargs):
        """Mix (:func:`fusion.imm_mix`, :func:`fusion.extend_to_model`) and predict every model
        (:func:`kalman.ekf_predict`) from ``prior`` (an IMM state or a track ending in one) to ``timestamp``."""
        if control_input is not None:
            raise ValueError("IMMPredictor takes no control input")
        prior = _imm_prior(prior)
        xs, Ps, mu = self._model_moments(prior)
        xc = np.stack([x[:COMMON] for x in xs])[None]
        Pc = np.stack([P[:COMMON, :COMMON] for P in Ps])[None]
        x0c, P0c, mu_pred = fusion.imm_mix(mu[None], self.transition_matrix, xc, Pc)
        interval = None if timestamp is None or prior.timestamp is None else timestamp - prior.timestamp
        x_pred, P_pred = [], []
        for m, (model, x, P) in enumerate(zip(self.transition_models, xs, Ps, strict=True)):
            x0, P0 = fusion.extend_to_model(x[None], P[None], x0c[:, m], P0c[:, m])
            xp, Pp = kalman.ekf_predict(motion_model(model, interval), x0, P0)
            x_pred.append(xp[0])
            P_pred.append(Pp[0])
        kind = IMMInformationStatePrediction if isinstance(prior, InformationState) else IMMStatePrediction
        return _imm_state(kind, x_pred, P_pred, mu_pred[0], timestamp, prior=prior)


# --- the updater ----------------------------------------------------------------------------------------------


class IMMUpdater(Updater):
    """swarmtrack's IMM update as a Stone Soup updater: every model's EKF update, its likelihood, the model
    probabilities and the combined estimate (module docstring, steps 3-4). The measurement model (the detection's,
    else ``measurement_model``) is defined on the common block (``ndim_state`` 4) or on a model's whole state; a
    linear one is used through its matrix, an unrotated ``CartesianToBearingRange`` through swarmtrack's analytic
    range-bearing Jacobian, any other through its ``function`` and ``jacobian``."""

    measurement_model: MeasurementModel = Property(
        default=None, doc="The measurement model used when a detection carries none.")

    def _models(self, predicted_state, measurement_model, measurement, noise: bool = True):
        """Per IMM model: the moments in swarmtrack's order, ``h``, ``H``, the innovation ``z − h`` (Stone Soup's
        angle types wrap it) and its covariance ``S = H P Hᵀ + R``."""
        model = self._check_measurement_model(measurement_model)
        xs, Ps = _moments(predicted_state.model_states)
        out = []
        for x, P in zip(xs, Ps, strict=True):
            h, H, R = linearise(model, x)
            S = symmetrize(H @ P @ H.T + (R if noise else 0.0))
            nu = None if measurement is None else np.asarray(measurement.state_vector - h, dtype=float).reshape(-1)
            out.append((x, P, h, H, R, nu, S))
        return out

    def predict_measurement(self, predicted_state, measurement_model=None, measurement_noise=True, **kwargs):
        """The IMM's predicted measurement: the moment-matched mixture (:func:`fusion.moment_combine`, weights the
        model probabilities) of every model's joint Gaussian of its common block and its measurement, giving the
        mean, the innovation covariance and the cross covariance (common block × measurement, Stone Soup's order).
        Angles are mixed as differences from the first model's (wrapped by Stone Soup's angle types)."""
        predicted_state = _imm_prior(predicted_state)
        parts = self._models(predicted_state, measurement_model, None, measurement_noise)
        h0 = parts[0][2]
        xs, Ps = [], []
        for x, P, h, H, _R, _nu, S in parts:
            cross = P[:COMMON] @ H.T  # (4, m)
            xs.append(np.r_[x[:COMMON], np.asarray(h - h0, dtype=float).reshape(-1)])
            Ps.append(np.block([[P[:COMMON, :COMMON], cross], [cross.T, S]]))
        mu = np.asarray(predicted_state.model_probabilities, dtype=float)
        mean, cov = fusion.moment_combine(mu[None], np.stack(xs)[None], np.stack(Ps)[None])
        mean, cov = mean[0], cov[0]
        p = permutation(COMMON)
        z = h0 + StateVector(mean[COMMON:])
        return GaussianMeasurementPrediction(z, CovarianceMatrix(cov[COMMON:, COMMON:]),
                                             timestamp=predicted_state.timestamp,
                                             cross_covar=CovarianceMatrix(cov[:COMMON, COMMON:][p]))

    def update(self, hypothesis, **kwargs):
        """Every model's update (:func:`kalman.ekf_update`), the likelihoods (:func:`fusion.log_gaussian`), the model
        probabilities (:func:`fusion.imm_update`) and the combined estimate (:func:`fusion.moment_combine`). A
        missed detection (a false hypothesis) keeps the prediction, with ``μ(k|k−1)``."""
        prediction = _imm_prior(hypothesis.prediction)
        kind = IMMInformationStateUpdate if isinstance(prediction, InformationState) else IMMStateUpdate
        mu_pred = np.asarray(prediction.model_probabilities, dtype=float)
        if not hypothesis:
            xs, Ps = _moments(prediction.model_states)
            return _imm_state(kind, xs, Ps, mu_pred, prediction.timestamp, hypothesis=hypothesis)
        measurement = hypothesis.measurement
        model = measurement.measurement_model or self.measurement_model
        if hypothesis.measurement_prediction is None:
            hypothesis.measurement_prediction = self.predict_measurement(prediction, model)
        xs, Ps, loglik = [], [], []
        for x, P, _h, H, R, nu, S in self._models(prediction, model, measurement):
            xu, Pu = kalman.ekf_update(x[None], P[None], H[None], R, nu[None])
            xs.append(xu[0])
            Ps.append(Pu[0])
            loglik.append(fusion.log_gaussian(nu, S))
        mu = fusion.imm_update(mu_pred[None], np.array(loglik)[None], np.ones((1, len(xs)), dtype=bool))[0]
        timestamp = measurement.timestamp if measurement.timestamp is not None else prediction.timestamp
        return _imm_state(kind, xs, Ps, mu, timestamp, hypothesis=hypothesis)
