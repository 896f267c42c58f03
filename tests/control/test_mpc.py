"""W20 Ch. 5's distributed MPC: prediction, side-step points, the QP against closed forms, the controller."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from swarmtrack.control.identification import NAMED_MODELS
from swarmtrack.control.mpc import (
    Condensed,
    FormationQP,
    MPCController,
    MPCSettings,
    SeparationConstraint,
    prediction_matrices,
    propagate_target,
    side_step,
)
from swarmtrack.estimation.base import TargetView
from swarmtrack.models import make_model
from swarmtrack.network.messages import Inbox
from swarmtrack.scenarios import load_scenario

MODEL = NAMED_MODELS["swarmtrack-quadrotor"]


def test_prediction_matrices_equal_stepping_the_model():
    rng = np.random.default_rng(0)
    h = 6
    x0, U = rng.normal(size=4), rng.normal(size=(h, 2))
    Phi, Gamma = prediction_matrices(MODEL.A, MODEL.B, h)
    x, stepped = x0, []
    for l in range(h):
        x = MODEL.A @ x + MODEL.B @ U[l]
        stepped.append(x)
    np.testing.assert_allclose(Phi @ x0 + Gamma @ U.ravel(), np.concatenate(stepped), rtol=0, atol=1e-12)


def test_free_response_holds_the_setpoint_at_the_current_position():
    """Zero relative input = setpoint at p(k) (eq. 5.25 read with relative setpoints)."""
    h = 5
    cond = Condensed.build(MODEL.A, MODEL.B, h)
    x0 = np.array([[3.0, -2.0, 0.4, 0.1]])
    x, out = x0[0], []
    for _ in range(h):
        x = MODEL.A @ x + MODEL.B @ x0[0, :2]
        out.append(x[:2])
    np.testing.assert_allclose(cond.free(x0)[0], np.concatenate(out), atol=1e-12)


@pytest.mark.parametrize(("delta", "expected"), [((1.0, 2.0), (0.0, 5.0)), ((-1.0, 2.0), (-5.0, 0.0)),
                                                 ((-1.0, -2.0), (0.0, -5.0)), ((1.0, -2.0), (5.0, 0.0)),
                                                 ((0.0, 0.0), (0.0, 5.0))])
def test_side_step_follows_the_quadrants_of_eq_5_29(delta, expected):
    np.testing.assert_array_equal(side_step(np.array(delta), 5.0), expected)


def _cost(U, G, f, r, w, R):
    e = G @ U + f - r
    return w * e @ e + R * U @ U


def test_qp_equals_the_unconstrained_minimiser_when_no_bound_is_active():
    s = MPCSettings(horizon=5, bound=100.0, eps=1e-9)
    cond = Condensed.build(MODEL.A, MODEL.B, s.horizon)
    qp = FormationQP(cond.G, s)
    rng = np.random.default_rng(1)
    f, r = rng.normal(size=10), rng.normal(size=10)
    U, status, _ = qp.solve(f, r, s.Q)
    G = cond.G
    exact = np.linalg.solve(s.Q * G.T @ G + s.R * np.eye(10), s.Q * G.T @ (r - f))
    assert status == 1
    np.testing.assert_allclose(U, exact, atol=1e-6)


def test_qp_with_active_bounds_and_a_separation_weight_matches_a_bounded_minimiser():
    s = MPCSettings(horizon=4, bound=0.5, eps=1e-9)
    cond = Condensed.build(MODEL.A, MODEL.B, s.horizon)
    qp = FormationQP(cond.G, s)
    f, r = np.zeros(8), np.tile([6.0, -4.0], 4)
    for w in (s.Q, s.Q + 2 * s.Q_s, s.Q):  # the Hessian's values change with the number of separation terms
        U, status, _ = qp.solve(f, r, w)
        ref = minimize(_cost, np.zeros(8), args=(cond.G, f, r, w, s.R), bounds=[(-0.5, 0.5)] * 8, method="L-BFGS-B",
                       options={"ftol": 1e-15, "gtol": 1e-12})
        assert status == 1
        assert np.abs(U).max() <= 0.5 + 1e-6
        assert _cost(U, cond.G, f, r, w, s.R) <= ref.fun + 1e-5
        np.testing.assert_allclose(U, ref.x, atol=1e-4)


def test_target_propagation_uses_each_uavs_model_and_its_extra_states():
    state = np.array([[0.0, 0.0, 1.0, 0.0]] * 3)
    motion = np.array([[0.0, 0.0, 0.0], [0.2, -0.1, 0.0], [0.0, 0.0, 0.3]])
    view = TargetView(state, np.array(["cv", "ca", "ct"], dtype=object), motion)
    out = propagate_target(view, None, 0.2, 3)
    for i, (name, extra) in enumerate((("cv", []), ("ca", [0.2, -0.1]), ("ct", [0.3]))):
        x = np.concatenate([state[i], extra])[None]
        for l in range(3):
            x = make_model(name, 0.2).f(x)
            np.testing.assert_allclose(out[i, l], x[0, :2], atol=1e-12)
    fixed = propagate_target(view, "cv", 0.2, 3)
    np.testing.assert_allclose(fixed[:, 2], [[0.6, 0.0]] * 3, atol=1e-12)


def _controller(n=1, **kw):
    s = MPCSettings(**kw)
    offsets = np.array([[0.0, 0.0], [10.0, 0.0], [-10.0, 0.0]])[:n]
    return MPCController(MODEL.A, MODEL.B, offsets, s)


def _inbox(nav):
    n = len(nav)
    return Inbox(~np.eye(n, dtype=bool), {"nav": nav})


def test_planned_setpoint_moves_at_most_the_bound_toward_a_far_slot():
    ctrl = _controller(bound=2.0)
    nav = np.zeros((1, 4))
    view = TargetView(np.array([[30.0, -40.0, 0.0, 0.0]]))
    ctrl.command(0.0, nav, view, _inbox(nav), 0.02)
    np.testing.assert_allclose(ctrl.setpoint[0], [2.0, -2.0], atol=1e-4)
    assert ctrl.solves[0] == 1 and ctrl.fallbacks[0] == 0


def test_setpoint_is_only_replanned_every_period():
    ctrl = _controller(period=0.2)
    nav = np.zeros((1, 4))
    view = TargetView(np.array([[1.0, 1.0, 0.0, 0.0]]))
    for k in range(10):  # 0.2 s of 20 ms control steps, then the next plan
        ctrl.command(0.02 * k, nav, view, _inbox(nav), 0.02)
    assert ctrl.solves[0] == 1
    ctrl.command(0.2, nav, view, _inbox(nav), 0.02)
    assert ctrl.solves[0] == 2


def test_separation_term_is_added_only_for_neighbours_within_r_s():
    ctrl = _controller(n=3, r_s=5.0)
    nav = np.array([[0.0, 0.0, 0, 0], [4.0, 0.0, 0, 0], [-9.0, 0.0, 0, 0]])
    view = TargetView(np.zeros((3, 4)))
    ctrl.command(0.0, nav, view, _inbox(nav), 0.02)
    np.testing.assert_array_equal(ctrl.avoiding, [1, 1, 0])


def test_a_solve_that_fails_its_iteration_limit_falls_back_to_a_feasible_setpoint_and_is_counted():
    ctrl = _controller(max_iter=1, bound=1.0)
    nav = np.array([[0.0, 0.0, 0.3, 0.0]])
    view = TargetView(np.array([[20.0, 5.0, 0.0, 0.0]]))
    ctrl.command(0.0, nav, view, _inbox(nav), 0.02)
    assert ctrl.fallbacks[0] == 1
    np.testing.assert_array_equal(ctrl.setpoint[0], [0.0, 0.0])  # the last setpoint: hold where it was
    nav2 = np.array([[5.0, 0.0, 0.0, 0.0]])  # moved away: the held setpoint is clipped into the new bounds
    ctrl.command(0.2, nav2, view, _inbox(nav2), 0.02)
    assert ctrl.fallbacks[0] == 2
    np.testing.assert_allclose(ctrl.setpoint[0], [4.0, 0.0])


def test_no_estimate_yet_keeps_the_uav_holding():
    ctrl = _controller()
    nav = np.array([[1.0, 2.0, 0.0, 0.0]])
    ctrl.command(0.0, nav, TargetView(np.full((1, 4), np.nan)), _inbox(nav), 0.02)
    np.testing.assert_array_equal(ctrl.setpoint[0], [1.0, 2.0])
    assert ctrl.solves[0] == 0


# --- Issue 42: the separation constraint -------------------------------------------------

#: The model identified on the 5° quadrotor (the simulated W20 scenarios' controller.model)
_, LIMITED_A, LIMITED_B = load_scenario("w20-mpc-collision").controller.uav_model()


def _separated_qp(slots=1, bound=1.0, h=5):
    s = MPCSettings(horizon=h, bound=bound, eps=1e-9, separation=1.0)
    cond = Condensed.build(LIMITED_A, LIMITED_B, h)
    return s, cond, FormationQP(cond.G, s, slots=slots)


def test_the_qp_with_separation_rows_matches_a_constrained_minimiser():
    """UAV i at the origin heads for a slot beyond its neighbour j at (1.6, 0): its planned positions keep to its side
    of the bisector x = 0.8, d/2 + margin away, where the unconstrained plan would not."""
    s, cond, qp = _separated_qp()
    x0 = np.array([[0.0, 0.0, 0.6, 0.0]])
    f, r = cond.free(x0)[0], np.tile([6.0, 0.3], 5)
    margins = np.linspace(0.05, 0.25, 5)
    normal = np.array([[-1.0, 0.0]])  # Δ = p_i − p_j = (−1.6, 0)
    rhs = 0.5 + margins + normal[0] @ [0.8, 0.0] - np.einsum("a,la->l", normal[0], f.reshape(5, 2))
    cons = SeparationConstraint(normal, rhs[None])
    U, status, _ = qp.solve(f, r, s.Q, cons)
    assert status == 1
    positions = (cond.G @ U + f).reshape(5, 2)
    assert np.all(0.8 - positions[:, 0] >= 0.5 + margins - 1e-6)
    rows = np.einsum("a,lau->lu", normal[0], cond.G.reshape(5, 2, 10))
    ref = minimize(lambda u: _cost(u, cond.G, f, r, s.Q, s.R) / 1e3, np.zeros(10), method="SLSQP",
                   bounds=[(-1, 1)] * 10, constraints=[{"type": "ineq", "fun": lambda u: rows @ u - rhs}],
                   options={"ftol": 1e-15, "maxiter": 500})
    assert ref.success and _cost(U, cond.G, f, r, s.Q, s.R) <= 1e3 * ref.fun + 1e-5
    np.testing.assert_allclose(U, ref.x, atol=2e-4)
    free, _, _ = FormationQP(cond.G, MPCSettings(horizon=5, bound=1.0, eps=1e-9)).solve(f, r, s.Q)
    assert (cond.G @ free + f)[-2] > 0.3  # without the constraint it would come closer


def test_an_unmeetable_separation_is_softened_and_counted_not_a_fallback():
    """Two UAVs 1.2 m apart closing at 2 m/s: no input within ±0.3 m keeps them 1 m apart over the horizon."""
    ctrl = MPCController(LIMITED_A, LIMITED_B, np.array([[0.0, 0.0], [10.0, 0.0]]),
                         MPCSettings(bound=0.3, separation=1.0, margins=(0.05,) * 5))
    nav = np.array([[0.0, 0.0, 1.0, 0.0], [1.2, 0.0, -1.0, 0.0]])
    view = TargetView(np.array([[0.0, 5.0, 0.0, 0.0]] * 2))
    ctrl.command(0.0, nav, view, _inbox(nav), 0.02)
    assert ctrl.softened.tolist() == ctrl.relaxed.tolist() == [1, 1] and ctrl.fallbacks.tolist() == [0, 0]
    assert {"softened", "relaxed"} <= set(ctrl.sample()) and "relaxed" in [p.name for p in ctrl.probes]


def test_without_neighbours_the_separation_changes_no_plan_bit_for_bit():
    nav = np.array([[0.0, 0.0, 0.3, -0.2], [20.0, 3.0, 0.0, 0.1]])
    view = TargetView(np.array([[4.0, 1.0, 0.5, 0.0]] * 2))
    plans = []
    for sep in (None, 1.0):
        ctrl = MPCController(LIMITED_A, LIMITED_B, np.array([[0.0, 0.0], [10.0, 0.0]]),
                             MPCSettings(separation=sep, margins=(0.1,) * 5 if sep else ()))
        for k in range(3):
            ctrl.command(0.2 * k, nav, view, _inbox(nav), 0.2)
        plans.append(ctrl.setpoint.copy())
        assert ("relaxed" in ctrl.sample()) is (sep is not None)
    np.testing.assert_array_equal(plans[0], plans[1])
