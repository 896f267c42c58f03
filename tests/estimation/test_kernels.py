"""The numba CV fast path (estimation/kernels.py) against the numpy reference (estimation/information.py).

Errors are measured per agent and normwise: ``max|a - b| / max|b|`` over each agent's array. The
information vector is measured against its natural scale ``‖Y‖∞ ‖x‖∞`` (``y = Y x``): right after the
near-zero-information start ``y(k|k-1) = P(k|k-1)⁻¹ x(k|k-1)`` cancels heavily (``P(k|k-1)`` has a 10⁶
velocity variance), and there the reference's own ``y`` is only good to ~1e-9 relative to ``|y|``
(checked against exact rational arithmetic), so no other algorithm can match it elementwise to that.
For the same reason agents only start missing measurements after the first 10 cycles: a cycle without
any measurement right after that start round-trips ``x`` through ``P(k|k-1)⁻¹`` and ``Y⁻¹`` with a
condition number ~1e9, and both implementations then sit ~1e-9 (relative) from the exact ``F x``.
"""

import numpy as np
import pytest

from swarmtrack.estimation.information import (
    FilterDivergence,
    RangeBearingUpdate,
    add_position_information,
    initial_information,
    predict,
    recover,
)
from swarmtrack.estimation.kernels import (
    POSTERIOR_NOT_PD,
    PREDICT_NOT_PD,
    check_flags,
    cv_cycle,
    cv_information_cycle,
    cv_position_contributions,
    cv_predicted_position,
    cv_recover,
)
from swarmtrack.models import make_model

N = 50
DT = 0.05
SIG = (0.08, 0.02)
MIN_RANGE = 0.05
RTOL = 1e-9
N_SENSORS = 3


def _rel(a, b):
    """Per-agent normwise relative error (max over agents)."""
    a = np.asarray(a).reshape(len(a), -1)
    b = np.asarray(b).reshape(len(b), -1)
    return float((np.abs(a - b).max(axis=1) / np.maximum(np.abs(b).max(axis=1), 1e-300)).max())


def _rel_y(y, y_ref, Y_ref, x_ref):
    """Per-agent error of an information vector relative to ``‖Y‖∞ ‖x‖∞`` (max over agents)."""
    scale = np.abs(Y_ref).sum(axis=-1).max(axis=-1) * np.abs(x_ref).max(axis=-1)
    return float((np.abs(y - y_ref).max(axis=-1) / np.maximum(scale, 1e-300)).max())


class _Scenario:
    """N targets moving with random accelerations, each seen by up to 3 sensors 1-10 m away."""

    def __init__(self, seed):
        self.rng = np.random.default_rng(seed)
        self.truth = np.column_stack([self.rng.uniform(-20, 20, (N, 2)), self.rng.normal(0, 1, (N, 2))])
        self.k = 0

    def step(self):
        rng = self.rng
        self.truth[:, :2] += DT * self.truth[:, 2:]
        self.truth[:, 2:] += 0.05 * rng.standard_normal((N, 2))
        ang = rng.uniform(-np.pi, np.pi, (N, N_SENSORS))
        r = rng.uniform(1.0, 10.0, (N, N_SENSORS))
        sensors = self.truth[:, None, :2] - np.stack([r * np.cos(ang), r * np.sin(ang)], axis=-1)
        z = np.stack([r + SIG[0] * rng.standard_normal(r.shape), ang + SIG[1] * rng.standard_normal(r.shape)], -1)
        # Own measurement always; each neighbour's with probability 1/2; from cycle 10 on, 5 % of the agents
        # see nothing at all (prediction only).
        mask = rng.random((N, N_SENSORS)) < 0.5
        mask[:, 0] = True
        dropout = rng.random(N) < 0.05
        if self.k >= 10:
            mask[dropout] = False
        self.k += 1
        return sensors, z, mask


def _fused_reference(x_pred_pos, sensors, z, mask):
    upd = RangeBearingUpdate(*SIG, mode="position", min_range=MIN_RANGE)
    I, i = upd.contributions(x_pred_pos[:, None, :], sensors, z)
    return (I * mask[..., None, None]).sum(1), (i * mask[..., None]).sum(1)


def _fused_kernel(x_pred_pos, sensors, z, mask):
    I = np.zeros((N, 2, 2))
    i = np.zeros((N, 2))
    for s in range(N_SENSORS):
        Is, i_s = cv_position_contributions(
            x_pred_pos, np.ascontiguousarray(sensors[:, s]), np.ascontiguousarray(z[:, s]), *SIG, MIN_RANGE
        )
        I += Is * mask[:, s, None, None]
        i += i_s * mask[:, s, None]
    return I, i


def _start(kind, model, scenario):
    if kind == "near_zero":
        return initial_information(model, N, 1e-6)
    rng = np.random.default_rng(11)
    A = rng.standard_normal((N, 4, 4))
    P0 = 0.3 * A @ np.swapaxes(A, -1, -2) + 0.2 * np.eye(4)
    x0 = scenario.truth + rng.multivariate_normal(np.zeros(4), 0.5 * np.eye(4), N)
    Y = np.linalg.inv(P0)
    Y = 0.5 * (Y + np.swapaxes(Y, -1, -2))
    return Y, np.einsum("nab,nb->na", Y, x0)


@pytest.mark.slow
@pytest.mark.parametrize("q", [None, (0.01, 0.02, 0.3, 0.05)])
@pytest.mark.parametrize("start", ["near_zero", "moderate_prior"])
def test_cycle_matches_reference_over_100_cycles(start, q):
    model = make_model("cv", DT, q)
    qd = np.ascontiguousarray(np.diag(model.Q))
    sc = _Scenario(seed=1 if start == "near_zero" else 2)
    Y, y = _start(start, model, sc)
    x, P = recover(Y, y)
    # A free-running kernel chain (own predictions, own contributions), checked against the reference chain.
    Yk, yk, xk, Pk = Y.copy(), y.copy(), x.copy(), P.copy()
    worst = {}
    for _ in range(100):
        sensors, z, mask = sc.step()
        # Reference cycle.
        Yp, yp, xp = predict(model, x, P)
        I, i = _fused_reference(xp[:, :2], sensors, z, mask)
        Yn, yn = add_position_information(Yp, yp, I, i)
        xn, Pn = recover(Yn, yn)
        # Kernel, one cycle from the reference's state with the reference's contributions.
        Y1, y1, x1, P1 = Y.copy(), y.copy(), x.copy(), P.copy()
        flags = cv_cycle(Y1, y1, x1, P1, DT, qd, I, i)
        assert not flags.any()
        # Kernel chain.
        I2, i2 = _fused_kernel(cv_predicted_position(xk, DT), sensors, z, mask)
        assert not cv_cycle(Yk, yk, xk, Pk, DT, qd, I2, i2).any()
        for name, err in {
            "Y": _rel(Y1, Yn),
            "y": _rel_y(y1, yn, Yn, xn),
            "x": _rel(x1, xn),
            "P": _rel(P1, Pn),
            "chain Y": _rel(Yk, Yn),
            "chain y": _rel_y(yk, yn, Yn, xn),
            "chain x": _rel(xk, xn),
            "chain P": _rel(Pk, Pn),
        }.items():
            worst[name] = max(worst.get(name, 0.0), err)
        Y, y, x, P = Yn, yn, xn, Pn
    assert max(worst.values()) < RTOL, worst
    # The kernel keeps its outputs exactly symmetric.
    np.testing.assert_array_equal(Pk, np.swapaxes(Pk, -1, -2))
    np.testing.assert_array_equal(Yk, np.swapaxes(Yk, -1, -2))


def test_moderate_prior_information_vector_elementwise():
    """Away from the near-zero start the information vector matches to 1e-9 relative to |y| as well."""
    model = make_model("cv", DT)
    qd = np.ascontiguousarray(np.diag(model.Q))
    sc = _Scenario(seed=4)
    Y, y = _start("moderate_prior", model, sc)
    x, P = recover(Y, y)
    for _ in range(20):
        sensors, z, mask = sc.step()
        Yp, yp, xp = predict(model, x, P)
        I, i = _fused_reference(xp[:, :2], sensors, z, mask)
        Yn, yn = add_position_information(Yp, yp, I, i)
        y1 = y.copy()
        cv_cycle(Y.copy(), y1, x.copy(), P.copy(), DT, qd, I, i)
        assert _rel(y1, yn) < RTOL
        Y, y = Yn, yn
        x, P = recover(Y, y)


@pytest.mark.slow
def test_recover_matches_reference():
    model = make_model("cv", DT)
    sc = _Scenario(seed=5)
    Y, y = _start("moderate_prior", model, sc)
    x_ref, P_ref = recover(Y, y)
    x, P, flags = cv_recover(Y, y)
    assert not flags.any()
    assert _rel(x, x_ref) < RTOL
    assert _rel(P, P_ref) < RTOL


@pytest.mark.parametrize("own", [0.0, 0.02])
@pytest.mark.parametrize("min_range", [MIN_RANGE, 1e-4])
@pytest.mark.parametrize("sig", [SIG, (0.4, 0.1)])
def test_position_contributions_match_reference(sig, min_range, own):
    rng = np.random.default_rng(6)
    n = 400
    sensor = rng.uniform(-30, 30, (n, 2))
    r = np.concatenate([rng.uniform(0.0, 0.06, 50), [0.0, 0.0, 1e-5], rng.uniform(0.5, 80.0, n - 53)])
    ang = rng.uniform(-np.pi, np.pi, n)
    x_pos = sensor + np.column_stack([r * np.cos(ang), r * np.sin(ang)])
    x_pos[50] = sensor[50]  # exactly on the sensor
    x_pos[51] = sensor[51] + np.array([-0.0, 0.0])
    z = np.column_stack([r + sig[0] * rng.standard_normal(n), ang + sig[1] * rng.standard_normal(n)])
    I_ref, i_ref = RangeBearingUpdate(*sig, mode="position", min_range=min_range, own_sigma=own).contributions(
        x_pos, sensor, z)
    I, i = cv_position_contributions(x_pos, sensor, z, sig[0], sig[1], min_range, own**2)
    assert _rel(I, I_ref) < RTOL
    assert _rel(i, i_ref) < RTOL
    np.testing.assert_array_equal(I[:, 0, 1], I[:, 1, 0])


def test_predicted_position():
    x = np.random.default_rng(7).standard_normal((10, 4))
    np.testing.assert_allclose(cv_predicted_position(x, DT), x[:, :2] + DT * x[:, 2:], rtol=0, atol=0)


def test_information_cycle_wrapper():
    model = make_model("cv", DT)
    qd = np.diag(model.Q)
    sc = _Scenario(seed=8)
    Y, y = _start("moderate_prior", model, sc)
    sensors, z, mask = sc.step()
    x, P = recover(Y, y)
    Yp, yp, xp = predict(model, x, P)
    I, i = _fused_reference(xp[:, :2], sensors, z, mask)
    Yn, yn = add_position_information(Yp, yp, I, i)
    xn, Pn = recover(Yn, yn)
    # Without x, P (recovered first); inputs as Fortran-ordered copies are not modified.
    Yf, yf = np.asfortranarray(Y), np.asfortranarray(y)
    Y1, y1, x1, P1, flags = cv_information_cycle(Yf, yf, DT, qd, I, i)
    assert not flags.any() and flags.dtype == np.uint8
    np.testing.assert_array_equal(Yf, Y)
    for a, b in [(Y1, Yn), (x1, xn), (P1, Pn)]:
        assert _rel(a, b) < RTOL
    assert _rel_y(y1, yn, Yn, xn) < RTOL
    # With x, P: C-contiguous float64 arrays are updated in place.
    Y2, y2, x2, P2 = Y.copy(), y.copy(), x.copy(), P.copy()
    out = cv_information_cycle(Y2, y2, DT, qd, I, i, x=x2, P=P2)
    assert all(o is a for o, a in zip(out[:4], (Y2, y2, x2, P2), strict=True))
    assert _rel(x2, xn) < RTOL and _rel(P2, Pn) < RTOL
    with pytest.raises(ValueError, match="shape"):
        cv_information_cycle(Y, y, DT, qd, I[:-1], i)


@pytest.mark.slow
def test_divergence_flags():
    model = make_model("cv", DT)
    qd = np.ascontiguousarray(np.diag(model.Q))
    sc = _Scenario(seed=9)
    Y, y = _start("moderate_prior", model, sc)
    x, P = recover(Y, y)
    sensors, z, mask = sc.step()
    Yp, yp, xp = predict(model, x, P)
    I, i = _fused_reference(xp[:, :2], sensors, z, mask)
    Yn, yn = add_position_information(Yp, yp, I, i)
    xn, Pn = recover(Yn, yn)

    P = P.copy()
    I = I.copy()
    i = i.copy()
    P[3] = -np.eye(4)  # prior covariance not PD -> P(k|k-1) not PD
    I[5] = -1e6 * np.eye(2)  # posterior information not PD
    I[7, 0, 1] = np.nan  # non-finite information
    i[9, 1] = np.inf  # non-finite information vector
    Y1, y1, x1, P1 = Y.copy(), y.copy(), x.copy(), P.copy()
    flags = cv_cycle(Y1, y1, x1, P1, DT, qd, I, i)
    assert flags[3] == PREDICT_NOT_PD
    assert flags[5] == flags[7] == flags[9] == POSTERIOR_NOT_PD
    bad = [3, 5, 7, 9]
    assert np.flatnonzero(flags).tolist() == bad
    assert np.isnan(Y1[3]).all() and np.isnan(y1[3]).all()
    assert np.isfinite(Y1[5]).all() and np.isfinite(y1[5]).all()  # the offending posterior is kept
    assert np.isnan(x1[bad]).all() and np.isnan(P1[bad]).all()
    good = np.setdiff1d(np.arange(N), bad)
    assert _rel(x1[good], xn[good]) < RTOL and _rel(P1[good], Pn[good]) < RTOL

    with pytest.raises(FilterDivergence) as err:
        check_flags(flags, 1.5)
    assert err.value.agents == bad
    check_flags(np.zeros(N, np.uint8), 1.5)

    # recover on a non-PD information matrix.
    Ybad = Yn.copy()
    Ybad[2] = np.diag([1.0, -1.0, 1.0, 1.0])
    _, P2, f2 = cv_recover(Ybad, yn)
    assert np.flatnonzero(f2).tolist() == [2] and f2[2] == POSTERIOR_NOT_PD and np.isnan(P2[2]).all()
    *_, f3 = cv_information_cycle(Ybad, yn, DT, qd, np.zeros((N, 2, 2)), np.zeros((N, 2)))
    assert np.flatnonzero(f3).tolist() == [2]


@pytest.mark.slow
def test_fs_cycle_matches_the_reference_over_60_cycles():
    """The compiled FS cycle (12 states, nonlinear f, fake vz = 0 measurement; covariance form) equals the
    information-form reference predict → add_position_information → the fake vz → recover, one cycle from the
    reference's state each time."""
    from swarmtrack.estimation.kernels import fs_cycle

    model = make_model("fs", DT)
    qd = np.ascontiguousarray(np.diag(model.Q))
    w_vz = 1.0 / 0.05**2
    rng = np.random.default_rng(5)
    n = 40
    x = model.initial_state() + np.zeros((n, 12))
    x[:, :4] = rng.normal(0.0, 1.0, (n, 4))
    x[:, 5:7] = rng.normal(0.0, 0.05, (n, 2))
    A = rng.standard_normal((n, 12, 12))
    P = 0.01 * A @ np.swapaxes(A, -1, -2) + np.diag(np.r_[0.1 * np.ones(4), 0.01 * np.ones(8)])
    for _ in range(60):
        Yp, yp, xp = predict(model, x, P)
        I = np.broadcast_to(np.diag([400.0, 300.0]), (n, 2, 2)).copy()
        i = np.einsum("nab,nb->na", I, xp[:, :2] + rng.normal(0.0, 0.05, (n, 2)))
        Yn, yn = add_position_information(Yp, yp, I, i)
        Yn[:, 4, 4] += w_vz
        xn, Pn = recover(Yn, yn)
        x1, P1 = x.copy(), P.copy()
        assert not fs_cycle(x1, P1, DT, qd, I, i, model.mass, model.Ixx, model.Iyy, model.g, w_vz).any()
        np.testing.assert_allclose(x1, xn, rtol=1e-8, atol=1e-10)
        np.testing.assert_allclose(P1, Pn, rtol=1e-7, atol=1e-12)
        x, P = xn, Pn


def test_fs_cycle_flags_a_covariance_that_is_not_positive_definite():
    from swarmtrack.estimation.kernels import PREDICT_NOT_PD, fs_cycle

    model = make_model("fs", DT)
    x = model.initial_state()[None].copy()
    P = -np.eye(12)[None].copy()
    flags = fs_cycle(x, P, DT, np.ascontiguousarray(np.diag(model.Q)), np.zeros((1, 2, 2)),
                     np.zeros((1, 2)), model.mass, model.Ixx, model.Iyy, model.g, 0.0)
    assert flags[0] == PREDICT_NOT_PD and np.isnan(x).all()


def test_fs_cycle_flags_a_posterior_that_is_not_positive_definite():
    """Negative position information (an indefinite Λ) makes (P⁻⁻¹ + M) indefinite: the posterior check fires."""
    from swarmtrack.estimation.kernels import POSTERIOR_NOT_PD, fs_cycle

    model = make_model("fs", DT)
    x = model.initial_state() + np.zeros((2, 12))
    P = np.broadcast_to(0.1 * np.eye(12), (2, 12, 12)).copy()
    I = np.stack([np.diag([400.0, 300.0]), np.diag([-1e6, 300.0])])
    flags = fs_cycle(x, P, DT, np.ascontiguousarray(np.diag(model.Q)), I, np.zeros((2, 2)), model.mass,
                     model.Ixx, model.Iyy, model.g, 400.0)
    assert flags.tolist() == [0, POSTERIOR_NOT_PD] and np.isnan(P[1]).all() and np.isfinite(P[0]).all()


@pytest.mark.slow
def test_the_unrolled_12x12_check_agrees_with_numpys_cholesky():
    """The straight-line LDLᵀ check of fs_cycle says positive definite exactly when numpy's Cholesky succeeds
    (away from singular-to-rounding matrices), and refuses NaN and inf anywhere in the lower triangle."""
    from swarmtrack.estimation.kernels import _positive_definite12

    rng = np.random.default_rng(11)
    for _ in range(200):
        B = rng.standard_normal((12, 12))
        A = B @ B.T + rng.uniform(-3.0, 3.0) * np.eye(12)  # PD or indefinite, far from singular
        if abs(np.linalg.eigvalsh(A)).min() < 1e-6:
            continue
        try:
            np.linalg.cholesky(A)
            expected = True
        except np.linalg.LinAlgError:
            expected = False
        assert _positive_definite12(A) == expected
    A = np.eye(12)
    for r, c in ((0, 0), (5, 2), (11, 0), (11, 11)):
        for bad in (np.nan, np.inf, -np.inf):
            Ab = A.copy()
            Ab[r, c] = bad
            assert not _positive_definite12(Ab)


@pytest.mark.slow
def test_the_unrolled_fs_prediction_is_f_p_ft_plus_q_with_the_models_jacobian():
    """kernels._FS_E (E = F − I, the pattern the unrolled P⁻ is generated from) is models/fs.py's Jacobian, and
    the unrolled P⁻ equals F S Fᵀ + Q for S the symmetric part of P, exactly symmetric."""
    from swarmtrack.estimation import kernels

    model = make_model("fs", DT)
    rng = np.random.default_rng(3)
    x = model.initial_state() + rng.normal(0.0, 0.3, 12)
    J = model.jacobian(x)
    E = np.zeros((12, 12))
    for r, c, _ in kernels._FS_E:
        E[r, c] = J[r, c]
    np.testing.assert_array_equal(np.eye(12) + E, J)
    args = tuple({name: J[r, c] for r, c, name in kernels._FS_E}.values())  # in the generated values' order
    P = rng.standard_normal((1, 12, 12))  # not symmetric: only its symmetric part counts
    A = np.empty((12, 12))
    q = np.diag(model.Q).copy()
    kernels._fs_predicted_covariance(P, 0, A, q, args)
    S = 0.5 * (P[0] + P[0].T)
    np.testing.assert_allclose(A, J @ S @ J.T + np.diag(q), rtol=1e-12, atol=1e-12)
    assert np.array_equal(A, A.T)


@pytest.mark.slow
def test_the_scalar_3x3_solve_equals_numpy_on_every_pivot_order():
    from swarmtrack.estimation.kernels import _solve3

    rng = np.random.default_rng(4)
    for _ in range(300):
        C = rng.standard_normal((3, 3)) * rng.choice([1e-3, 1.0, 1e3], (3, 3))
        B = rng.standard_normal((3, 3))
        X = np.array(_solve3(*(tuple(row) for row in np.hstack([C, B]))))
        np.testing.assert_allclose(C @ X, B, atol=1e-8 * np.linalg.cond(C) * (1 + abs(B).max()))


@pytest.mark.slow
def test_the_compiled_fs_estimator_equals_the_numpy_one_in_the_loop():
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim.engine import simulate

    runs = {k: simulate(load_scenario("l24-fs", [f"kernels={k}", "duration=15"], seed=2)) for k in ("auto", "numpy")}
    np.testing.assert_allclose(np.asarray(runs["auto"].estimate), np.asarray(runs["numpy"].estimate),
                               rtol=1e-7, atol=1e-9)
