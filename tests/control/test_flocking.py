"""Properties of the flocking protocols (L24 Sec. 2, L23 Sec. 2 and Fig. 1)."""

from __future__ import annotations

import numpy as np
import pytest

from swarmtrack.control import (
    FlockingGains,
    FlockingState,
    bump,
    flocking_control,
    inter_agent_distances,
    phi,
    sigma_norm,
)

NO_CLIP = FlockingGains(accel_limit=np.inf)


# --------------------------------------------------------------------------- primitives


def test_sigma_norm_values_and_smooth_at_zero():
    eps = 0.1
    z = np.array([[3.0, 4.0], [0.0, 0.0]])
    expected = (np.sqrt(1 + eps * np.array([25.0, 0.0])) - 1) / eps
    np.testing.assert_allclose(sigma_norm(z, eps), expected, rtol=1e-12)
    # no cancellation for tiny vectors: ‖z‖σ ≈ ‖z‖²/2
    assert sigma_norm(np.array([1e-9, 0.0]), eps) == pytest.approx(5e-19, rel=1e-9)
    assert sigma_norm(np.zeros(2), eps) == 0.0
    # gradient z/√(1+ε‖z‖²) → 0 at the origin: one-sided difference quotients vanish (differentiable at 0,
    # unlike ‖z‖ whose quotient is 1)
    for hstep in (1e-3, 1e-5):
        assert sigma_norm(np.array([hstep, 0.0]), eps) / hstep == pytest.approx(hstep / 2, rel=1e-3)
    # batched over leading axes
    assert sigma_norm(np.ones((4, 5, 2)), eps).shape == (4, 5)


def test_phi_is_odd_and_bounded():
    z = np.linspace(-50, 50, 101)
    np.testing.assert_allclose(phi(-z), -phi(z))
    assert np.all(np.abs(phi(z)) < 1.0)
    assert phi(0.0) == 0.0


def test_bump_is_one_below_h_zero_beyond_one_and_continuous():
    h = 0.3
    assert np.all(bump(np.linspace(0, h - 1e-9, 50), h) == 1.0)
    assert np.all(bump(np.array([1.0 + 1e-9, 1.5, 10.0]), h) == 0.0)
    assert bump(1.0, h) == pytest.approx(0.0, abs=1e-15)
    assert bump(h, h) == 1.0
    z = np.linspace(0, 1.2, 120001)
    b = bump(z, h)
    assert np.max(np.abs(np.diff(b))) < 1e-3  # no jumps
    assert np.all(np.diff(b) <= 1e-15)  # non-increasing


# --------------------------------------------------------------------------- protocol terms


def _two_agents(spacing):
    q = np.array([[0.0, 0.0], [spacing, 0.0]])
    return q, np.zeros((2, 2))


def _u(q, p, variant="standard", gains=NO_CLIP, q_t=None, p_t=None, nb=None, state=None):
    n = len(q)
    q_t = np.zeros((n, 2)) if q_t is None else q_t
    p_t = np.zeros((n, 2)) if p_t is None else p_t
    nb = np.ones((n, n), bool) if nb is None else nb
    state = FlockingState.zeros(n) if state is None else state
    return flocking_control(q, p, q_t, p_t, nb, state, gains, variant, 0.05)


def test_distance_regulator_zero_at_d_repulsive_inside_attractive_outside():
    g = FlockingGains(K_dt=0.0, K_vt=0.0, accel_limit=np.inf)  # isolate u_d
    q, p = _two_agents(g.d)
    q_t = q.copy()  # no target pull
    u, _ = _u(q, p, gains=g, q_t=q_t)
    np.testing.assert_allclose(u, 0.0, atol=1e-12)
    u, _ = _u(*_two_agents(g.d - 0.5), gains=g, q_t=q_t)
    assert u[0, 0] < 0 < u[1, 0]  # pushed apart
    u, _ = _u(*_two_agents(g.d + 0.3), gains=g, q_t=q_t)
    assert u[0, 0] > 0 > u[1, 0]  # pulled together
    np.testing.assert_allclose(u[0], -u[1])  # action = reaction


def test_velocity_consensus_drives_equal_velocities():
    g = FlockingGains(K_d=0.0, K_dt=0.0, K_vt=0.0, accel_limit=np.inf)
    rng = np.random.default_rng(1)
    q = rng.uniform(-1.5, 1.5, (4, 2))  # all well within r_comm and frozen (only p evolves)
    p = rng.normal(size=(4, 2))
    mean0 = p.mean(axis=0)
    for _ in range(400):
        u, _ = _u(q, p, gains=g, q_t=q)
        p = p + 0.05 * u
    np.testing.assert_allclose(p, np.broadcast_to(mean0, p.shape), atol=1e-6)  # average consensus


def test_non_neighbours_contribute_nothing():
    rng = np.random.default_rng(2)
    q = rng.uniform(-2, 2, (4, 2))
    p = rng.normal(size=(4, 2))
    nb = np.ones((4, 4), bool)
    nb[0, 3] = False
    u_masked, _ = _u(q, p, nb=nb)
    # moving agent 3 arbitrarily changes nothing for agent 0 once it is not a neighbour of 0
    q2, p2 = q.copy(), p.copy()
    q2[3] += [0.7, -0.4]
    p2[3] += [3.0, 1.0]
    u_moved, _ = _u(q2, p2, nb=nb)
    np.testing.assert_allclose(u_masked[0], u_moved[0])
    # and agents beyond r_comm are ignored even when the mask allows them
    q3 = q.copy()
    q3[3] = [100.0, 100.0]
    u_far, _ = _u(q3, p, nb=np.ones((4, 4), bool))
    u_cut, _ = _u(q3, p, nb=nb)
    np.testing.assert_allclose(u_far[0], u_cut[0])


def _naive(q, p, q_t, p_t, nb, state, g, variant, dt):
    """Double-loop reference written straight from L24 eq. 1-3 / L23 eq. 2-10."""
    n = len(q)
    sig = lambda z: (np.sqrt(1 + g.eps * z @ z) - 1) / g.eps  # noqa: E731
    sig_d = (np.sqrt(1 + g.eps * g.d**2) - 1) / g.eps
    sig_r = (np.sqrt(1 + g.eps * g.r_comm**2) - 1) / g.eps

    def a(z):
        if 0 <= z < g.h:
            return 1.0
        if g.h <= z <= 1:
            return 0.5 * (1 + np.cos(np.pi * (z - g.h) / (1 - g.h)))
        return 0.0

    u = np.zeros((n, 2))
    e_new = state.e_int_integral.copy()
    v_new = state.v_int_integral.copy()
    for i in range(n):
        ud, uv, e = np.zeros(2), np.zeros(2), np.zeros(2)
        for j in range(n):
            if i == j or not nb[i, j]:
                continue
            qij = q[i] - q[j]
            s = sig(qij)
            aij = a(s / sig_r)
            f = (s - sig_d) / np.sqrt(1 + (s - sig_d) ** 2) / (1 + g.eps * s)
            ud += -g.K_d * aij * qij * f
            uv += -g.K_v * aij * (p[i] - p[j])
            e += aij * (q[j] - q[i]) * f
        kdt = np.arctan(np.linalg.norm(q[i] - q_t[i]) / g.D_dt) if variant == "tailored" else g.K_dt
        ui = ud + uv - kdt * (q[i] - q_t[i]) - g.K_vt * (p[i] - p_t[i])
        if variant != "standard":
            ui += g.K_int * state.e_int_integral[i]
            e_new[i] += dt * e
        if variant == "tailored":
            ui -= g.K_vint * state.v_int_integral[i]
            v_new[i] += dt * (p[i] - p_t[i])
        norm = np.linalg.norm(ui)
        u[i] = ui if norm <= g.accel_limit else ui * g.accel_limit / norm
    return u, e_new, v_new


@pytest.mark.parametrize("variant", ["standard", "integral", "tailored"])
def test_vectorised_equals_naive_double_loop(variant):
    rng = np.random.default_rng(3)
    n = 6
    q = rng.uniform(-4, 4, (n, 2))
    p = rng.normal(size=(n, 2))
    q_t = rng.normal(size=(n, 2))  # each agent its own target estimate
    p_t = rng.normal(size=(n, 2)) * 0.5
    nb = rng.random((n, n)) < 0.7
    state = FlockingState(rng.normal(size=(n, 2)), rng.normal(size=(n, 2)))
    for g in (FlockingGains(), FlockingGains(accel_limit=np.inf, h=0.3, eps=0.5)):
        u, new = flocking_control(q, p, q_t, p_t, nb, state, g, variant, 0.05)
        u_ref, e_ref, v_ref = _naive(q, p, q_t, p_t, nb, state, g, variant, 0.05)
        np.testing.assert_allclose(u, u_ref, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(new.e_int_integral, e_ref, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(new.v_int_integral, v_ref, rtol=1e-10, atol=1e-12)


def test_pure_function_and_acceleration_clip():
    rng = np.random.default_rng(4)
    q = rng.uniform(-20, 20, (5, 2))
    p = rng.normal(size=(5, 2))
    state = FlockingState(np.ones((5, 2)), np.ones((5, 2)))
    q0, p0, e0 = q.copy(), p.copy(), state.e_int_integral.copy()
    u, new = _u(q, p, variant="tailored", gains=FlockingGains(), state=state)
    assert np.all(np.linalg.norm(u, axis=1) <= FlockingGains().accel_limit + 1e-12)
    np.testing.assert_array_equal(q, q0)
    np.testing.assert_array_equal(p, p0)
    np.testing.assert_array_equal(state.e_int_integral, e0)
    assert new is not state
    with pytest.raises(ValueError):
        _u(q, p, variant="bogus")


def test_integrals_do_not_accumulate_for_inactive_agents():
    rng = np.random.default_rng(5)
    n = 4
    q = rng.uniform(-2, 2, (n, 2))
    p = rng.normal(size=(n, 2))
    active = np.array([True, False, True, False])
    state = FlockingState.zeros(n)
    g = FlockingGains()
    for _ in range(10):
        u, state = flocking_control(
            q,
            p,
            np.ones((n, 2)),
            np.zeros((n, 2)),
            np.ones((n, n), bool),
            state,
            g,
            "tailored",
            0.05,
            active=active,
        )
    np.testing.assert_array_equal(state.e_int_integral[~active], 0.0)
    np.testing.assert_array_equal(state.v_int_integral[~active], 0.0)
    assert np.all(np.abs(state.e_int_integral[active]) > 0)
    assert np.all(np.abs(state.v_int_integral[active]) > 0)
    np.testing.assert_allclose(u[~active], -g.K_vt * p[~active])  # only hold position


def test_inter_agent_distances():
    q = np.array([[0.0, 0.0], [3.0, 4.0], [0.0, 1.0]])
    D = inter_agent_distances(q)
    np.testing.assert_allclose(D, [[0, 5, 1], [5, 0, np.hypot(3, 3)], [1, np.hypot(3, 3), 0]])


# --------------------------------------------------------------------------- L23 Fig. 1 claims


def _simulate(variant, seed, target_velocity, gains=None, n=3, T=60.0, dt=0.05, tau=0.15):
    """Lagged double integrator: the achieved acceleration follows the command with a first-order lag τ
    (stand-in for the quadrotor attitude loop). Returns the pair distances (steps, n(n-1)/2)."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-5, 5, (n, 2))  # random start in a 10 m box
    p = np.zeros((n, 2))
    acc = np.zeros((n, 2))
    vt = np.asarray(target_velocity, dtype=float)
    qt = np.zeros(2)
    state = FlockingState.zeros(n)
    nb = np.ones((n, n), bool)
    iu = np.triu_indices(n, 1)
    alpha = 1.0 - np.exp(-dt / tau)
    steps = int(round(T / dt))
    out = np.empty((steps, len(iu[0])))
    for k in range(steps):
        u, state = flocking_control(
            q, p, np.tile(qt, (n, 1)), np.tile(vt, (n, 1)), nb, state, gains, variant, dt
        )
        acc += alpha * (u - acc)
        p = p + dt * acc
        q = q + dt * p
        qt = qt + dt * vt
        out[k] = inter_agent_distances(q)[iu]
    return out


def _offset_and_overshoot(D, d=4.0, dt=0.05, last=10.0):
    offset = float(np.mean(np.abs(D[-int(last / dt) :] - d)))
    overshoot = 0.0
    for c in D.T:  # per pair: after the spacing first reaches d, the largest |distance − d|
        cross = np.nonzero(np.diff(np.sign(c - d)) != 0)[0]
        if len(cross):
            overshoot = max(overshoot, float(np.max(np.abs(c[cross[0] + 1 :] - d))))
    return offset, overshoot


@pytest.mark.slow
@pytest.mark.parametrize("target_velocity", [(0.0, 0.0), (0.5, 0.0)])
def test_l23_fig1_standard_offset_integral_removes_it_tailored_smoother(target_velocity):
    seeds = range(6)
    for seed in seeds:
        std_off, _ = _offset_and_overshoot(_simulate("standard", seed, target_velocity))
        int_off, int_ov = _offset_and_overshoot(_simulate("integral", seed, target_velocity))
        tai_off, tai_ov = _offset_and_overshoot(_simulate("tailored", seed, target_velocity))
        assert std_off > 0.2, (seed, std_off)  # standard: steady-state spacing offset
        assert int_off < 0.05, (seed, int_off)  # integral: offset gone ...
        assert tai_off < 0.05, (seed, tai_off)  # tailored: offset gone ...
        assert tai_ov < int_ov, (seed, tai_ov, int_ov)  # ... and a smoother transient than integral
