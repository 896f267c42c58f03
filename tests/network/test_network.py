import numpy as np
import pytest

from swarmtrack.network import Channel, adjacency
from swarmtrack.network.messages import Inbox


def test_line_topology_is_the_l24_chain():
    A = adjacency("line", 3)
    assert A.tolist() == [[False, True, False], [True, False, True], [False, True, False]]


@pytest.mark.parametrize("kind, links", [("none", 0), ("full", 12), ("ring", 8), ("line", 6)])
def test_topologies_are_symmetric_without_self_loops(kind, links):
    A = adjacency(kind, 4)
    assert np.array_equal(A, A.T) and not A.diagonal().any() and A.sum() == links


def test_proximity_links_uavs_closer_than_r_comm():
    pos = np.array([[0.0, 0.0], [4.0, 0.0], [9.0, 0.0]])
    A = adjacency("proximity", 3, positions=pos, r_comm=4.8)
    assert A[0, 1] and A[1, 0] and not A[1, 2] and not A[0, 2]


def test_edges_are_checked():
    assert adjacency("edges", 3, edges=[(0, 2)]).sum() == 2
    with pytest.raises(ValueError, match="missing UAV"):
        adjacency("edges", 3, edges=[(0, 3)])
    with pytest.raises(ValueError, match="unknown topology"):
        adjacency("star", 3)


def test_inbox_sum_equals_the_loop_over_neighbours():
    rng = np.random.default_rng(0)
    A = rng.random((6, 6)) < 0.5
    payload = rng.standard_normal((6, 2, 2))
    got = Inbox(A, {"p": payload}).sum("p")  # what a receiver's inbox delivers
    for i in range(6):
        np.testing.assert_allclose(got[i], sum((payload[j] for j in range(6) if A[i, j]), np.zeros((2, 2))))


def test_message_loss_drops_the_stated_fraction_reproducibly():
    def links(seed):
        ch = Channel("full", 20, 4.8, loss_probability=0.3, rng=np.random.default_rng(seed))
        return np.stack([ch.links(np.zeros((20, 2))) for _ in range(50)])

    a = links(1)
    kept = a.sum() / (50 * 20 * 19)
    assert abs(kept - 0.7) < 0.02
    assert np.array_equal(a, links(1))
