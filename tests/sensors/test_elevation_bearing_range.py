"""Range-bearing-elevation sensor (sensors/elevation_bearing_range.py): the analytic model and its Jacobian, the
converted position and its covariance, the planar sensor recovered at zero elevation, and one EKF over CV and CT in
3-D equal to Stone Soup's with ``CartesianToElevationBearingRange``."""

import datetime

import numpy as np
import pytest

from swarmtrack.sensors import elevation_bearing_range as ebr
from swarmtrack.sensors import range_bearing as rb

SIG = (0.08, 0.02, 0.02)


def _pairs(n=50, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(-8, 8, (n, 3)), rng.uniform(-8, 8, (n, 3))


def test_the_measurement_without_noise_converts_back_to_the_target():
    target, sensor = _pairs()
    z = ebr.measure(target, sensor, *SIG, noise=np.zeros((len(target), 3)))
    np.testing.assert_allclose(ebr.to_position(z, sensor), target, atol=1e-12)
    assert np.all(np.abs(z[:, 1]) <= np.pi) and np.all(np.abs(z[:, 2]) <= np.pi / 2)


def test_the_noise_has_each_axis_deviation_and_the_bearing_is_wrapped():
    rng = np.random.default_rng(1)
    target = np.array([-5.0, -1e-3, 1.0])  # a bearing near ±π: noise crosses the cut
    z = ebr.measure(np.broadcast_to(target, (20000, 3)), np.zeros(3), *SIG, rng=rng)
    h = ebr.spherical(target, np.zeros(3))
    err = z - h
    err[:, 1] = rb.wrap_angle(err[:, 1])
    np.testing.assert_allclose(err.std(axis=0), SIG, rtol=0.03)
    assert np.all(np.abs(z[:, 1]) <= np.pi)


def test_the_analytic_jacobian_equals_central_differences():
    target, sensor = _pairs(20, seed=2)
    _, H = ebr.spherical_model(target, sensor)
    step = 1e-6
    for k in range(len(target)):
        for j in range(3):
            e = np.zeros(3)
            e[j] = step
            d = ebr.spherical(target[k] + e, sensor[k]) - ebr.spherical(target[k] - e, sensor[k])
            d[1] = rb.wrap_angle(d[1])
            np.testing.assert_allclose(H[k, :, j], d / (2 * step), rtol=1e-6, atol=1e-7)


def test_the_jacobian_stays_finite_on_the_sensor_and_straight_above_it():
    _, H = ebr.spherical_model(np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 9.0]]), np.array([1.0, 2.0, 3.0]))
    assert np.all(np.isfinite(H))
    R = ebr.position_covariance(6.0, 0.3, np.pi / 2, *SIG)
    assert np.all(np.linalg.eigvalsh(R) > 0)


def test_the_position_covariance_is_the_first_order_propagation_of_the_spherical_noise():
    target, sensor = _pairs(20, seed=4)
    h = ebr.spherical(target, sensor)
    R = ebr.position_covariance(h[:, 0], h[:, 1], h[:, 2], *SIG)
    step = 1e-6
    for k in range(len(h)):
        J = np.empty((3, 3))
        for j in range(3):
            e = np.zeros(3)
            e[j] = step
            J[:, j] = (ebr.to_position(h[k] + e, sensor[k]) - ebr.to_position(h[k] - e, sensor[k])) / (2 * step)
        np.testing.assert_allclose(R[k], J @ np.diag(np.square(SIG)) @ J.T, rtol=1e-6, atol=1e-12)


def test_a_target_level_with_its_sensor_gives_the_planar_sensor_and_a_decoupled_altitude():
    target, sensor = _pairs(30, seed=5)
    target[:, 2] = sensor[:, 2]
    h, H = ebr.spherical_model(target, sensor)
    h2, H2 = rb.polar_model(target[:, :2], sensor[:, :2])
    np.testing.assert_allclose(h[:, :2], h2, rtol=1e-15)
    np.testing.assert_allclose(H[:, :2, :2], H2, rtol=1e-15)
    assert not H[:, :2, 2].any() and not H[:, 2, :2].any()
    R = ebr.position_covariance(h[:, 0], h[:, 1], h[:, 2], *SIG)
    R2 = rb.position_covariance(h[:, 0], h[:, 1], *SIG[:2])
    np.testing.assert_allclose(R[:, :2, :2], R2, rtol=1e-14, atol=1e-18)
    assert not R[:, :2, 2].any()
    np.testing.assert_allclose(R[:, 2, 2], (h[:, 0] * SIG[2]) ** 2, rtol=1e-14)


# --- one EKF against Stone Soup's ---------------------------------------------------------------------------------


def _stone_soup_ekf(transition, steps, sensor, measurements, prior, covariance, dt, analytic, iz):
    """Stone Soup's ExtendedKalmanPredictor and Updater with CartesianToElevationBearingRange on x, y and the
    altitude (index ``iz`` in Stone Soup's order), in its order; with ``analytic`` the measurement model's
    Jacobian is this module's (Stone Soup's own is finite differences)."""
    from stonesoup.models.measurement.nonlinear import CartesianToElevationBearingRange
    from stonesoup.predictor.kalman import ExtendedKalmanPredictor
    from stonesoup.types.detection import Detection
    from stonesoup.types.hypothesis import SingleHypothesis
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import ExtendedKalmanUpdater

    class Analytic(CartesianToElevationBearingRange):
        def jacobian(self, state, **kwargs):
            x = np.asarray(state.state_vector, dtype=float).ravel()
            _, H = ebr.spherical_model(x[list(self.mapping)], np.asarray(self.translation_offset).ravel())
            out = np.zeros((3, self.ndim_state))
            out[:, list(self.mapping)] = H[[2, 1, 0]]  # Stone Soup's [ε, β, ρ]
            return out

    cls = Analytic if analytic else CartesianToElevationBearingRange
    model = cls(ndim_state=len(prior), mapping=(0, 2, iz), noise_covar=np.diag(np.square(SIG[::-1])),
                translation_offset=np.asarray(sensor, dtype=float).reshape(3, 1))
    predictor, updater = ExtendedKalmanPredictor(transition), ExtendedKalmanUpdater(model)
    t0 = datetime.datetime(2024, 5, 1)
    state = GaussianState(prior, covariance, timestamp=t0)
    for k in range(steps):
        t = t0 + datetime.timedelta(seconds=dt * (k + 1))
        pred = predictor.predict(state, timestamp=t)
        det = Detection(np.asarray(measurements[k][::-1]).reshape(3, 1), timestamp=t, measurement_model=model)
        state = updater.update(SingleHypothesis(pred, det))
    return np.asarray(state.state_vector, dtype=float).ravel(), np.asarray(state.covar, dtype=float)


@pytest.mark.parametrize("kind", ["cv", "ct"])
def test_an_ekf_with_the_elevation_bearing_range_update_equals_stone_soups(kind):
    pytest.importorskip("stonesoup")
    from stonesoup.models.transition.base import CombinedGaussianTransitionModel
    from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
    from stonesoup.models.transition.nonlinear import ConstantTurn

    from swarmtrack.estimation.kalman import ekf_predict, ekf_update
    from swarmtrack.interop.stonesoup_models import permutation, stone_soup_order
    from swarmtrack.models.three_d import ConstantTurn3D, ConstantVelocity3D

    dt, steps = 0.1, 25
    interval = datetime.timedelta(seconds=dt)
    if kind == "cv":
        ss = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.05)] * 3)
        cls, truth = ConstantVelocity3D, np.array([1.0, -2.0, 0.8, 0.3, 2.0, 0.2])
    else:
        # Stone Soup's CT Jacobian is finite differences; its CombinedGaussianTransitionModel takes it per block
        class AnalyticTurn(ConstantTurn):
            def jacobian(self, state, time_interval=None, **kwargs):
                p5 = permutation(5)
                x = np.asarray(state.state_vector, dtype=float).ravel()[p5]
                return model.planar.jacobian(x)[np.ix_(p5, p5)]

        ss = CombinedGaussianTransitionModel([AnalyticTurn(linear_noise_coeffs=np.array([0.05, 0.05]),
                                                           turn_noise_coeff=0.001), ConstantVelocity(0.05)])
        cls, truth = ConstantTurn3D, np.array([1.0, -2.0, 0.8, 0.3, 2.0, 0.2, 0.4])
    n = len(truth)
    p = stone_soup_order(cls(dt=dt, Q=np.eye(n)))
    back = np.argsort(p)
    Q = np.asarray(ss.covar(time_interval=interval))[np.ix_(back, back)]
    Q[np.abs(Q) < 1e-300] = 0.0
    model = cls(dt=dt, Q=Q)
    sensor = np.array([-4.0, -3.0, 6.0])
    rng = np.random.default_rng(7)
    xs, measurements = truth, []
    for _ in range(steps):
        xs = model.f(xs)
        measurements.append(ebr.measure(xs[[0, 1, model.altitude_index]], sensor, *SIG, rng=rng))
    x0 = truth + 0.3
    P0 = np.diag(np.full(n, 0.5))

    x, P = x0.copy(), P0.copy()
    iz = model.altitude_index
    for z in measurements:
        x, P = ekf_predict(model, x, P)
        h, Hp = ebr.spherical_model(x[[0, 1, iz]], sensor)
        H = np.zeros((3, n))
        H[:, [0, 1, iz]] = Hp
        nu = z - h
        nu[1] = rb.wrap_angle(nu[1])
        x, P = ekf_update(x, P, H, np.diag(np.square(SIG)), nu)

    iz_ss = int(back[iz])
    got = _stone_soup_ekf(ss, steps, sensor, measurements, x0[p].reshape(-1, 1), P0[np.ix_(p, p)], dt, True, iz_ss)
    np.testing.assert_allclose(got[0][back], x, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(got[1][np.ix_(back, back)], P, rtol=1e-9, atol=1e-14)
    # Stone Soup's own finite-difference Jacobian: the same filter to the accuracy of its differences
    own = _stone_soup_ekf(ss, steps, sensor, measurements, x0[p].reshape(-1, 1), P0[np.ix_(p, p)], dt, False, iz_ss)
    np.testing.assert_allclose(own[0][back], x, rtol=1e-5, atol=1e-6)


def test_the_closed_form_position_information_is_the_inverse_of_the_covariance_with_the_own_variance():
    target, sensor = _pairs(30, seed=6)
    h = ebr.spherical(target, sensor)
    R = ebr.position_covariance(h[:, 0], h[:, 1], h[:, 2], *SIG) + 0.02**2 * np.eye(3)
    info = ebr.position_information(h[:, 0], h[:, 1], h[:, 2], *SIG, own_var=0.02**2)
    np.testing.assert_allclose(info @ R, np.broadcast_to(np.eye(3), R.shape), atol=1e-10)
