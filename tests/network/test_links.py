"""Dense and sparse links (network/links.py) hold the same links and give the same sums."""

import numpy as np
import pytest
from scipy import sparse as sp

from swarmtrack.network import (
    SPARSE_MIN_UAVS,
    Channel,
    adjacency,
    drop,
    edge_list,
    is_sparse,
    n_links,
    neighbour_lists,
    neighbour_sum,
    proximity_links,
    static_links,
    to_dense,
)


def _swarm(n, seed, neighbours_per_uav=3.0, r_comm=4.8):
    """Uniform positions in a square holding about ``neighbours_per_uav`` UAVs within r_comm of each UAV."""
    half = np.sqrt(np.pi * r_comm**2 * n / neighbours_per_uav) / 2
    return np.random.default_rng(seed).uniform(-half, half, (n, 2))


def _canonical(A):
    return (is_sparse(A) and A.dtype == bool and A.has_canonical_format and np.all(A.data)
            and not A.diagonal().any())


def _brute_force(q, r_comm):
    n = len(q)
    return np.array([[i != j and np.sum((q[i] - q[j]) ** 2) < r_comm**2 for j in range(n)] for i in range(n)])


@pytest.mark.parametrize("seed", range(5))
def test_sparse_proximity_is_exactly_the_dense_proximity(seed):
    q = _swarm(500, seed)
    dense = proximity_links(q, 4.8, sparse=False)
    links = proximity_links(q, 4.8, sparse=True)
    assert _canonical(links) and np.array_equal(links.toarray(), dense)
    assert n_links(links) == n_links(dense) > 0


@pytest.mark.slow
def test_pairs_at_exactly_r_comm_are_out_and_coincident_uavs_are_in():
    # on an integer grid with spacing 3 and r_comm = 6, many pairs sit at exactly 6 (and √(36) is exact);
    # the KD-tree alone would count them as inside
    g = np.arange(12) * 3.0
    q = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    q = np.concatenate([q, q[:5]])  # five UAVs sharing a spot with another
    for r_comm in (6.0, 3.0 * np.sqrt(2.0), 4.8):
        dense = proximity_links(q, r_comm, sparse=False)
        links = proximity_links(q, r_comm, sparse=True)
        assert np.array_equal(links.toarray(), dense)
        assert np.array_equal(dense, _brute_force(q, r_comm))
    assert not links[0, 2] and links[0, 144] and links[144, 0]  # d = 6 == r_comm: out; d = 0: in


def test_proximity_chooses_sparse_from_the_threshold_on():
    assert not is_sparse(proximity_links(_swarm(SPARSE_MIN_UAVS - 1, 0), 4.8))
    assert is_sparse(proximity_links(_swarm(SPARSE_MIN_UAVS, 0), 4.8))


def test_adjacency_is_the_dense_form_whatever_the_size():
    q = _swarm(SPARSE_MIN_UAVS + 10, 1)
    assert not is_sparse(adjacency("proximity", len(q), positions=q, r_comm=4.8))
    assert not is_sparse(adjacency("ring", SPARSE_MIN_UAVS + 10))


@pytest.mark.parametrize("kind, edges", [("none", ()), ("line", ()), ("ring", ()),
                                          ("edges", [(0, 5), (5, 0), (3, 7), (2, 9)])])
@pytest.mark.parametrize("n", [1, 2, 3, 10])
def test_static_sparse_links_equal_the_dense_ones(kind, edges, n):
    edges = [e for e in edges if max(e) < n]
    dense = static_links(kind, n, edges, sparse=False)
    links = static_links(kind, n, edges, sparse=True)
    assert _canonical(links) and np.array_equal(links.toarray(), dense)
    assert np.array_equal(dense, dense.T) and not dense.diagonal().any()


def test_large_static_topologies_are_sparse_except_full():
    n = SPARSE_MIN_UAVS
    assert is_sparse(static_links("ring", n)) and n_links(static_links("ring", n)) == 2 * n
    assert is_sparse(static_links("line", n)) and n_links(static_links("line", n)) == 2 * (n - 1)
    full = static_links("full", n)
    assert not is_sparse(full) and n_links(full) == n * (n - 1)


def test_static_links_check_their_arguments():
    with pytest.raises(ValueError, match="missing UAV"):
        static_links("edges", 3, [(0, 3)], sparse=True)
    with pytest.raises(ValueError, match="self-loop"):
        static_links("edges", 3, [(1, 1)], sparse=True)
    with pytest.raises(ValueError, match="unknown topology"):
        static_links("star", 3)
    with pytest.raises(ValueError, match="proximity_links"):
        static_links("proximity", 3)


@pytest.mark.parametrize("shape", [(), (2,), (4, 4)])
def test_sparse_neighbour_sum_equals_the_dense_one(shape):
    rng = np.random.default_rng(3)
    q = _swarm(400, 3, neighbours_per_uav=6)
    dense, links = proximity_links(q, 4.8, sparse=False), proximity_links(q, 4.8, sparse=True)
    payload = rng.standard_normal((400, *shape))
    got = neighbour_sum(links, payload)
    assert got.shape == payload.shape
    np.testing.assert_allclose(got, neighbour_sum(dense, payload), rtol=1e-13, atol=1e-13)


def test_edge_list_is_row_major_and_agrees_between_forms():
    rng = np.random.default_rng(4)
    dense = rng.random((30, 30)) < 0.2
    dense[np.arange(30), np.arange(30)] = True  # a set diagonal is not a link
    receivers, senders = edge_list(dense)
    expected = [(i, j) for i in range(30) for j in range(30) if dense[i, j] and i != j]
    assert list(zip(receivers.tolist(), senders.tolist(), strict=True)) == expected
    links = sp.csr_array(dense & ~np.eye(30, dtype=bool))
    for a, b in zip(edge_list(links), (receivers, senders), strict=True):
        assert np.array_equal(a, b)
    indptr, s = neighbour_lists(dense)
    assert np.array_equal(indptr, links.indptr) and np.array_equal(s, links.indices)


def test_drop_keeps_about_one_minus_p_of_sparse_links_reproducibly():
    links = proximity_links(_swarm(2000, 5, neighbours_per_uav=5), 4.8, sparse=True)
    kept = [drop(links, 0.3, np.random.default_rng(seed)) for seed in (1, 1, 2)]
    assert all(_canonical(k) for k in kept)
    assert abs(n_links(kept[0]) / n_links(links) - 0.7) < 0.02
    assert (kept[0] != kept[1]).nnz == 0 and (kept[0] != kept[2]).nnz > 0
    assert (kept[0] > links).nnz == 0  # only ever removes links


def test_drop_on_dense_links_is_the_channels_historic_draw():
    A = np.random.default_rng(0).random((20, 20)) < 0.5
    expected = A & (np.random.default_rng(9).random((20, 20)) >= 0.25)
    assert np.array_equal(drop(A, 0.25, np.random.default_rng(9)), expected)
    assert drop(A, 0.0, None) is A  # nothing lost, nothing drawn


def test_channel_picks_sparse_links_above_the_threshold():
    small, large = SPARSE_MIN_UAVS - 1, SPARSE_MIN_UAVS
    for topology in ("proximity", "ring"):
        assert not is_sparse(Channel(topology, small, 4.8).links(_swarm(small, 0)))
        assert is_sparse(Channel(topology, large, 4.8).links(_swarm(large, 0)))
    assert not is_sparse(Channel("full", large, 4.8).links(_swarm(large, 0)))
    assert is_sparse(Channel("full", large, 4.8).beacon_links(_swarm(large, 0)))


def test_beacon_links_are_the_proximity_graph_with_their_own_losses():
    q = _swarm(SPARSE_MIN_UAVS + 50, 6)
    proximity = proximity_links(q, 4.8, sparse=False)
    assert np.array_equal(to_dense(Channel("line", len(q), 4.8).beacon_links(q)), proximity)
    ch = Channel("proximity", len(q), 4.8, loss_probability=0.4, rng=np.random.default_rng(2))
    links, beacons = to_dense(ch.links(q)), to_dense(ch.beacon_links(q))
    assert ch._proximity(q.copy()) is ch._proximity(q)  # one proximity graph per positions
    assert not (links & ~proximity).any() and not (beacons & ~proximity).any()
    assert (links != beacons).any()  # separate loss draws
    n = n_links(proximity)
    assert abs(n_links(links) / n - 0.6) < 0.05 and abs(n_links(beacons) / n - 0.6) < 0.05


def test_proximity_cache_follows_moving_positions():
    q = _swarm(50, 7)
    ch = Channel("proximity", 50, 4.8)
    first = ch.links(q)
    q[:] = q * 0.5  # the caller moves the swarm in place
    assert np.array_equal(ch.links(q), proximity_links(q, 4.8)) and not np.array_equal(ch.links(q), first)


def test_edge_list_leaves_out_a_stored_self_link():
    links = sp.csr_array(np.array([[True, True], [False, True]]))
    receivers, senders = edge_list(links)
    assert receivers.tolist() == [0] and senders.tolist() == [1]


@pytest.mark.parametrize("dim", [2, 3])
def test_the_compiled_dense_proximity_equals_the_numpy_blocks_bit_for_bit(dim):
    """The dense links (one compiled pass) are :func:`proximity_blocks`' test exactly: pairs at r_comm and within
    rounding of it, coincident UAVs, a UAV with a NaN position (no links)."""
    from swarmtrack.network.links import proximity_blocks

    rng = np.random.default_rng(dim)
    for _ in range(50):
        q = rng.uniform(-10, 10, (40, dim))
        q[1] = q[0]
        q[2] = q[0] + 4.8 * np.eye(dim)[0] * (1 + rng.integers(-2, 3) * np.finfo(float).eps)
        q[3, -1] = np.nan
        dense = proximity_links(q, 4.8, sparse=False)
        assert dense.dtype == bool and np.array_equal(dense, proximity_blocks(q[None], 4.8)[0])
        assert dense[0, 1] and dense[1, 0] and not dense[3].any() and not dense[:, 3].any()


@pytest.mark.parametrize("sparse", [False, True])
def test_a_subsets_inbox_holds_its_rows_and_sums_them_as_the_swarm(sparse):
    """Inbox.restrict: the rows of the subset's receivers (no self-loop), every sender's payloads, the late parts
    restricted too; its sums, edges and own-first lists are the swarm's rows, bit for bit."""
    from swarmtrack.network.messages import Inbox

    rng = np.random.default_rng(4)
    n = 30
    links = drop(proximity_links(rng.uniform(0, 12, (n, 2)), 4.8, sparse=sparse), 0.1, rng)
    late = drop(static_links("ring", n, sparse=sparse), 0.5, rng)
    payload = {"info_vector": rng.normal(size=(n, 2)), "info_matrix": rng.normal(size=(n, 2, 2)),
               "seen": rng.random(n) < 0.8}
    whole = Inbox(links, payload, (Inbox(late, {**payload, "info_vector": payload["info_vector"] + 1.0}),))
    recv, send = whole.heard()
    for uavs in ([0], [7], [n - 1], [3, 4, 20]):
        sub = whole.restrict(uavs)
        assert sub.links.shape == (len(uavs), n) and is_sparse(sub.links) == sparse
        assert np.array_equal(sub.receivers, uavs) and np.array_equal(sub.late[0].receivers, uavs)
        for name in ("info_vector", "info_matrix"):
            assert np.array_equal(sub.sum(name), whole.sum(name)[uavs])
        r, s = sub.edges()
        keep = np.isin(whole.edges()[0], uavs)
        assert np.array_equal(np.asarray(uavs)[r], whole.edges()[0][keep])
        assert np.array_equal(s, whole.edges()[1][keep])
        r, s = sub.heard()
        own = np.isin(recv, uavs)
        assert sorted(zip(np.asarray(uavs)[r].tolist(), s.tolist(), strict=True)) == \
            sorted(zip(recv[own].tolist(), send[own].tolist(), strict=True))
    with pytest.raises(ValueError, match="increasing order"):
        whole.restrict([3, 1])


def test_a_subsets_detections_are_its_own_renumbered():
    from swarmtrack.sensors.detections import Detections

    owner = np.array([0, 0, 1, 3, 3, 3])
    det = Detections(owner, np.arange(12.0).reshape(6, 2), np.arange(12.0).reshape(6, 2) + 100, np.arange(6), 4,
                     taken=1.5)
    sub = det.of_uavs([1, 3])
    assert sub.n_uavs == 2 and sub.taken == 1.5
    assert np.array_equal(sub.owner, [0, 1, 1, 1]) and np.array_equal(sub.label, [2, 3, 4, 5])
    z, pos, seen = sub.of_label(4)
    z_all, pos_all, seen_all = det.of_label(4)
    assert np.array_equal(z, z_all[[1, 3]], equal_nan=True) and np.array_equal(seen, seen_all[[1, 3]])


def test_each_uavs_detections_in_one_pass_are_its_own_subset():
    from swarmtrack.sensors.detections import Detections

    owner = np.array([3, 0, 1, 3, 0, 3])  # unsorted owners: each UAV's rows keep their order
    det = Detections(owner, np.arange(12.0).reshape(6, 2), np.arange(12.0).reshape(6, 2) + 100, np.arange(6), 5,
                     frame=np.arange(6) * 10, footprint=np.arange(10.0).reshape(5, 2), taken=0.5)
    for i, one in enumerate(det.of_each_uav()):
        alone = det.of_uavs([i])
        for name in ("owner", "z", "sensor_pos", "label", "frame", "footprint"):
            assert np.array_equal(getattr(one, name), getattr(alone, name)), (i, name)
        assert (one.n_uavs, one.grid, one.taken) == (alone.n_uavs, alone.grid, alone.taken)


def _same_csr(a, b):
    return (a.shape == b.shape and a.indptr.dtype == b.indptr.dtype and a.indices.dtype == b.indices.dtype
            and np.array_equal(a.indptr, b.indptr) and np.array_equal(a.indices, b.indices))


@pytest.mark.parametrize("seed", range(3))
def test_the_strips_give_the_kd_trees_links_exactly(seed):
    """Sparse proximity links from the strips (:func:`_proximity_strips`) are the KD-tree's, array for array (CSR
    canonical: rows sorted, same index types): uniform swarms sparse to crowded, a line, one spot, integer grids with
    pairs at exactly r_comm and on the strips' edges, pairs a rounding away from r_comm in every direction, coincident
    UAVs."""
    from swarmtrack.network.links import _proximity_kdtree, _strips_fit

    rng = np.random.default_rng(seed)
    g = np.arange(30) * 3.0
    lattice = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    cases = [_swarm(n, seed, k) for n, k in ((300, 3), (1000, 30), (3000, 200))]
    cases += [np.stack([np.linspace(0, 900, 400), np.zeros(400)], axis=1), np.full((350, 2), -7.5),
              np.concatenate([lattice, lattice[:40]]), np.concatenate([lattice, lattice[:40]]) * 1.6 - 20.0]
    near = rng.uniform(-20, 20, (400, 2))
    near[1::2] = near[::2] + 4.8 * np.array([1.0, 0.0]) * (1 + rng.integers(-3, 4, (200, 1)) * np.finfo(float).eps)
    cases.append(near)
    # pairs a rounding away from r_comm in every direction: on the edges of the outer strips' shorter windows too
    ring = rng.uniform(-30, 30, (600, 2))
    angle = rng.uniform(0, 2 * np.pi, 300)
    scale = 4.8 * (1 + rng.integers(-4, 5, 300) * np.finfo(float).eps)
    ring[1::2] = ring[::2] + np.stack([np.cos(angle), np.sin(angle)], axis=1) * scale[:, None]
    cases.append(ring)
    for q in cases:
        for r_comm in (4.8, 6.0, 3.0 * np.sqrt(2.0)):
            assert _strips_fit(q, r_comm)
            links = proximity_links(q, r_comm, sparse=True)
            assert _canonical(links) and _same_csr(links, _proximity_kdtree(q, r_comm))
    q = cases[-2]
    assert np.array_equal(proximity_links(q, 6.0, sparse=True).toarray(), _brute_force(q, 6.0))


def test_positions_the_strips_do_not_take_go_to_the_kd_tree():
    """A scattered swarm (far more strips than UAVs), 3-D positions: the KD-tree's links, the same as the dense form's;
    a NaN position too (which the KD-tree refuses, as it always did)."""
    from swarmtrack.network.links import STRIPS_PER_UAV, _strips_fit

    q = _swarm(400, 3)
    far = q.copy()
    far[0] = [1e5, 1e5]
    nan = q.copy()
    nan[5, 1] = np.nan
    solid = np.random.default_rng(3).uniform(-10, 10, (400, 3))
    assert _strips_fit(q, 4.8) and not _strips_fit(far, 4.8) and not _strips_fit(nan, 4.8)
    assert not _strips_fit(solid, 4.8) and not _strips_fit(q, 0.0)
    assert np.ptp(far[:, 0]) / 4.8 * 3 > STRIPS_PER_UAV * len(far)
    with pytest.raises(ValueError, match="finite"):
        proximity_links(nan, 4.8, sparse=True)
    for p in (far, solid):
        links = proximity_links(p, 4.8, sparse=True)
        assert _canonical(links) and np.array_equal(links.toarray(), proximity_links(p, 4.8, sparse=False))


@pytest.mark.parametrize("shape", [(), (2,), (2, 2), (4,), (5,), (4, 4)])
def test_the_compiled_inbox_sum_is_scipys_bit_for_bit(shape):
    """:func:`neighbour_sum` over CSR links (compiled up to four columns, scipy beyond) adds the senders in scipy's
    order: the same bits, signed zeros, infinities and NaN included, after losses too; other payload types and links
    with a stored false value go to scipy."""
    rng = np.random.default_rng(len(shape))
    n = 600
    links = proximity_links(_swarm(n, 4, neighbours_per_uav=40), 4.8, sparse=True)
    payload = rng.standard_normal((n, *shape)) * 10.0 ** rng.uniform(-8, 8, (n, *shape))
    payload[::11] = -0.0
    payload[5::97] = np.inf
    payload[7::89] = np.nan
    for A in (links, drop(links, 0.3, rng)):
        expected = np.asarray(A @ payload.reshape(n, -1)).reshape(n, *shape)
        got = neighbour_sum(A, payload)
        assert got.shape == expected.shape and got.tobytes() == expected.tobytes()
    ints = rng.integers(-5, 5, (n, *shape))
    assert np.array_equal(neighbour_sum(links, ints), np.asarray(links @ ints.reshape(n, -1)).reshape(n, *shape))
    holed = links.copy()
    holed.data[::3] = False  # a stored false value: no link
    assert np.array_equal(neighbour_sum(holed, ints), np.asarray(holed @ ints.reshape(n, -1)).reshape(n, *shape))


def test_two_sums_in_one_pass_are_the_two_sums():
    """:func:`neighbour_sums` (two float payloads of up to eight numbers together summed side by side) gives
    :func:`neighbour_sum`'s bits, over CSR links with and without losses and over dense links; wider payloads go to
    it."""
    from swarmtrack.network.links import neighbour_sums

    rng = np.random.default_rng(8)
    n = 500
    links = proximity_links(_swarm(n, 8, neighbours_per_uav=30), 4.8, sparse=True)
    for shapes in (((2, 2), (2,)), ((), (4,)), ((3,), ()), ((5,), (2,)), ((3, 3), (2,))):
        first = rng.standard_normal((n, *shapes[0])) * 10.0 ** rng.uniform(-6, 6, (n, *shapes[0]))
        second = rng.standard_normal((n, *shapes[1]))
        first[::13] = -0.0
        for A in (links, drop(links, 0.2, rng), to_dense(links)):
            got = neighbour_sums(A, first, second)
            for g, p in zip(got, (first, second), strict=True):
                expected = neighbour_sum(A, p)
                assert g.shape == expected.shape and g.tobytes() == expected.tobytes()


def test_the_outer_strips_shorter_windows_hold_every_pair_closer_than_r_comm():
    """White box: pairs just within r_comm, whole strips apart along x (just across a strip's edge) and as far
    apart along y as that lets them be, for each strip the windows reach: every one is a link, as the KD-tree says."""
    from swarmtrack.network.links import _STRIP_MARGIN, _STRIPS_PER_R, _proximity_kdtree

    r = 4.8
    step = r * _STRIP_MARGIN / _STRIPS_PER_R
    points = [[0.0, 0.0]]  # the smallest x: the strips start here
    for o in range(1, _STRIPS_PER_R + 1):
        for k in range(40):
            x = (5 * k + 2) * step - 1e-9 * (k % 3)  # at or just before a strip's edge
            dx = (o - 1) * step + 1e-9 * (1 + k % 4)
            dy = np.sqrt(r * r - dx * dx) * (1 - 1e-12 * (1 + k % 5))
            y = 30.0 * k
            points += [[x, y], [x + dx, y + dy], [x + 0.5 * step, y + 12.0], [x + 0.5 * step + dx, y + 12.0 - dy]]
    q = np.array(points)
    q = np.concatenate([q, np.random.default_rng(0).uniform(0, q[:, 0].max(), (300, 2)) + [0.0, 1300.0]])
    links = proximity_links(q, r, sparse=True)
    assert _same_csr(links, _proximity_kdtree(q, r))
    pairs = np.arange(1, 1 + 4 * 40 * _STRIPS_PER_R, 2)
    assert links[pairs, pairs + 1].all()
