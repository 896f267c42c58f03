"""3-D target models (models/three_d.py): analytic Jacobians, the horizontal block predicted as the planar model,
the altitude decoupled, CT exact at ω = 0, and the same transitions as Stone Soup's 3-D models."""

import datetime

import numpy as np
import pytest

from swarmtrack.models import make_model
from swarmtrack.models.three_d import ConstantTurn3D, ConstantVelocity3D

DT = 0.05
PLANAR = {"cv3d": "cv", "ca3d": "ca", "ct3d": "ct"}


def _states(model, n=40, seed=0, omega=None):
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, 3.0, (n, model.dim))
    if model.name == "fs3d":
        x[:, 6:10] *= 0.1  # small angles and rates
        x[:, 12] = 14.7 + rng.normal(0.0, 1.0, n)  # about the hover thrust
    if model.name == "ct3d":
        x[:, 6] = rng.uniform(-2.0, 2.0, n) if omega is None else omega
    return x


def _finite_difference(model, x, h=1e-6):
    J = np.empty((model.dim, model.dim))
    for j in range(model.dim):
        e = np.zeros(model.dim)
        e[j] = h
        J[:, j] = (model.f(x + e) - model.f(x - e)) / (2 * h)
    return J


@pytest.mark.parametrize("name", ["cv3d", "ca3d", "ct3d", "fs3d"])
def test_the_analytic_jacobian_equals_central_differences(name):
    m = make_model(name, DT)
    for x in _states(m, 10):
        np.testing.assert_allclose(m.jacobian(x), _finite_difference(m, x), rtol=1e-7, atol=1e-8)


@pytest.mark.parametrize("name", ["cv3d", "ca3d", "ct3d"])
def test_the_horizontal_states_are_predicted_bit_for_bit_as_the_planar_model_and_the_altitude_apart(name):
    m, planar = make_model(name, DT), make_model(PLANAR[name], DT)
    x = _states(m)
    p, v = m.planar_index, m.vertical_index
    assert [m.state_names[i] for i in p] == list(planar.state_names)
    assert m.state_names[:6] == ("x", "y", "vx", "vy", "z", "vz") and m.altitude_index == 4
    np.testing.assert_array_equal(m.f(x)[:, p], planar.f(x[:, p]))
    J = m.jacobian(x)
    np.testing.assert_array_equal(J[:, p[:, None], p[None, :]], planar.jacobian(x[:, p]))
    assert not J[:, p[:, None], v[None, :]].any() and not J[:, v[:, None], p[None, :]].any()
    moved = x.copy()
    moved[:, v] += 10.0  # another altitude: the horizontal prediction does not change
    np.testing.assert_array_equal(m.f(moved)[:, p], m.f(x)[:, p])
    z, vz = m.f(x)[:, 4], m.f(x)[:, 5]
    az = x[:, 8] if name == "ca3d" else 0.0
    np.testing.assert_allclose(z, x[:, 4] + DT * x[:, 5] + 0.5 * DT**2 * az, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(vz, x[:, 5] + DT * az, rtol=1e-15, atol=1e-15)


def test_ct_in_3d_is_cv_in_3d_at_zero_turn_rate_and_keeps_the_turn_rate_column():
    ct, cv = make_model("ct3d", DT), make_model("cv3d", DT)
    x = _states(ct, omega=0.0)
    np.testing.assert_allclose(ct.f(x)[:, :6], cv.f(x[:, :6]), rtol=0, atol=1e-15)
    J = ct.jacobian(x)
    np.testing.assert_allclose(J[:, 0, 6], -DT**2 * x[:, 3] / 2, rtol=1e-12)  # ∂x'/∂ω = −T² vy / 2
    np.testing.assert_allclose(J[:, 1, 6], DT**2 * x[:, 2] / 2, rtol=1e-12)


def test_a_q_that_couples_the_horizontal_and_the_altitude_states_is_refused():
    Q = np.eye(6) * 0.01
    Q[0, 5] = Q[5, 0] = 0.001
    with pytest.raises(ValueError, match="couples"):
        ConstantVelocity3D(dt=DT, Q=Q)
    with pytest.raises(ValueError, match="length 7"):
        make_model("ct3d", DT, q=[0.01] * 5)


def test_the_initial_information_treats_the_altitude_as_a_kinematic_state():
    ct = make_model("ct3d", DT)
    diag = ct.initial_information_diagonal(1e-6)
    np.testing.assert_array_equal(diag[:6], 1e-6)
    assert diag[6] == 1 / 0.5**2  # the planar CT's turn-rate prior
    ca = make_model("ca3d", DT).initial_information_diagonal(1e-6)
    np.testing.assert_array_equal(ca[6:], 1 / 3.0**2)


def test_the_transitions_equal_stone_soups_3d_models_in_its_order():
    pytest.importorskip("stonesoup")
    from stonesoup.models.transition.base import CombinedGaussianTransitionModel
    from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
    from stonesoup.models.transition.nonlinear import ConstantTurn
    from stonesoup.types.state import State

    from swarmtrack.interop.stonesoup_models import stone_soup_order

    interval = datetime.timedelta(seconds=DT)
    cv_ss = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.3)] * 3)
    p = stone_soup_order(make_model("cv3d", DT))
    back = np.argsort(p)
    Q = np.asarray(cv_ss.covar(time_interval=interval))[np.ix_(back, back)]
    Q[np.abs(Q) < 1e-300] = 0.0
    # swarmtrack's order couples x with vx, as Stone Soup's: a CV in 3-D with Stone Soup's Q
    cv = ConstantVelocity3D(dt=DT, Q=Q)
    np.testing.assert_array_equal(cv.F, np.asarray(cv_ss.matrix(time_interval=interval))[np.ix_(back, back)])

    ct_ss = CombinedGaussianTransitionModel([ConstantTurn(linear_noise_coeffs=np.array([0.3, 0.3]),
                                                          turn_noise_coeff=0.01), ConstantVelocity(0.3)])
    p = stone_soup_order(make_model("ct3d", DT))
    assert [make_model("ct3d", DT).state_names[i] for i in p] == ["x", "vx", "y", "vy", "omega", "z", "vz"]
    back = np.argsort(p)
    Q = np.asarray(ct_ss.covar(time_interval=interval))[np.ix_(back, back)]
    ct = ConstantTurn3D(dt=DT, Q=Q)
    for x in _states(ct, 8, seed=3):
        want = np.asarray(ct_ss.function(State(x[p]), time_interval=interval), dtype=float).ravel()[back]
        np.testing.assert_allclose(ct.f(x), want, rtol=0, atol=1e-12)
        if abs(x[6]) > 0.1:  # Stone Soup's finite differences are accurate away from ω = 0
            J = np.asarray(ct_ss.jacobian(State(x[p]), time_interval=interval), dtype=float)[np.ix_(back, back)]
            np.testing.assert_allclose(ct.jacobian(x), J, atol=1e-6)


def test_fs_in_3d_is_the_planar_fs_plus_its_altitude_without_the_fake_vz_measurement():
    fs3, fs = make_model("fs3d", DT), make_model("fs", DT)
    x = _states(fs3, seed=5)
    others = np.r_[0:4, 5:13]
    np.testing.assert_array_equal(fs3.f(x)[:, others], fs.f(x[:, others]))
    np.testing.assert_array_equal(fs3.f(x)[:, 4], x[:, 4] + DT * x[:, 5])
    np.testing.assert_array_equal(fs3.jacobian(x)[:, others[:, None], others[None, :]], fs.jacobian(x[:, others]))
    assert not hasattr(fs3, "VZ_INDEX")  # the estimators add L24's fake vz = 0 to the planar FS only
    hover = fs3.initial_state()
    np.testing.assert_allclose(fs3.f(hover), hover, atol=1e-12)  # hover thrust: it stays put
    with pytest.raises(ValueError, match="mass"):
        make_model("fs3d", DT, mass=-1.0)
