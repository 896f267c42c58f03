"""swarmtrack's IMM as a Stone Soup predictor/updater pair, and a run as Stone Soup truths and tracks
(interop/stonesoup.py): each test is named after the property it proves.

The reference for the pair is swarmtrack's own IMM functions (``fusion.imm_mix``, ``extend_to_model``,
``kalman.ekf_predict``/``ekf_update``, ``log_gaussian``, ``imm_update``, ``moment_combine``) driven directly on the
same models and data in swarmtrack's state order, and, for models of one size, FilterPy's ``IMMEstimator``.
"""

import datetime
import itertools

import numpy as np
import pytest

pytest.importorskip("stonesoup")

from stonesoup.base import Property  # noqa: E402
from stonesoup.dataassociator.neighbour import NearestNeighbour  # noqa: E402
from stonesoup.deleter.time import UpdateTimeStepsDeleter  # noqa: E402
from stonesoup.hypothesiser.distance import DistanceHypothesiser  # noqa: E402
from stonesoup.initiator.base import Initiator  # noqa: E402
from stonesoup.measures import Euclidean, Mahalanobis  # noqa: E402
from stonesoup.metricgenerator.manager import MultiManager  # noqa: E402
from stonesoup.metricgenerator.ospametric import OSPAMetric  # noqa: E402
from stonesoup.models.measurement.linear import LinearGaussian  # noqa: E402
from stonesoup.models.measurement.nonlinear import CartesianToBearingRange  # noqa: E402
from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity  # noqa: E402
from stonesoup.models.transition.nonlinear import ConstantTurn as SSConstantTurn  # noqa: E402
from stonesoup.tracker.simple import SingleTargetTracker  # noqa: E402
from stonesoup.types.detection import Detection, MissedDetection  # noqa: E402
from stonesoup.types.hypothesis import SingleHypothesis  # noqa: E402
from stonesoup.types.state import GaussianState, InformationState, State  # noqa: E402
from stonesoup.types.track import Track  # noqa: E402

import swarmtrack  # noqa: E402
from swarmtrack.estimation import fusion, kalman  # noqa: E402
from swarmtrack.estimation.information import symmetrize  # noqa: E402
from swarmtrack.interop.stonesoup import (  # noqa: E402
    IMMInformationState,
    IMMInformationStatePrediction,
    IMMInformationStateUpdate,
    IMMPredictor,
    IMMState,
    IMMStatePrediction,
    IMMStateUpdate,
    IMMUpdater,
    SwarmtrackTransitionModel,
    estimate_tracks,
    truth_paths,
)
from swarmtrack.models import ConstantTurn, make_model  # noqa: E402
from swarmtrack.models import ConstantVelocity as STConstantVelocity  # noqa: E402
from swarmtrack.sensors.range_bearing import polar_model, wrap_angle  # noqa: E402

DT = 0.1
T0 = datetime.datetime(2024, 5, 1, 12, 0, 0)
RHO = np.array([[0.95, 0.05], [0.10, 0.90]])
R_POS = np.array([[0.04, 0.01], [0.01, 0.09]])
SIG_RANGE, SIG_BEARING = 0.08, 0.02
SENSOR0 = np.array([-6.0, -4.0])
#: Stone Soup's [x, vx, y, vy, ω] from swarmtrack's [x, y, vx, vy, ω] and back (written out, not imported)
SS = [0, 2, 1, 3, 4]
TOL = 1e-9


def _ss(n):
    return SS[:n]


def _cv(q):
    return CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])


def _ct():
    return SSConstantTurn(linear_noise_coeffs=np.array([0.05, 0.05]), turn_noise_coeff=0.02)


CASES = {  # Stone Soup transition models of each IMM model
    "one-size": lambda: [_cv(0.01), _cv(1.0)],
    "different-sizes": lambda: [_cv(0.05), _ct()],
}


def _swarmtrack_model(ss_model):
    """The swarmtrack model with the same F (or f) and Q, in swarmtrack's order."""
    n = ss_model.ndim_state
    Q = np.asarray(ss_model.covar(time_interval=datetime.timedelta(seconds=DT)))[np.ix_(_ss(n), _ss(n))]
    return STConstantVelocity(dt=DT, Q=Q) if n == 4 else ConstantTurn(dt=DT, Q=Q)


def _initial():
    """Every model's prior in swarmtrack's order and the model probabilities."""
    x = [np.array([0.0, 0.0, 1.0, 0.3]), np.array([0.2, -0.1, 0.9, 0.4, 0.05])]
    P = [np.diag([0.5, 0.5, 0.2, 0.2]), np.diag([0.6, 0.4, 0.3, 0.2, 0.04])]
    P[1][0, 2] = P[1][2, 0] = 0.05
    P[1][3, 4] = P[1][4, 3] = 0.01
    return x, P, np.array([0.6, 0.4])


def _priors(case):
    x, P, mu = _initial()
    if case == "one-size":
        x, P = [x[0], x[0] + 0.1], [P[0], 2.0 * P[0]]
    return x, P, mu


def _turning_truth(steps, turn=0.6):
    x = np.array([0.0, 0.0, 1.0, 0.3])  # swarmtrack's order
    out = []
    for k in range(steps):
        w = turn if k > steps // 3 else 0.0
        c, s = np.cos(w * DT), np.sin(w * DT)
        x = np.array([x[0] + DT * x[2], x[1] + DT * x[3], c * x[2] - s * x[3], s * x[2] + c * x[3]])
        out.append(x.copy())
    return np.array(out)


def _sensor(k):
    return SENSOR0 + np.array([0.05 * k, 0.02 * k])  # the sensor moves: a new model each detection


def _detections(kind, steps=30, seed=7):
    """Stone Soup detections of the turning target, each with its measurement model."""
    rng = np.random.default_rng(seed)
    out = []
    for k, truth in enumerate(_turning_truth(steps), start=1):
        t = T0 + datetime.timedelta(seconds=DT * k)
        if kind == "linear":
            model = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=R_POS)
            z = truth[:2] + rng.multivariate_normal(np.zeros(2), R_POS)
        else:
            model = CartesianToBearingRange(ndim_state=4, mapping=(0, 2),
                                            noise_covar=np.diag([SIG_BEARING**2, SIG_RANGE**2]),
                                            translation_offset=_sensor(k).reshape(2, 1))
            d = truth[:2] - _sensor(k)
            z = [np.arctan2(d[1], d[0]) + SIG_BEARING * rng.standard_normal(),
                 np.hypot(*d) + SIG_RANGE * rng.standard_normal()]
        out.append(Detection(np.array(z, dtype=float).reshape(-1, 1), timestamp=t, measurement_model=model))
    return out


def _measurement(det, k, x):
    """Direct side: ``H`` (m, n) in swarmtrack's order, ``R`` and the innovation of one detection at ``x``."""
    n = x.size
    z = np.asarray(det.state_vector, dtype=float).ravel()
    if isinstance(det.measurement_model, LinearGaussian):
        H = np.zeros((2, n))
        H[0, 0] = H[1, 1] = 1.0
        return H, R_POS, z - x[:2]
    (rho, beta), Hrb = polar_model(x[:2], _sensor(k))  # [ρ, β]; Stone Soup's detections are [β, ρ]
    H = np.zeros((2, n))
    H[:, :2] = Hrb[::-1]
    return H, np.diag([SIG_BEARING**2, SIG_RANGE**2]), np.array([wrap_angle(z[0] - beta), z[1] - rho])


def _direct_imm(models, x, P, mu, dets):
    """swarmtrack's IMM functions driven directly; per step the combined state, mu and every model's state."""
    out = []
    for k, det in enumerate(dets, start=1):
        xc = np.stack([v[:4] for v in x])[None]
        Pc = np.stack([v[:4, :4] for v in P])[None]
        x0c, P0c, mu_pred = fusion.imm_mix(mu[None], RHO, xc, Pc)
        xs, Ps, loglik = [], [], []
        for m, model in enumerate(models):
            x0, P0 = fusion.extend_to_model(x[m][None], P[m][None], x0c[:, m], P0c[:, m])
            xp, Pp = kalman.ekf_predict(model, x0, P0)
            H, R, nu = _measurement(det, k, xp[0])
            S = symmetrize(H @ Pp[0] @ H.T + R)
            xu, Pu = kalman.ekf_update(xp, Pp, H[None], R, nu[None])
            xs.append(xu[0])
            Ps.append(Pu[0])
            loglik.append(fusion.log_gaussian(nu, S))
        mu = fusion.imm_update(mu_pred, np.array(loglik)[None], np.ones((1, len(models)), bool))[0]
        xbar, Pbar = fusion.moment_combine(mu[None], np.stack([v[:4] for v in xs])[None],
                                           np.stack([v[:4, :4] for v in Ps])[None])
        x, P = xs, Ps
        out.append((xbar[0], Pbar[0], mu, [v.copy() for v in xs], [v.copy() for v in Ps]))
    return out


def _imm_prior(x, P, mu, information=False):
    states = [GaussianState(v[_ss(v.size)], C[np.ix_(_ss(v.size), _ss(v.size))], timestamp=T0)
              for v, C in zip(x, P, strict=True)]
    kind = IMMInformationState if information else IMMState
    return kind.from_model_states(states, mu)


def _stonesoup_loop(ss_models, prior, dets):
    """Stone Soup's tracking loop: predict the track to each detection, update with a SingleHypothesis."""
    predictor = IMMPredictor(transition_models=ss_models, transition_matrix=RHO)
    updater = IMMUpdater()
    track = Track([prior])
    for det in dets:
        prediction = predictor.predict(track, timestamp=det.timestamp)
        track.append(updater.update(SingleHypothesis(prediction, det)))
    return track


def _gaussian(state):
    """Mean and covariance of a Stone Soup state in swarmtrack's order (information form by a plain inverse: an
    independent path)."""
    if isinstance(state, InformationState):
        P = np.linalg.inv(np.asarray(state.precision, dtype=float))
        x = P @ np.asarray(state.state_vector, dtype=float).ravel()
    else:
        x, P = np.asarray(state.state_vector, dtype=float).ravel(), np.asarray(state.covar, dtype=float)
    p = _ss(x.size)
    return x[p], P[np.ix_(p, p)]


def _max_difference(track, reference):
    worst = 0.0
    for state, (xbar, Pbar, mu, xs, Ps) in zip(track[1:], reference, strict=True):
        x, P = _gaussian(state)
        parts = [(x, xbar), (P, Pbar), (state.model_probabilities, mu)]
        for s, xm, Pm in zip(state.model_states, xs, Ps, strict=True):
            xg, Pg = _gaussian(s)
            parts += [(xg, xm), (Pg, Pm)]
        worst = max(worst, *(np.max(np.abs(a - b)) for a, b in parts))
    return worst


# --- the IMM pair equals swarmtrack's IMM ---------------------------------------------------------------------


@pytest.mark.parametrize("measurement", ["linear", "bearing-range"])
@pytest.mark.parametrize("case", list(CASES))
def test_a_stone_soup_loop_with_the_imm_pair_equals_swarmtrack_imm_driven_directly(case, measurement):
    ss_models = CASES[case]()
    x, P, mu = _priors(case)
    dets = _detections(measurement)
    reference = _direct_imm([_swarmtrack_model(m) for m in ss_models], x, P, mu, dets)
    track = _stonesoup_loop(ss_models, _imm_prior(x, P, mu), dets)
    assert all(isinstance(s, IMMStateUpdate) for s in track[1:])
    assert _max_difference(track, reference) < TOL
    final = track[-1].model_probabilities
    assert 1e-6 < final.min() and final.max() < 1 - 1e-6  # the probabilities moved, not saturated
    assert np.ptp([s.model_probabilities[0] for s in track]) > 0.05


def test_the_one_size_imm_pair_equals_filterpys_imm_estimator():
    kf = pytest.importorskip("filterpy.kalman")
    ss_models = CASES["one-size"]()
    x, P, mu = _priors("one-size")
    dets = _detections("linear")
    filters = []
    for model, xm, Pm in zip(ss_models, x, P, strict=True):
        f = kf.KalmanFilter(dim_x=4, dim_z=2)
        f.x = xm[SS[:4]].reshape(4, 1).copy()
        f.P = Pm[np.ix_(SS[:4], SS[:4])].copy()
        interval = datetime.timedelta(seconds=DT)
        f.F, f.Q = model.matrix(time_interval=interval), np.asarray(model.covar(time_interval=interval))
        f.H, f.R = dets[0].measurement_model.matrix(), R_POS.copy()
        filters.append(f)
    imm = kf.IMMEstimator(filters, mu.copy(), RHO.copy())
    track = _stonesoup_loop(ss_models, _imm_prior(x, P, mu), dets)
    for state, det in zip(track[1:], dets, strict=True):
        imm.predict()
        imm.update(np.asarray(det.state_vector, dtype=float))
        np.testing.assert_allclose(state.model_probabilities, imm.mu, rtol=0, atol=TOL)
        np.testing.assert_allclose(np.asarray(state.state_vector).ravel(), imm.x.ravel(), rtol=0, atol=TOL)
        np.testing.assert_allclose(state.covar, imm.P, rtol=0, atol=TOL)


class _GivenTrack(Initiator):
    """Starts one track at a given prior (the first time it is asked)."""

    prior: State = Property(doc="The track's first state.")

    def initiate(self, detections, timestamp, **kwargs):
        prior, self.prior = self.prior, None
        return {Track([prior])} if prior is not None else set()


def test_a_stone_soup_tracker_with_the_imm_pair_tracks_as_the_plain_loop():
    """Inside Stone Soup's SingleTargetTracker (a distance hypothesiser on the IMM's predicted measurement, nearest
    neighbour association): with clutter far off, every update equals the plain loop's."""
    ss_models = CASES["different-sizes"]()
    x, P, mu = _initial()
    dets = _detections("linear")
    predictor = IMMPredictor(transition_models=ss_models, transition_matrix=RHO)
    updater = IMMUpdater(measurement_model=dets[0].measurement_model)
    clutter = [Detection(np.array([[40.0], [-30.0]]), timestamp=d.timestamp) for d in dets]  # uses the updater's
    scans = [(T0, set())] + [(d.timestamp, {d, c}) for d, c in zip(dets, clutter, strict=True)]
    hypothesiser = DistanceHypothesiser(predictor, updater, Mahalanobis(), missed_distance=5.0)
    tracker = SingleTargetTracker(initiator=_GivenTrack(_imm_prior(x, P, mu)),
                                  deleter=UpdateTimeStepsDeleter(time_steps_since_update=5),
                                  detector=scans, data_associator=NearestNeighbour(hypothesiser), updater=updater)
    for _ in tracker:
        pass
    (track,) = tracker.tracks
    plain = _stonesoup_loop(ss_models, _imm_prior(x, P, mu), dets)
    assert len(track) == len(plain) and all(isinstance(s, IMMStateUpdate) for s in track[1:])
    for a, b in zip(track[1:], plain[1:], strict=True):
        assert a.hypothesis.measurement in dets
        np.testing.assert_allclose(np.asarray(a.state_vector, float), np.asarray(b.state_vector, float), atol=TOL)
        np.testing.assert_allclose(a.covar, b.covar, atol=TOL)
        np.testing.assert_allclose(a.model_probabilities, b.model_probabilities, atol=TOL)


def test_the_predicted_measurement_is_the_moment_matched_mixture_of_the_models():
    ss_models = CASES["different-sizes"]()
    x, P, mu = _initial()
    predictor = IMMPredictor(transition_models=ss_models, transition_matrix=RHO)
    prediction = predictor.predict(_imm_prior(x, P, mu), timestamp=T0 + datetime.timedelta(seconds=DT))
    assert isinstance(prediction, IMMStatePrediction)
    model = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=R_POS)
    mp = IMMUpdater(measurement_model=model).predict_measurement(prediction)
    w = prediction.model_probabilities
    zs, Ss, Cs = [], [], []
    for s in prediction.model_states:
        xs, Ps = np.asarray(s.state_vector, float).ravel(), np.asarray(s.covar, float)
        zs.append(xs[[0, 2]])
        Ss.append(Ps[np.ix_([0, 2], [0, 2])] + R_POS)
        Cs.append(Ps[:4, [0, 2]])
    zbar = sum(wi * z for wi, z in zip(w, zs, strict=True))
    S = sum(wi * (Si + np.outer(z - zbar, z - zbar)) for wi, z, Si in zip(w, zs, Ss, strict=True))
    xbar = np.asarray(prediction.state_vector, float).ravel()
    C = sum(wi * (Ci + np.outer(np.asarray(s.state_vector, float).ravel()[:4] - xbar, z - zbar))
            for wi, z, Ci, s in zip(w, zs, Cs, prediction.model_states, strict=True))
    np.testing.assert_allclose(np.asarray(mp.state_vector, float).ravel(), zbar, atol=1e-12)
    np.testing.assert_allclose(mp.covar, S, atol=1e-12)
    np.testing.assert_allclose(mp.cross_covar, C, atol=1e-12)


def test_a_missed_detection_keeps_the_prediction_and_its_model_probabilities():
    ss_models = CASES["different-sizes"]()
    x, P, mu = _initial()
    prediction = IMMPredictor(transition_models=ss_models, transition_matrix=RHO).predict(
        _imm_prior(x, P, mu), timestamp=T0 + datetime.timedelta(seconds=DT))
    missed = IMMUpdater().update(SingleHypothesis(prediction, MissedDetection(timestamp=prediction.timestamp)))
    np.testing.assert_array_equal(missed.model_probabilities, prediction.model_probabilities)
    np.testing.assert_allclose(missed.state_vector, prediction.state_vector, atol=1e-15)
    np.testing.assert_allclose(missed.covar, prediction.covar, atol=1e-15)
    np.testing.assert_allclose(prediction.model_probabilities, mu @ RHO, atol=1e-15)


# --- the information form -------------------------------------------------------------------------------------


@pytest.mark.parametrize("measurement", ["linear", "bearing-range"])
def test_the_information_form_round_trip_equals_the_gaussian_form(measurement):
    ss_models = CASES["different-sizes"]()
    x, P, mu = _initial()
    dets = _detections(measurement, steps=15)
    gaussian = _stonesoup_loop(ss_models, _imm_prior(x, P, mu), dets)
    information = _stonesoup_loop(ss_models, _imm_prior(x, P, mu, information=True), dets)
    predictor = IMMPredictor(transition_models=ss_models, transition_matrix=RHO)
    assert isinstance(predictor.predict(information, timestamp=dets[0].timestamp), IMMInformationStatePrediction)
    for g, i in zip(gaussian[1:], information[1:], strict=True):
        assert isinstance(i, IMMInformationStateUpdate)
        assert all(isinstance(s, InformationState) for s in i.model_states)
        xg, Pg = _gaussian(g)
        xi, Pi = _gaussian(i)
        np.testing.assert_allclose(xi, xg, rtol=0, atol=1e-9)
        np.testing.assert_allclose(Pi, Pg, rtol=0, atol=1e-9 * np.abs(Pg).max())
        np.testing.assert_allclose(i.model_probabilities, g.model_probabilities, rtol=0, atol=1e-9)
        np.testing.assert_allclose(np.asarray(i.precision) @ np.asarray(g.covar), np.eye(4), atol=1e-8)  # Y = P⁻¹


# --- the models -------------------------------------------------------------------------------------------------


def test_stone_soups_constant_turn_is_predicted_by_swarmtracks_ct_with_the_same_f():
    """Stone Soup's ConstantTurn is mapped to swarmtrack's CT: the same f, and the analytic Jacobian, which equals
    Stone Soup's finite differences where they are accurate and keeps ∂x'/∂ω = −T² vy / 2 at ω = 0, where Stone
    Soup's ``1 − cos(ωT)`` cancels to 0 under its 1e-8 step."""
    ct = _ct()
    st = _swarmtrack_model(ct)
    interval = datetime.timedelta(seconds=DT)
    for omega in (0.0, 1e-4, 0.3, -2.0):
        xs = np.array([1.0, 0.8, -2.0, 0.4, omega])  # Stone Soup's order
        want = np.asarray(ct.function(State(xs), time_interval=interval), float).ravel()
        np.testing.assert_allclose(st.f(xs[SS])[SS], want, rtol=0, atol=1e-12)
        J = st.jacobian(xs[SS])[np.ix_(SS, SS)]
        if abs(omega) > 0.1:
            np.testing.assert_allclose(J, ct.jacobian(State(xs), time_interval=interval), atol=1e-6)
    J0 = st.jacobian(np.array([1.0, -2.0, 0.8, 0.4, 0.0]))
    np.testing.assert_allclose(J0[:2, 4], [-DT**2 * 0.4 / 2, DT**2 * 0.8 / 2], rtol=1e-12)


def test_a_swarmtrack_model_as_a_stone_soup_transition_model_is_that_model_in_stone_soups_order():
    model = make_model("ct", DT)
    wrapped = SwarmtrackTransitionModel(model)
    interval = datetime.timedelta(seconds=DT)
    xs = np.array([1.0, 0.8, -2.0, 0.4, 0.3])
    assert wrapped.ndim_state == 5
    np.testing.assert_array_equal(np.asarray(wrapped.function(State(xs), time_interval=interval), float).ravel(),
                                  model.f(xs[SS])[SS])
    np.testing.assert_array_equal(wrapped.jacobian(State(xs), time_interval=interval),
                                  model.jacobian(xs[SS])[np.ix_(SS, SS)])
    np.testing.assert_array_equal(wrapped.covar(time_interval=interval), model.Q[np.ix_(SS, SS)])
    with pytest.raises(ValueError, match="fixed period"):
        wrapped.covar(time_interval=datetime.timedelta(seconds=2 * DT))
    # in the IMM: L24's CT model beside Stone Soup's CV, predicted by the swarmtrack model itself
    x, P, mu = _initial()
    dets = _detections("linear", steps=10)
    track = _stonesoup_loop([_cv(0.05), wrapped], _imm_prior(x, P, mu), dets)
    reference = _direct_imm([_swarmtrack_model(_cv(0.05)), model], x, P, mu, dets)
    assert _max_difference(track, reference) < TOL


# --- clear errors -----------------------------------------------------------------------------------------------


def test_invalid_inputs_are_refused_with_clear_errors():
    ss_models = CASES["different-sizes"]()
    with pytest.raises(ValueError, match="rows summing to 1"):
        IMMPredictor(transition_models=ss_models, transition_matrix=np.array([[0.9, 0.2], [0.1, 0.9]]))
    with pytest.raises(ValueError, match="2 x 2"):
        IMMPredictor(transition_models=ss_models, transition_matrix=np.eye(3))
    with pytest.raises(ValueError, match="at least one"):
        IMMPredictor(transition_models=[], transition_matrix=np.ones((0, 0)))
    with pytest.raises(ValueError, match="common block"):
        IMMPredictor(transition_models=[ConstantVelocity(0.1)], transition_matrix=np.eye(1))
    predictor = IMMPredictor(transition_models=ss_models, transition_matrix=RHO)
    x, P, mu = _initial()
    t1 = T0 + datetime.timedelta(seconds=DT)
    with pytest.raises(TypeError, match="IMMState"):
        predictor.predict(GaussianState(x[0], P[0], timestamp=T0), timestamp=t1)
    with pytest.raises(ValueError, match="model_probabilities"):
        _imm_prior(x, P, np.array([0.7, 0.4]))
    swapped = IMMState.from_model_states(list(reversed(_imm_prior(x, P, mu).model_states)), mu[::-1])
    with pytest.raises(ValueError, match="model 0: the prior's state has 5 states"):
        predictor.predict(swapped, timestamp=t1)
    with pytest.raises(ValueError, match="3 model states"):
        prior = _imm_prior(x, P, mu)
        predictor.predict(IMMState.from_model_states([*prior.model_states, prior.model_states[0]],
                                                     [0.5, 0.25, 0.25]), timestamp=t1)
    with pytest.raises(ValueError, match="timestamps"):
        predictor.predict(_imm_prior(x, P, mu), timestamp=None)
    prediction = predictor.predict(_imm_prior(x, P, mu), timestamp=t1)
    with pytest.raises(ValueError, match="No measurement model"):
        IMMUpdater().update(SingleHypothesis(prediction, Detection(np.zeros((2, 1)), timestamp=t1)))
    wrong = LinearGaussian(ndim_state=6, mapping=(0, 2), noise_covar=R_POS)
    with pytest.raises(ValueError, match="defined on 6 states"):
        IMMUpdater(measurement_model=wrong).update(SingleHypothesis(prediction, Detection(np.zeros((2, 1)),
                                                                                          timestamp=t1)))


def test_the_package_is_a_stone_soup_plugin():
    from stonesoup.plugins.swarmtrack import IMMPredictor as FromPlugin

    assert FromPlugin is IMMPredictor


# --- a run as Stone Soup truths and tracks ----------------------------------------------------------------------


def test_a_recording_becomes_ground_truth_paths_and_tracks_in_stone_soups_order():
    t = np.array([0.0, 0.05, 0.1])
    target = np.array([[1.0, 2.0, 0.5, -0.5], [1.1, 1.9, 0.5, -0.5], [1.2, 1.8, 0.5, -0.5]])
    uav = np.zeros((3, 2, 4))
    est = target[:, None, :] + np.array([[0.1, 0.0, 0.0, 0.0], [0.0, -0.2, 0.0, 0.0]])
    est[1, 1] = np.nan  # UAV 2 had no estimate at step 1
    cov = np.broadcast_to(np.diag([1.0, 2.0, 3.0, 4.0]), (3, 2, 4, 4))
    rec = swarmtrack.Recording.from_arrays(t, np.zeros(3, int), ["p"], target, uav, est, cov, d=1.0, r_comm=5.0)
    (truth,) = truth_paths(rec, T0)
    assert truth.id == "targets/1" and len(truth) == 3 and truth[0].metadata == {"group": "targets", "member": 1}
    assert [s.timestamp for s in truth] == [T0 + datetime.timedelta(seconds=s) for s in t]
    np.testing.assert_array_equal(np.asarray(truth[1].state_vector).ravel(), [1.1, 0.5, 1.9, -0.5])
    tracks = {tr.id: tr for tr in estimate_tracks(rec, T0)}
    assert sorted(tracks) == ["uav1", "uav2"] and len(tracks["uav1"]) == 3 and len(tracks["uav2"]) == 2
    np.testing.assert_array_equal(np.asarray(tracks["uav1"][0].state_vector).ravel(), [1.1, 0.5, 2.0, -0.5])
    np.testing.assert_array_equal(np.diag(tracks["uav1"][0].covar), [1.0, 3.0, 2.0, 4.0])
    assert len(truth_paths(rec, T0, groups=["targets", "uavs"])) == 3
    with pytest.raises(ValueError, match="unknown group"):
        truth_paths(rec, T0, groups=["boats"])
    with pytest.raises(TypeError, match="datetime"):
        estimate_tracks(rec, 0.0)


def _direct_ospa(X, Y, c, p):
    """OSPA of order p, cut-off c between point sets X (m, 2) and Y (n, 2) by trying every assignment."""
    if len(X) > len(Y):
        X, Y = Y, X
    m, n = len(X), len(Y)
    if n == 0:
        return 0.0
    d = np.minimum(np.linalg.norm(X[:, None] - Y[None], axis=-1), c) ** p
    best = min(sum(d[i, j] for i, j in enumerate(perm)) for perm in itertools.permutations(range(n), m))
    return ((best + c**p * (n - m)) / n) ** (1.0 / p)


def test_stone_soups_ospa_on_a_converted_run_equals_a_direct_computation():
    rec = swarmtrack.simulate(swarmtrack.load_scenario("l24-ct", ["duration=2"], seed=3))
    c, p = 2.0, 1.5
    truths, tracks = truth_paths(rec, T0), estimate_tracks(rec, T0)
    assert len(truths) == 1 and len(tracks) == rec.n_agents
    manager = MultiManager([OSPAMetric(c=c, p=p, measure=Euclidean(mapping=(0, 2)))])
    manager.add_data({"groundtruth_paths": truths, "tracks": tracks})
    metric = manager.generate_metrics()["ospa_generator"]["OSPA distances"]
    got = {m.timestamp: m.value for m in metric.value}
    want = {}
    for k, s in enumerate(rec.t):
        Y = rec.estimate[k][np.isfinite(rec.estimate[k]).all(axis=1)][:, :2]
        want[T0 + datetime.timedelta(seconds=float(s))] = _direct_ospa(rec.target[k][None, :2], Y, c, p)
    assert got.keys() == want.keys()
    diff = max(abs(got[k] - want[k]) for k in want)
    assert diff < 1e-12
    assert max(want.values()) > min(want.values())  # the distances vary over the run
