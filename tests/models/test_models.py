"""Properties of the target motion models (L24 Sec. 3.1, W20 eqs. 2.37-2.39) and of make_model."""

from __future__ import annotations

import numpy as np
import pytest

from swarmtrack.models import (
    DEFAULT_Q_DIAG,
    MODEL_NAMES,
    ConstantAcceleration,
    ConstantTurn,
    ConstantVelocity,
    FullStateQuadrotor,
    make_model,
)
from swarmtrack.models.ct import SMALL_TURN
from swarmtrack.models.fs import VZ_INDEX

DT = 0.05


def numerical_jacobian(f, x: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    n = x.shape[-1]
    J = np.zeros((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = eps
        J[:, j] = (f(x + e) - f(x - e)) / (2 * eps)
    return J


def random_state(name: str, rng: np.random.Generator) -> np.ndarray:
    model = make_model(name, DT)
    x = rng.normal(size=model.dim)
    if name == "ct":
        x[4] = rng.uniform(-1.0, 1.0)
    if name == "fs":
        x[5:7] = rng.uniform(-0.4, 0.4, size=2)
        x[11] = model.mass * model.g * rng.uniform(0.8, 1.2)
    return x


# --- Jacobians -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_analytic_jacobian_matches_central_differences_at_random_states(name):
    rng = np.random.default_rng(1)
    model = make_model(name, DT)
    for _ in range(5):
        x = random_state(name, rng)
        np.testing.assert_allclose(model.jacobian(x), numerical_jacobian(model.f, x), atol=1e-7, rtol=1e-6)


@pytest.mark.parametrize(
    "omega",
    [0.0, 1e-7, 1e-4, -1e-4, SMALL_TURN / DT, -SMALL_TURN / DT, SMALL_TURN / DT * (1 + 1e-9), 0.5, -2.0],
)
def test_ct_jacobian_matches_central_differences_including_small_turn_rates(omega):
    model = make_model("ct", DT)
    x = np.array([1.0, -2.0, 3.0, -1.5, omega])
    J = model.jacobian(x)
    assert np.all(np.isfinite(J))
    np.testing.assert_allclose(J, numerical_jacobian(model.f, x, eps=1e-5), atol=1e-8, rtol=1e-6)


def test_ct_omega_column_at_zero_turn_rate_has_the_series_limit():
    model = make_model("ct", DT)
    vx, vy = 3.0, -1.5
    J = model.jacobian(np.array([0.0, 0.0, vx, vy, 0.0]))
    # d/dω of sin(ωT)/ω is 0 at ω = 0 and of (1 − cos ωT)/ω is T²/2.
    np.testing.assert_allclose(J[:2, 4], [-vy * DT**2 / 2, vx * DT**2 / 2], rtol=1e-14)
    np.testing.assert_allclose(J[2:4, 4], [-DT * vy, DT * vx], rtol=1e-14)


# --- CT ----------------------------------------------------------------------------------------------------


def test_ct_f_and_jacobian_are_continuous_across_the_small_turn_threshold():
    model = make_model("ct", DT)
    w0 = SMALL_TURN / DT
    for sign in (1.0, -1.0):
        below = np.array([1.0, -2.0, 3.0, -1.5, sign * w0 * (1 - 1e-14)])
        above = np.array([1.0, -2.0, 3.0, -1.5, sign * w0 * (1 + 1e-14)])
        assert abs(below[4] * DT) < SMALL_TURN <= abs(above[4] * DT)  # the two sides use different branches
        np.testing.assert_allclose(model.f(below), model.f(above), rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(model.jacobian(below), model.jacobian(above), rtol=1e-9, atol=1e-14)


def test_ct_at_zero_turn_rate_propagates_like_cv():
    ct, cv = make_model("ct", DT), make_model("cv", DT)
    x = np.array([1.0, -2.0, 3.0, -1.5])
    out = ct.f(np.append(x, 0.0))
    np.testing.assert_allclose(out[:4], cv.f(x), rtol=1e-15, atol=1e-15)
    assert out[4] == 0.0
    # a tiny turn rate departs from CV only by O(ω·T·|v|)
    out = ct.f(np.append(x, 1e-7))
    np.testing.assert_allclose(out[:4], cv.f(x), atol=1e-7 * DT * 4)
    np.testing.assert_allclose(ct.jacobian(np.append(x, 0.0))[:4, :4], cv.jacobian(x), atol=1e-15)


@pytest.mark.parametrize("omega", [0.3, -0.7, 2.0])
def test_ct_turns_the_velocity_vector_by_omega_times_dt(omega):
    model = make_model("ct", DT)
    v = np.array([3.0, -1.5])
    out = model.f(np.array([0.0, 0.0, *v, omega]))
    v_new = out[2:4]
    assert np.linalg.norm(v_new) == pytest.approx(np.linalg.norm(v), rel=1e-12)
    angle = np.arctan2(v[0] * v_new[1] - v[1] * v_new[0], v @ v_new)
    assert angle == pytest.approx(omega * DT, rel=1e-10)


def test_ct_follows_the_exact_circle_over_a_full_turn():
    omega, speed, radius = 0.5, 2.0, 4.0  # radius = speed/omega
    model = make_model("ct", DT)
    x = np.array([radius, 0.0, 0.0, speed, omega])  # counter-clockwise circle around the origin
    steps = round(2 * np.pi / omega / DT)
    for _ in range(steps):
        x = model.f(x)
        assert np.hypot(x[0], x[1]) == pytest.approx(radius, rel=1e-10)


# --- linear models -----------------------------------------------------------------------------------------


def test_cv_and_ca_transition_matrices_follow_l24_and_w20():
    cv = ConstantVelocity(dt=DT, Q=np.eye(4))
    ca = ConstantAcceleration(dt=DT, Q=np.eye(6))
    x = np.array([1.0, 2.0, 3.0, 4.0, 0.5, -0.2])
    np.testing.assert_allclose(cv.f(x[:4]), [1 + 3 * DT, 2 + 4 * DT, 3, 4])
    np.testing.assert_allclose(
        ca.f(x),
        [1 + 3 * DT + 0.25 * DT**2, 2 + 4 * DT - 0.1 * DT**2, 3 + 0.5 * DT, 4 - 0.2 * DT, 0.5, -0.2],
    )
    assert cv.linear and ca.linear
    assert not make_model("ct", DT).linear and not make_model("fs", DT).linear


def test_linear_jacobian_is_a_writable_copy_of_f():
    model = make_model("cv", DT)
    J = model.jacobian(np.zeros((3, 4)))
    J[0, 0, 0] = 99.0
    np.testing.assert_array_equal(model.jacobian(np.zeros(4)), model.F)


# --- FS ----------------------------------------------------------------------------------------------------


def test_fs_hovers_with_level_attitude_and_thrust_mg():
    model = make_model("fs", DT)
    x0 = model.initial_state()
    assert x0[11] == pytest.approx(1.5 * 9.81)
    assert np.count_nonzero(x0) == 1
    x = x0.copy()
    x[[0, 1, 2, 3]] = [1.0, -2.0, 0.5, 0.0]
    out = model.f(x)
    assert out[VZ_INDEX] == pytest.approx(0.0, abs=1e-15)
    np.testing.assert_allclose(out[2:4], x[2:4], atol=1e-15)
    np.testing.assert_allclose(out[5:], x[5:], atol=1e-15)
    np.testing.assert_allclose(out[:2], x[:2] + DT * x[2:4])


def test_fs_pitch_accelerates_along_x_and_roll_along_minus_y():
    model = make_model("fs", DT)
    x = model.initial_state()
    x[6] = 0.1  # pitch
    out = model.f(x)
    assert out[2] == pytest.approx(DT * 9.81 * np.sin(0.1))
    x = model.initial_state()
    x[5] = 0.1  # roll
    assert model.f(x)[3] == pytest.approx(-DT * 9.81 * np.sin(0.1))


def test_fs_defaults_are_the_px4_iris_and_expose_vz_index():
    model = make_model("fs", DT)
    assert (model.mass, model.Ixx, model.Iyy, model.g) == (1.5, 0.029, 0.029, 9.81)
    assert FullStateQuadrotor.VZ_INDEX == VZ_INDEX == 4
    assert model.state_names[VZ_INDEX] == "vz"
    heavy = make_model("fs", DT, mass=2.0, Ixx=0.05)
    assert heavy.mass == 2.0 and heavy.Ixx == 0.05
    assert heavy.initial_state()[11] == pytest.approx(2.0 * 9.81)


# --- batching ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_batched_f_and_jacobian_have_batch_shapes_and_equal_per_item_results(name):
    rng = np.random.default_rng(7)
    model = make_model(name, DT)
    n = model.dim
    X = np.stack([random_state(name, rng) for _ in range(21)]).reshape(7, 3, n)
    if name == "ct":
        X[0, 0, 4] = 0.0  # mix series and closed-form branches in one batch
    fx, J = model.f(X), model.jacobian(X)
    assert fx.shape == (7, 3, n) and J.shape == (7, 3, n, n)
    for i in range(7):
        for j in range(3):
            np.testing.assert_allclose(fx[i, j], model.f(X[i, j]), rtol=1e-14, atol=1e-14)
            np.testing.assert_allclose(J[i, j], model.jacobian(X[i, j]), rtol=1e-14, atol=1e-14)
    assert model.f(X[0, 0]).shape == (n,) and model.jacobian(X[0, 0]).shape == (n, n)


# --- make_model --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "cls", "dim"),
    [
        ("cv", ConstantVelocity, 4),
        ("ca", ConstantAcceleration, 6),
        ("ct", ConstantTurn, 5),
        ("fs", FullStateQuadrotor, 12),
    ],
)
def test_make_model_builds_each_model_with_default_q(name, cls, dim):
    model = make_model(name, DT)
    assert isinstance(model, cls) and model.name == name and model.dim == dim and model.dt == DT
    assert model.Q.shape == (dim, dim)
    np.testing.assert_array_equal(np.diag(model.Q), DEFAULT_Q_DIAG[name])
    np.testing.assert_array_equal(model.Q, np.diag(np.diag(model.Q)))
    assert model.initial_state().shape == (dim,)


def test_default_q_matches_l24_section_4():
    assert DEFAULT_Q_DIAG["cv"] == (0.05**2,) * 4
    assert DEFAULT_Q_DIAG["ct"] == (0.05**2,) * 4 + (0.02**2,)
    assert DEFAULT_Q_DIAG["fs"] == (0.05**2,) * 5 + (0.02**2,) * 4 + (0.01**2,) * 3


def test_make_model_uses_the_given_q_diagonal():
    model = make_model("cv", 0.1, q=[1.0, 2.0, 3.0, 4.0])
    np.testing.assert_array_equal(model.Q, np.diag([1.0, 2.0, 3.0, 4.0]))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(name="cx", dt=DT), "unknown motion model"),
        (dict(name="cv", dt=0.0), "dt"),
        (dict(name="cv", dt=-0.1), "dt"),
        (dict(name="cv", dt=float("nan")), "dt"),
        (dict(name="cv", dt=DT, q=[1.0, 1.0, 1.0]), "length 4"),
        (dict(name="ct", dt=DT, q=np.ones((5, 5))), "length 5"),
        (dict(name="cv", dt=DT, q=[1.0, 0.0, 1.0, 1.0]), "positive"),
        (dict(name="cv", dt=DT, q=[1.0, -1.0, 1.0, 1.0]), "positive"),
        (dict(name="cv", dt=DT, q=[1.0, np.inf, 1.0, 1.0]), "finite"),
        (dict(name="cv", dt=DT, mass=2.0), "unknown parameter"),
        (dict(name="fs", dt=DT, mass=-1.0), "mass"),
    ],
)
def test_make_model_rejects_bad_input_with_value_error_naming_the_problem(kwargs, match):
    with pytest.raises(ValueError, match=match):
        make_model(**kwargs)
