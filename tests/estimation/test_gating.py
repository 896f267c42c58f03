"""Defences against a lying neighbour (estimation/gating.py): the χ²-gate leaves out what its prediction cannot
explain and keeps what it can; covariance intersection never claims more than either piece; a run with a liar is
contained by the gate, which names the liar."""

import numpy as np
import pytest

from swarmtrack.analysis.metrics import summary
from swarmtrack.estimation.gating import chi2_gate, covariance_intersection
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate

N = 3


def _payloads(positions, sigma=0.1):
    I = np.broadcast_to(np.eye(2) / sigma**2, (N, 2, 2)).copy()
    return {"info_matrix": I, "info_vector": np.einsum("nab,nb->na", I, positions), "seen": np.ones(N, dtype=bool)}


def test_the_chi2_gate_keeps_consistent_contributions_and_leaves_out_a_far_one():
    full = ~np.eye(N, dtype=bool)
    claimed = np.array([[0.05, 0.0], [-0.05, 0.1], [3.0, 0.0]])  # UAV 3 claims a target 3 m away
    x_pos = np.zeros((N, 2))
    P_pos = np.broadcast_to(np.eye(2) * 0.01, (N, 2, 2))
    I, i, recv, send, ok = chi2_gate(full, _payloads(claimed), x_pos, P_pos, -2 * np.log1p(-0.999), N)
    assert set(send[~ok].tolist()) == {2} and sorted(recv[~ok].tolist()) == [0, 1] and ok.sum() == 4
    np.testing.assert_allclose(I[0], np.eye(2) / 0.01)  # UAV 1 kept only UAV 2's
    np.testing.assert_allclose(I[2], 2 * np.eye(2) / 0.01)  # UAV 3 kept both honest ones


def _ci_by_hand(Y, y, neighbours, pay):
    """Covariance intersection receiver by receiver, ω by a dense scan of the fused covariance's determinant."""
    Y, y = Y.copy(), y.copy()
    omegas = np.linspace(0.001, 0.999, 9999)
    for r, senders in neighbours.items():
        for s in senders:
            Yj = np.zeros((4, 4))
            Yj[:2, :2] = pay["info_matrix"][s]
            logdet = [np.linalg.slogdet(w * Y[r] + (1 - w) * Yj)[1] for w in omegas]  # of the information
            w = omegas[int(np.argmax(logdet))]
            Y[r] = w * Y[r] + (1 - w) * Yj
            y[r] = w * y[r]
            y[r, :2] += (1 - w) * pay["info_vector"][s]
    return Y, y


@pytest.mark.slow
def test_covariance_intersection_picks_the_determinant_minimising_weight_on_an_irregular_graph():
    rng = np.random.default_rng(0)
    n = 4
    A = rng.standard_normal((n, 4, 4))
    Y = A @ np.swapaxes(A, -1, -2) + 4 * np.eye(4)
    y = rng.standard_normal((n, 4))
    links = np.zeros((n, n), dtype=bool)
    neighbours = {0: [1, 2, 3], 1: [0], 3: [2]}  # UAV 3 hears nobody; the others 3, 1 and 1 neighbours
    for r, senders in neighbours.items():
        links[r, senders] = True
    I = rng.standard_normal((n, 2, 2))
    I = I @ np.swapaxes(I, -1, -2) * 50 + np.eye(2)
    pay = {"info_matrix": I, "info_vector": rng.standard_normal((n, 2)), "seen": np.ones(n, dtype=bool)}
    Yci, yci = covariance_intersection(Y, y, links, pay)
    Yref, yref = _ci_by_hand(Y, y, neighbours, pay)
    np.testing.assert_allclose(Yci, Yref, rtol=0.05)  # ω on a 49-value grid against a 9,999-value scan
    np.testing.assert_array_equal(Yci[2], Y[2])  # nobody heard: unchanged
    Ysum = Y.copy()
    for r, senders in neighbours.items():
        Ysum[r, :2, :2] += I[senders].sum(axis=0)
    assert (np.linalg.eigvalsh(Ysum - Yci) > -1e-9).all()  # never more information than the plain sum


@pytest.mark.slow
@pytest.mark.parametrize("gating", ["none", "chi2"])
def test_a_liar_among_five_is_contained_by_the_gate_and_named(gating):
    base = ["duration=40", "network.topology=full", "swarm.n_uavs=5", "sensor.latency=0"]
    liar = ["network.liar={uav: 3, offset: [1.0, 0.0]}", f"estimator.gating={gating}"]
    clean = np.delete(summary(simulate(load_scenario("l24-cv", base)))["position_rmse_per_uav"], 2).mean()
    got = summary(simulate(load_scenario("l24-cv", base + liar)))
    honest = np.delete(got["position_rmse_per_uav"], 2).mean()
    if gating == "chi2":
        assert honest <= 1.2 * clean
        suspects = [w["uav"] for w in got["warnings"] if w["kind"] == "suspect_neighbour"]
        assert suspects == [3]
        assert got["network"]["rejected_per_uav"][2] > 0 and sum(got["network"]["rejected_per_uav"]) == \
            got["network"]["rejected_per_uav"][2]
    else:
        assert honest > 1.5 * clean
