"""The W20 Ch. 4 fusion kernels (estimation/fusion.py): each test is named after the property it proves.

The reference for the IMM is FilterPy's ``IMMEstimator`` (a dev dependency): its ``M[i, j]`` is the probability
of switching from filter i to filter j, ``mu`` is updated as ``cbar * likelihood`` normalised, and ``x``, ``P``
after ``update`` are the moment-matched combination of its filters.
"""

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from swarmtrack.estimation.fusion import (
    extend_to_model,
    imm_mix,
    imm_predict,
    imm_update,
    log_gaussian,
    ml_fuse,
    moment_combine,
    select_least_max_eigenvalue,
    select_least_trace,
    ttest_select,
    window_score,
)

RHO = np.array([[0.90, 0.05, 0.05], [0.10, 0.80, 0.10], [0.05, 0.15, 0.80]])


def _spd(rng, *shape, d=4, scale=1.0):
    A = rng.standard_normal(shape + (d, d))
    return scale * (A @ np.swapaxes(A, -1, -2) + 0.5 * np.eye(d))


def _inv(A):
    return np.linalg.inv(A)


def _is_pd(A):
    try:
        np.linalg.cholesky(A)
        return True
    except np.linalg.LinAlgError:
        return False


# --- T-test --------------------------------------------------------------------------------------------------


def test_window_score_is_the_mean_of_available_entries_and_nan_when_empty():
    w = np.array([[1.0, 2.0, 3.0, 6.0], [np.nan, np.nan, 4.0, 2.0], [np.nan] * 4])
    s = window_score(w)
    np.testing.assert_allclose(s[:2], [3.0, 3.0])
    assert np.isnan(s[2])


def test_ttest_picks_the_lowest_mean_ignoring_invalid_and_nan_candidates():
    windows = np.array([[5.0, 5.0, 5.0], [1.0, 1.0, np.nan], [0.5, 0.5, 0.5], [np.nan] * 3])
    score = np.tile(window_score(windows), (4, 1))
    valid = np.array([[1, 1, 1, 1], [1, 1, 0, 1], [1, 0, 0, 1], [0, 0, 0, 1]], dtype=bool)
    np.testing.assert_array_equal(ttest_select(score, valid), [2, 1, 0, -1])


def test_ttest_breaks_ties_to_the_lowest_index():
    score = np.array([[2.0, 1.0, 1.0], [3.0, 3.0, 3.0]])
    np.testing.assert_array_equal(ttest_select(score, np.ones((2, 3), bool)), [1, 0])


# --- log-likelihood ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("m", [1, 2, 3, 4, 6])  # unrolled Cholesky up to 4, LAPACK above
def test_log_gaussian_equals_scipy_and_marks_non_pd_rows_nan(m):
    rng = np.random.default_rng(1)
    S = _spd(rng, 6, d=m)
    nu = rng.standard_normal((6, m))
    expected = [multivariate_normal.logpdf(nu[k], cov=S[k]) for k in range(6)]
    np.testing.assert_allclose(log_gaussian(nu, S), expected, rtol=1e-12)
    S_bad = S.copy()
    S_bad[2] = -np.eye(m)  # not positive definite
    S_bad[4, 0, 0] = np.nan
    out = log_gaussian(nu, S_bad)
    assert np.isnan(out[[2, 4]]).all()
    np.testing.assert_allclose(np.delete(out, [2, 4]), np.delete(expected, [2, 4]), rtol=1e-12)


# --- mode probabilities --------------------------------------------------------------------------------------


def test_imm_predict_is_one_markov_step_and_stays_normalised():
    rng = np.random.default_rng(2)
    mu = rng.dirichlet(np.ones(3), size=5)
    out = imm_predict(mu, RHO)
    direct = np.array([[sum(RHO[i, j] * mu[b, i] for i in range(3)) for j in range(3)] for b in range(5)])
    np.testing.assert_allclose(out, direct, rtol=1e-15)
    np.testing.assert_allclose(out.sum(axis=1), 1.0, rtol=1e-15)


def test_imm_update_equals_the_direct_formula_on_moderate_numbers():
    rng = np.random.default_rng(3)
    mu_pred = rng.dirichlet(np.ones(4), size=7)
    loglik = rng.uniform(-8.0, 2.0, (7, 4))
    direct = mu_pred * np.exp(loglik)
    direct /= direct.sum(axis=1, keepdims=True)
    np.testing.assert_allclose(imm_update(mu_pred, loglik, np.ones((7, 4), bool)), direct, rtol=1e-14)


def test_imm_update_stays_finite_and_normalised_for_underflowing_likelihoods():
    mu_pred = np.array([[0.2, 0.5, 0.3]])
    loglik = np.array([[-2000.0, -2001.0, -2005.0]])  # exp() underflows to 0 for every candidate
    out = imm_update(mu_pred, loglik, np.ones((1, 3), bool))
    assert np.isfinite(out).all()
    np.testing.assert_allclose(out.sum(), 1.0, rtol=1e-15)
    shifted = imm_update(mu_pred, loglik + 2000.0, np.ones((1, 3), bool))  # the same ratios, no underflow
    np.testing.assert_allclose(out, shifted, rtol=1e-11)  # log μ − 2000 keeps ~2000 ε of absolute precision


def test_imm_update_keeps_the_prediction_of_candidates_without_evidence():
    mu_pred = np.array([[0.1, 0.2, 0.3, 0.4], [0.25, 0.25, 0.25, 0.25]])
    loglik = np.array([[0.0, np.log(3.0), np.nan, 5.0], [1.0, 2.0, 3.0, 4.0]])
    valid = np.array([[1, 1, 1, 0], [0, 0, 0, 0]], dtype=bool)
    out = imm_update(mu_pred, loglik, valid)
    # row 0: candidate 2 has NaN loglik, candidate 3 is invalid: both keep μ_pred; 0 and 1 share their 0.3
    # in proportion 0.1·1 : 0.2·3
    np.testing.assert_allclose(out[0], [0.3 * 0.1 / 0.7, 0.3 * 0.6 / 0.7, 0.3, 0.4], rtol=1e-14)
    np.testing.assert_allclose(out[0].sum(), 1.0, rtol=1e-15)
    np.testing.assert_array_equal(out[1], mu_pred[1])  # no evidence at all


# --- moment matching -----------------------------------------------------------------------------------------


def test_moment_combine_equals_the_mixture_moments_with_renormalised_weights():
    rng = np.random.default_rng(4)
    w = rng.uniform(0.1, 1.0, (3, 4))
    x = rng.standard_normal((3, 4, 5))
    P = _spd(rng, 3, 4, d=5)
    xb, Pb = moment_combine(3.0 * w, x, P)  # weights need not sum to 1
    wn = w / w.sum(axis=1, keepdims=True)
    for b in range(3):
        xe = sum(wn[b, m] * x[b, m] for m in range(4))
        Pe = sum(wn[b, m] * (P[b, m] + np.outer(x[b, m] - xe, x[b, m] - xe)) for m in range(4))
        np.testing.assert_allclose(xb[b], xe, rtol=1e-13)
        np.testing.assert_allclose(Pb[b], Pe, rtol=1e-13)
    np.testing.assert_array_equal(Pb, np.swapaxes(Pb, -1, -2))


def test_moment_combine_ignores_nan_candidates_with_zero_weight():
    rng = np.random.default_rng(5)
    x = rng.standard_normal((2, 3, 4))
    P = _spd(rng, 2, 3)
    w = np.array([[0.5, 0.0, 0.5], [0.2, 0.8, 0.0]])
    x_nan, P_nan = x.copy(), P.copy()
    x_nan[0, 1] = np.nan
    P_nan[0, 1] = np.nan
    x_nan[1, 2] = np.nan
    P_nan[1, 2] = np.inf
    a = moment_combine(w, x_nan, P_nan)
    b = moment_combine(w, x, P)
    assert np.isfinite(a[0]).all() and np.isfinite(a[1]).all()
    np.testing.assert_allclose(a[0], b[0], rtol=1e-15)
    np.testing.assert_allclose(a[1], b[1], rtol=1e-15)


def test_moment_combine_of_a_single_weight_one_is_that_candidate():
    rng = np.random.default_rng(6)
    x = rng.standard_normal((1, 3, 4))
    P = _spd(rng, 1, 3)
    x[0, 0] = np.nan
    xb, Pb = moment_combine(np.array([[0.0, 1.0, 0.0]]), x, P)
    np.testing.assert_allclose(xb[0], x[0, 1], rtol=1e-15)
    np.testing.assert_allclose(Pb[0], P[0, 1], rtol=1e-15)


# --- IMM mixing ----------------------------------------------------------------------------------------------


def _mix_loop(mu, rho, x, P, valid):
    B, M, d = x.shape
    x0, P0 = np.empty_like(x), np.empty_like(P)
    for b in range(B):
        src = [i for i in range(M) if valid[b, i]]
        for j in range(M):
            c = sum(rho[i, j] * mu[b, i] for i in src)
            wts = {i: rho[i, j] * mu[b, i] / c for i in src}
            x0[b, j] = sum(wts[i] * x[b, i] for i in src)
            P0[b, j] = sum(wts[i] * (P[b, i] + np.outer(x[b, i] - x0[b, j], x[b, i] - x0[b, j])) for i in src)
    return x0, P0


def test_imm_mix_equals_the_textbook_interaction_step():
    rng = np.random.default_rng(7)
    mu = rng.dirichlet(np.ones(3), size=4)
    x = rng.standard_normal((4, 3, 4))
    P = _spd(rng, 4, 3)
    x0, P0, mu_pred = imm_mix(mu, RHO, x, P)
    xe, Pe = _mix_loop(mu, RHO, x, P, np.ones((4, 3), bool))
    np.testing.assert_allclose(x0, xe, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(P0, Pe, rtol=1e-13)
    np.testing.assert_allclose(mu_pred, imm_predict(mu, RHO), rtol=1e-15)


def test_imm_mix_excludes_invalid_candidates_and_renormalises_the_weights():
    rng = np.random.default_rng(8)
    mu = rng.dirichlet(np.ones(3), size=3)
    x = rng.standard_normal((3, 3, 4))
    P = _spd(rng, 3, 3)
    valid = np.array([[1, 0, 1], [1, 1, 1], [0, 1, 0]], dtype=bool)
    x[~valid] = np.nan
    P[~valid] = np.nan
    x0, P0, mu_pred = imm_mix(mu, RHO, x, P, valid)
    xe, Pe = _mix_loop(mu, RHO, x, P, valid)
    np.testing.assert_allclose(x0, xe, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(P0, Pe, rtol=1e-13)
    np.testing.assert_allclose(mu_pred, imm_predict(mu, RHO), rtol=1e-15)  # mass of invalid ones is carried


def test_imm_mix_with_an_identity_transition_matrix_does_not_mix():
    rng = np.random.default_rng(9)
    mu = rng.dirichlet(np.ones(3), size=2)
    x = rng.standard_normal((2, 3, 4))
    P = _spd(rng, 2, 3)
    x0, P0, mu_pred = imm_mix(mu, np.eye(3), x, P)
    np.testing.assert_allclose(x0, x, rtol=1e-15)
    np.testing.assert_allclose(P0, P, rtol=1e-15)
    np.testing.assert_allclose(mu_pred, mu, rtol=1e-15)


# --- maximum-likelihood fusion -------------------------------------------------------------------------------


def test_ml_fuse_of_two_candidates_equals_the_closed_form():
    rng = np.random.default_rng(10)
    x = rng.standard_normal((5, 2, 4))
    P = _spd(rng, 5, 2)
    xf, Pf = ml_fuse(x, P, np.ones((5, 2), bool), np.zeros(5, int))
    for b in range(5):
        P1, P2 = P[b]
        Si = _inv(P1 + P2)
        np.testing.assert_allclose(xf[b], P2 @ Si @ x[b, 0] + P1 @ Si @ x[b, 1], rtol=1e-11, atol=1e-12)
        np.testing.assert_allclose(Pf[b], _inv(_inv(P1) + _inv(P2)), rtol=1e-11, atol=1e-12)


def test_ml_fuse_of_two_candidates_does_not_depend_on_which_is_first():
    rng = np.random.default_rng(11)
    x = rng.standard_normal((5, 2, 4))
    P = _spd(rng, 5, 2)
    valid = np.ones((5, 2), bool)
    a = ml_fuse(x, P, valid, np.zeros(5, int))
    b = ml_fuse(x, P, valid, np.ones(5, int))
    np.testing.assert_allclose(a[0], b[0], rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(a[1], b[1], rtol=1e-11, atol=1e-12)


def test_ml_fuse_covariance_is_spd_and_no_larger_than_either_input():
    rng = np.random.default_rng(12)
    x = rng.standard_normal((50, 2, 4))
    P = np.concatenate([_spd(rng, 50, 1, scale=1e-3), _spd(rng, 50, 1, scale=1e2)], axis=1)  # very unequal
    _, Pf = ml_fuse(x, P, np.ones((50, 2), bool), np.zeros(50, int))
    np.testing.assert_array_equal(Pf, np.swapaxes(Pf, -1, -2))
    assert np.linalg.eigvalsh(Pf).min() > 0
    for m in range(2):
        gap = np.linalg.eigvalsh(P[:, m] - Pf)
        assert (gap.min(axis=-1) > -1e-12 * np.abs(gap).max(axis=-1)).all()


def test_ml_fuse_of_several_equals_the_information_sum_over_valid_candidates_only():
    rng = np.random.default_rng(13)
    x = rng.standard_normal((4, 4, 4))
    P = _spd(rng, 4, 4)
    valid = np.array([[1, 1, 1, 1], [1, 0, 1, 1], [0, 1, 0, 1], [1, 0, 0, 0]], dtype=bool)
    first = np.array([2, 3, 1, 0])
    x[~valid] = np.nan
    P[~valid] = np.nan
    xf, Pf = ml_fuse(x, P, valid, first)
    for b in range(4):
        Y = sum(_inv(P[b, m]) for m in range(4) if valid[b, m])
        y = sum(_inv(P[b, m]) @ x[b, m] for m in range(4) if valid[b, m])
        np.testing.assert_allclose(Pf[b], _inv(Y), rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(xf[b], np.linalg.solve(Y, y), rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(xf[3], x[3, 0])  # alone: the own estimate unchanged


def test_ml_fuse_gives_nan_where_the_own_candidate_is_missing():
    rng = np.random.default_rng(14)
    x = rng.standard_normal((2, 3, 4))
    P = _spd(rng, 2, 3)
    valid = np.array([[0, 1, 1], [1, 1, 1]], dtype=bool)
    xf, Pf = ml_fuse(x, P, valid, np.array([0, -1]))
    assert np.isnan(xf).all() and np.isnan(Pf).all()


# --- extension to a larger model -----------------------------------------------------------------------------


@pytest.mark.parametrize("n", [5, 6])
def test_extend_to_model_keeps_positive_definiteness(n):
    rng = np.random.default_rng(15 + n)
    B = 200
    P = _spd(rng, B, d=n)
    x = rng.standard_normal((B, n))
    Pc = _spd(rng, B, d=4, scale=10.0 ** rng.uniform(-3, 3, (B, 1, 1)))
    xc = rng.standard_normal((B, 4))
    x_new, P_new = extend_to_model(x, P, xc, Pc)
    assert x_new.shape == (B, n) and P_new.shape == (B, n, n)
    np.testing.assert_array_equal(x_new[:, :4], xc)
    np.testing.assert_allclose(P_new[:, :4, :4], Pc, rtol=1e-15)
    assert _is_pd(P_new)


@pytest.mark.parametrize("n", [5, 6])
def test_extend_to_model_reproduces_the_input_given_its_own_common_block(n):
    rng = np.random.default_rng(20 + n)
    P = _spd(rng, 10, d=n)
    x = rng.standard_normal((10, n))
    x_new, P_new = extend_to_model(x, P, x[:, :4], P[:, :4, :4])
    np.testing.assert_allclose(x_new, x, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(P_new, P, rtol=1e-12, atol=1e-13)


def test_extend_to_model_keeps_the_extra_states_conditional_on_the_common_block():
    rng = np.random.default_rng(30)
    P = _spd(rng, 5, d=6)
    x = rng.standard_normal((5, 6))
    Pc = _spd(rng, 5)
    xc = rng.standard_normal((5, 4))
    _, P_new = extend_to_model(x, P, xc, Pc)
    G_old = P[:, 4:, :4] @ _inv(P[:, :4, :4])
    G_new = P_new[:, 4:, :4] @ _inv(P_new[:, :4, :4])
    np.testing.assert_allclose(G_new, G_old, rtol=1e-10, atol=1e-12)
    schur_old = P[:, 4:, 4:] - G_old @ P[:, :4, 4:]
    schur_new = P_new[:, 4:, 4:] - G_new @ P_new[:, :4, 4:]
    np.testing.assert_allclose(schur_new, schur_old, rtol=1e-9, atol=1e-11)


def test_extend_to_model_of_the_same_size_returns_the_common_block():
    rng = np.random.default_rng(31)
    xc, Pc = rng.standard_normal((3, 4)), _spd(rng, 3)
    x_new, P_new = extend_to_model(rng.standard_normal((3, 4)), _spd(rng, 3), xc, Pc)
    np.testing.assert_array_equal(x_new, xc)
    np.testing.assert_allclose(P_new, Pc, rtol=1e-15)


# --- occlusion policies --------------------------------------------------------------------------------------


def test_occlusion_policies_pick_the_least_trace_and_least_largest_eigenvalue_among_valid():
    rng = np.random.default_rng(32)
    Ppos = _spd(rng, 40, 4, d=2)
    valid = rng.uniform(size=(40, 4)) < 0.7
    valid[0] = False
    tr = np.trace(Ppos, axis1=-2, axis2=-1)
    lam = np.linalg.eigvalsh(Ppos)[..., -1]
    for policy, value in ((select_least_trace, tr), (select_least_max_eigenvalue, lam)):
        got = policy(Ppos, valid)
        assert got[0] == -1
        expected = np.where(valid.any(1), np.argmin(np.where(valid, value, np.inf), axis=1), -1)
        np.testing.assert_array_equal(got, expected)


def test_the_two_occlusion_policies_differ_on_an_elongated_covariance():
    Ppos = np.array([[[[4.0, 0.0], [0.0, 0.1]], [[2.5, 0.0], [0.0, 2.5]]]])  # trace 4.1 vs 5, max eig 4 vs 2.5
    valid = np.ones((1, 2), bool)
    assert select_least_trace(Ppos, valid)[0] == 0
    assert select_least_max_eigenvalue(Ppos, valid)[0] == 1


# --- a full IMM cycle against FilterPy ------------------------------------------------------------------------

DT = 0.1
F_CV = np.array([[1, 0, DT, 0], [0, 1, 0, DT], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=float)
H_POS = np.eye(2, 4)
R_POS = np.array([[0.5, 0.1], [0.1, 0.3]])
Q_SCALES = (0.01, 1.0, 25.0)


def _q(scale):
    g = np.array([[DT**2 / 2, 0], [0, DT**2 / 2], [DT, 0], [0, DT]])
    return scale * g @ g.T + 1e-9 * np.eye(4)


def _initial():
    x = np.array([[10.0, -5.0, 1.0, 0.5], [11.0, -4.0, 0.0, 0.0], [9.0, -6.0, 2.0, -1.0]])
    P = np.stack([np.diag([4.0, 4.0, 1.0, 1.0]) * s for s in (1.0, 2.0, 0.5)])
    return x, P, np.array([0.5, 0.3, 0.2])


def _measurements(steps):
    rng = np.random.default_rng(40)
    truth = np.array([10.0, -5.0, 1.5, 0.8])
    z = []
    for k in range(steps):
        if k == steps // 2:
            truth[2:] = [-2.0, 3.0]  # a manoeuvre, so the probabilities move
        truth = F_CV @ truth
        z.append(truth[:2] + rng.multivariate_normal(np.zeros(2), R_POS))
    return np.array(z)


def _batched_imm_step(mu, x, P, z):
    """One IMM step with the fusion kernels and a numpy Kalman filter per model (B, 3 models)."""
    Q = np.stack([_q(s) for s in Q_SCALES])
    x0, P0, mu_pred = imm_mix(mu, RHO, x, P)
    xp = x0 @ F_CV.T
    Pp = F_CV @ P0 @ F_CV.T + Q
    S = H_POS @ Pp @ H_POS.T + R_POS
    PHt = Pp @ H_POS.T
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, -1, -2)), -1, -2)
    nu = z[:, None, :] - xp @ H_POS.T
    xu = xp + (K @ nu[..., None])[..., 0]
    A = np.eye(4) - K @ H_POS
    Pu = A @ Pp @ np.swapaxes(A, -1, -2) + K @ R_POS @ np.swapaxes(K, -1, -2)
    mu = imm_update(mu_pred, log_gaussian(nu, S), np.ones(mu.shape, bool))
    xc, Pc = moment_combine(mu, xu, Pu)
    return mu, xu, Pu, xc, Pc


def test_batched_imm_cycle_equals_filterpy_imm_estimator():
    kalman = pytest.importorskip("filterpy.kalman")
    x_init, P_init, mu_init = _initial()
    filters = []
    for m, s in enumerate(Q_SCALES):
        kf = kalman.KalmanFilter(dim_x=4, dim_z=2)
        kf.x = x_init[m].reshape(4, 1).copy()
        kf.P = P_init[m].copy()
        kf.F, kf.H, kf.R, kf.Q = F_CV.copy(), H_POS.copy(), R_POS.copy(), _q(s)
        filters.append(kf)
    imm = kalman.IMMEstimator(filters, mu_init.copy(), RHO.copy())

    mu, x, P = mu_init[None].copy(), x_init[None].copy(), P_init[None].copy()
    z_all = _measurements(12)
    for z in z_all:
        imm.predict()
        imm.update(z)
        mu, x, P, xc, Pc = _batched_imm_step(mu, x, P, z[None])
        np.testing.assert_allclose(mu[0], imm.mu, rtol=1e-10, atol=1e-14)
        np.testing.assert_allclose(xc[0], imm.x.ravel(), rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(Pc[0], imm.P, rtol=1e-10, atol=1e-12)
        for m, kf in enumerate(filters):
            np.testing.assert_allclose(x[0, m], kf.x.ravel(), rtol=1e-10, atol=1e-10)
            np.testing.assert_allclose(P[0, m], kf.P, rtol=1e-10, atol=1e-12)
    assert imm.mu.max() < 0.99 and imm.mu.min() > 1e-6  # the probabilities were exercised, not saturated


def test_batched_imm_of_stacked_identical_problems_equals_the_single_problem():
    x_init, P_init, mu_init = _initial()
    B = 7
    single = (mu_init[None].copy(), x_init[None].copy(), P_init[None].copy())
    stacked = (np.tile(mu_init, (B, 1)), np.tile(x_init, (B, 1, 1)), np.tile(P_init, (B, 1, 1, 1)))
    for z in _measurements(8):
        *single, xc1, Pc1 = _batched_imm_step(*single, z[None])
        *stacked, xcB, PcB = _batched_imm_step(*stacked, np.tile(z, (B, 1)))
        for got, want in zip((*stacked, xcB, PcB), (*single, xc1, Pc1), strict=True):
            np.testing.assert_array_equal(got, np.broadcast_to(got[:1], got.shape))  # rows identical
            # numpy may take another code path for another batch size: equal to rounding, normwise
            np.testing.assert_allclose(got, np.broadcast_to(want, got.shape), rtol=0, atol=1e-13 * np.abs(want).max())
