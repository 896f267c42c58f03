"""The compiled flocking kernel (control/kernels.py) against the numpy reference (control/flocking.py)."""

import tracemalloc

import numpy as np
import pytest
from scipy import sparse as sp

from swarmtrack.control import VARIANTS, FlockingGains, FlockingState, flocking_control
from swarmtrack.control.kernels import flocking_control_compiled
from swarmtrack.network.links import drop, is_sparse, neighbour_sum, proximity_links
from swarmtrack.vehicles import double_integrator

TOL = 1e-12  # same terms, only the order of the neighbour sums differs


def _close(a, b, tol=TOL):
    scale = max(1.0, float(np.abs(b).max(initial=0.0)))
    np.testing.assert_allclose(a, b, rtol=0, atol=tol * scale)


@pytest.mark.slow
@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("n", [1, 2, 5, 40])
@pytest.mark.parametrize("gains", [FlockingGains(), FlockingGains(accel_limit=np.inf, d=3.0, r_comm=6.0, h=0.5)])
def test_random_inputs_give_the_reference_commands_and_integrals(variant, n, gains):
    rng = np.random.default_rng(n)
    for _ in range(20):
        # spacings from 0 to beyond r_comm: all three pieces of the bump and pairs out of range
        q = rng.uniform(-1.5, 1.5, (n, 2)) * max(1.0, np.sqrt(n))
        p, q_t, p_t = rng.normal(0, 1, (n, 2)), rng.normal(0, 3, (n, 2)), rng.normal(0, 1, (n, 2))
        neighbours = rng.random((n, n)) < 0.7  # not symmetric, diagonal set on some rows
        state = FlockingState(rng.normal(0, 2, (n, 2)), rng.normal(0, 2, (n, 2)))
        active = rng.random(n) < 0.7
        for act in (active, None):
            u_ref, s_ref = flocking_control(q, p, q_t, p_t, neighbours, state, gains, variant, 0.05, active=act)
            u, s = flocking_control_compiled(q, p, q_t, p_t, neighbours, state, gains, variant, 0.05, active=act)
            _close(u, u_ref)
            _close(s.e_int_integral, s_ref.e_int_integral)
            _close(s.v_int_integral, s_ref.v_int_integral)


def test_broadcast_target_and_unknown_variant():
    q = np.array([[0.0, 0.0], [3.0, 1.0], [1.0, 4.0]])
    state = FlockingState.zeros(3)
    nb = np.ones((3, 3), dtype=bool)
    u_ref, _ = flocking_control(q, np.zeros((3, 2)), [1.0, 2.0], [0.5, 0.0], nb, state)
    u, _ = flocking_control_compiled(q, np.zeros((3, 2)), [1.0, 2.0], [0.5, 0.0], nb, state)
    _close(u, u_ref)
    with pytest.raises(ValueError, match="unknown flocking variant"):
        flocking_control_compiled(q, np.zeros((3, 2)), q, q, nb, state, variant="bogus")


@pytest.mark.parametrize("variant", VARIANTS)
def test_closed_loop_runs_stay_together(variant):
    """Double-integrator agents chasing a moving target for 300 steps, the two implementations side by side."""
    rng = np.random.default_rng(7)
    n, dt = 6, 0.05
    start = np.concatenate([rng.uniform(-6, 6, (n, 2)), np.zeros((n, 2))], axis=1)
    runs = []
    for control in (flocking_control, flocking_control_compiled):
        x, state = start.copy(), FlockingState.zeros(n)
        traj = []
        for k in range(300):
            t = k * dt
            q_t, p_t = np.array([0.5 * t, np.sin(0.1 * t)]), np.array([0.5, 0.1 * np.cos(0.1 * t)])
            d = x[:, None, :2] - x[None, :, :2]
            nb = np.einsum("ijk,ijk->ij", d, d) < 4.8**2
            u, state = control(x[:, :2], x[:, 2:], q_t, p_t, nb, state, FlockingGains(), variant, dt,
                               active=np.full(n, k >= 20))
            x = double_integrator.step(x, u, dt)
            traj.append(x)
        runs.append((np.array(traj), state))
    (ref, s_ref), (fast, s_fast) = runs
    _close(fast, ref, 1e-9)
    _close(s_fast.e_int_integral, s_ref.e_int_integral, 1e-9)
    _close(s_fast.v_int_integral, s_ref.v_int_integral, 1e-9)
    # the swarm did gather around the target
    assert np.linalg.norm(ref[-1, :, :2].mean(axis=0) - [0.5 * 299 * dt, np.sin(0.1 * 299 * dt)]) < 3.0


# --------------------------------------------------------------------------- sparse (CSR) links


def _swarm_links(n, seed, neighbours_per_uav=4.0, r_comm=4.8):
    """Uniform positions holding ~``neighbours_per_uav`` UAVs within r_comm, and their links in both forms."""
    half = np.sqrt(np.pi * r_comm**2 * n / neighbours_per_uav) / 2
    q = np.random.default_rng(seed).uniform(-half, half, (n, 2))
    return q, proximity_links(q, r_comm, sparse=False), proximity_links(q, r_comm, sparse=True)


def _random_inputs(rng, n):
    p, q_t, p_t = rng.normal(0, 1, (n, 2)), rng.normal(0, 3, (n, 2)), rng.normal(0, 1, (n, 2))
    state = FlockingState(rng.normal(0, 2, (n, 2)), rng.normal(0, 2, (n, 2)))
    return p, q_t, p_t, state, rng.random(n) < 0.7


@pytest.mark.slow
@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("control", [flocking_control, flocking_control_compiled], ids=["numpy", "compiled"])
def test_sparse_links_give_the_dense_reference_at_n_2000(variant, control):
    q, dense, links = _swarm_links(2000, 11)
    p, q_t, p_t, state, active = _random_inputs(np.random.default_rng(11), 2000)
    # r_comm = 6 > 4.8: the bump still reaches beyond the links, so the links, not the bump, cut pairs off
    for gains in (FlockingGains(), FlockingGains(accel_limit=np.inf, d=3.0, r_comm=6.0, h=0.5)):
        u_ref, s_ref = flocking_control(q, p, q_t, p_t, dense, state, gains, variant, 0.05, active=active)
        u, s = control(q, p, q_t, p_t, links, state, gains, variant, 0.05, active=active)
        _close(u, u_ref)
        _close(s.e_int_integral, s_ref.e_int_integral)
        _close(s.v_int_integral, s_ref.v_int_integral)


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("n", [1, 2, 5, 40])
def test_asymmetric_sparse_links_give_the_dense_reference(variant, n):
    """Random one-way links (as after message loss), a stored self-link (ignored), pairs beyond r_comm."""
    rng = np.random.default_rng(100 + n)
    for _ in range(10):
        q = rng.uniform(-1.5, 1.5, (n, 2)) * max(1.0, np.sqrt(n))
        p, q_t, p_t, state, active = _random_inputs(rng, n)
        dense = rng.random((n, n)) < 0.7
        links = sp.csr_array(dense)
        u_ref, s_ref = flocking_control(q, p, q_t, p_t, dense, state, FlockingGains(), variant, 0.05, active=active)
        for control in (flocking_control, flocking_control_compiled):
            u, s = control(q, p, q_t, p_t, links, state, FlockingGains(), variant, 0.05, active=active)
            _close(u, u_ref)
            _close(s.e_int_integral, s_ref.e_int_integral)
            _close(s.v_int_integral, s_ref.v_int_integral)


def test_sparse_path_never_builds_an_n_by_n_array():
    """Memory O(N + links): links, inbox sums, losses and flocking at N = 20,000 allocate well under one N² byte
    array (400 MB)."""
    n = 20_000
    rng = np.random.default_rng(5)
    q = rng.uniform(-1, 1, (n, 2)) * np.sqrt(n) * 2.2
    p, q_t, p_t, state, active = _random_inputs(rng, n)
    flocking_control_compiled(q[:2], p[:2], q_t[:2], p_t[:2], sp.csr_array(np.ones((2, 2), bool)),
                              FlockingState.zeros(2))  # compile outside the measurement
    tracemalloc.start()
    try:
        links = proximity_links(q, 4.8)
        neighbour_sum(drop(links, 0.2, rng), rng.standard_normal((n, 2, 2)))
        flocking_control(q, p, q_t, p_t, links, state, active=active)
        flocking_control_compiled(q, p, q_t, p_t, links, state, active=active)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert is_sparse(links) and peak < 20e6


@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("n, form", [(2, "dense"), (40, "dense"), (40, "csr"), (400, "csr")])
def test_a_subsets_commands_are_the_whole_swarms_rows_bit_for_bit(variant, n, form):
    """R receivers over N senders (one UAV's own process): each row of the compiled kernels and of the numpy
    reference is exactly the whole swarm's (the dense kernel sums a receiver's lower senders, then its higher)."""
    from swarmtrack.network.links import rows_of

    rng = np.random.default_rng(n)
    q = rng.uniform(-1.5, 1.5, (n, 2)) * max(1.0, np.sqrt(n))
    p, q_t, p_t = rng.normal(0, 1, (n, 2)), rng.normal(0, 3, (n, 2)), rng.normal(0, 1, (n, 2))
    links = proximity_links(q, 4.8, sparse=form == "csr")
    links = drop(links, 0.2, rng)  # not symmetric
    state = FlockingState(rng.normal(0, 2, (n, 2)), rng.normal(0, 2, (n, 2)))
    active = rng.random(n) < 0.8
    subsets = [np.array([i]) for i in range(min(n, 6))] + [np.array([0, n - 1]), np.sort(rng.choice(n, n // 2, False))]
    for law in (flocking_control, flocking_control_compiled):
        u, s = law(q, p, q_t, p_t, links, state, FlockingGains(), variant, 0.05, active=active)
        for rows in subsets:
            part = FlockingState(state.e_int_integral[rows], state.v_int_integral[rows])
            u_r, s_r = law(q, p, q_t[rows], p_t[rows], rows_of(links, rows), part, FlockingGains(), variant, 0.05,
                           active=active[rows], receivers=rows)
            assert np.array_equal(u_r, u[rows])
            assert np.array_equal(s_r.e_int_integral, s.e_int_integral[rows])
            assert np.array_equal(s_r.v_int_integral, s.v_int_integral[rows])


@pytest.mark.parametrize("variant", VARIANTS)
def test_the_staged_csr_kernel_is_the_link_by_link_one_bit_for_bit(variant):
    """:func:`flocking_kernel_csr` (pair terms in vectorised stages, blocks of rows) against
    :func:`flocking_kernel_csr_reference` (:func:`_pair_weight` link by link): the same bits, over crowded and sparse
    swarms, one-way links with a stored self-link, coincident agents, pairs on the bump's plateau, slope and edge and
    beyond r_comm (the links are wider than the bump), a NaN position, a subset of receivers, long rows and short."""
    from swarmtrack.control.kernels import (
        flocking_kernel_csr,
        flocking_kernel_csr_reference,
        gain_vector,
        variant_code,
    )
    from swarmtrack.network.links import rows_of

    rng = np.random.default_rng(VARIANTS.index(variant))
    for n, per_uav in ((500, 3.0), (1500, 300.0), (40, 30.0)):
        for gains in (FlockingGains(), FlockingGains(accel_limit=np.inf, d=3.0, r_comm=6.0, h=0.5)):
            half = np.sqrt(np.pi * 6.0**2 * n / per_uav) / 2
            q = rng.uniform(-half, half, (n, 2))
            q[1] = q[0]
            q[3] = q[2] + [gains.r_comm, 0.0]
            links = drop(proximity_links(q, 6.5, sparse=True), 0.1, rng)  # the links reach beyond the bump
            links = (links + sp.csr_array(([True], ([4], [4])), shape=(n, n))).tocsr()  # a self-link
            links.sort_indices()
            qp = np.concatenate([q + rng.normal(0, 0.05, q.shape), rng.normal(0, 1, (n, 2))], axis=1)
            qp[7, 0] = np.nan
            qp_t = rng.normal(0, 3, (n, 4))
            e, v = rng.normal(0, 2, (n, 2)), rng.normal(0, 2, (n, 2))
            active = rng.random(n) < 0.8
            args = (qp_t, e, v, active, gain_vector(gains), variant_code(variant), 0.05)
            for rows in (np.arange(n), np.sort(rng.choice(n, n // 3, replace=False))):
                part = rows_of(links, rows) if len(rows) < n else links
                own = qp[rows]
                got = flocking_kernel_csr(qp, own, rows, args[0][rows], part.indptr, part.indices, args[1][rows],
                                          args[2][rows], args[3][rows], *args[4:])
                expected = flocking_kernel_csr_reference(qp, own, rows, args[0][rows], part.indptr, part.indices,
                                                         args[1][rows], args[2][rows], args[3][rows], *args[4:])
                for a, b in zip(got, expected, strict=True):
                    assert a.tobytes() == b.tobytes()
