"""The metrics stream over a recording's chunks in one pass (sections, health checks and spacing together, what
several of them compute from a chunk computed once) and equal the whole-run computation: numpy formulas on the
whole arrays, LAPACK's solve for the NEES, a KD-tree for the spacing of a large swarm."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from swarmtrack.analysis import metrics
from swarmtrack.capabilities.tracking_swarm import metrics as gaussian
from swarmtrack.sim.recorder import Chunk, Recording


def _swarm(K=160, N=90, seed=3, spread=30.0, dt=0.05) -> Recording:
    """A whole-run recording of N > ALL_PAIRS_UP_TO UAVs around a moving target, with covariances of every shape a
    filter gives (correlated, per UAV and step), two phases and a detection flag with gaps."""
    rng = np.random.default_rng(seed)
    t = np.arange(K) * dt
    target = np.zeros((K, 4))
    target[:, 0], target[:, 2] = 0.4 * t, 0.4
    uav = np.zeros((K, N, 4))
    uav[:, :, :2] = rng.uniform(-spread, spread, (N, 2)) * np.linspace(1.0, 0.3, K)[:, None, None]  # contracts
    root = rng.standard_normal((K, N, 4, 4)) * 0.2
    cov = root @ np.swapaxes(root, -1, -2) + 0.05 * np.eye(4)
    est = target[:, None, :] + np.einsum("knij,knj->kni", np.linalg.cholesky(cov), rng.standard_normal((K, N, 4)))
    rec = Recording.from_arrays(t=t, phase=(t > 3).astype(int), phase_names=["a", "b"], target=target, uav=uav,
                                estimate=est, covariance=cov, d=4.0, r_comm=4.8, chase_start=1.0)
    detected = (rng.random((K, N)) > 0.02).astype(float)
    detected[40:80, :3] = 0.0  # three UAVs blind for 2 s
    nis = rng.chisquare(2, (K, N))
    nis[detected == 0] = np.nan
    chunk = rec._chunks[0]
    probes = {**chunk.probes, "detected": detected, "nis": nis}
    meta = {**rec.meta, "probes": {**rec.meta["probes"], "detected": [], "nis": []}}
    return Recording(meta, [Chunk(0, chunk.t, chunk.truth, chunk.phase, probes)])


def _chunked(rec: Recording, size: int) -> Recording:
    """The same recording in chunks of ``size`` steps (the last shorter)."""
    (c,) = rec._chunks
    parts = [Chunk(k, c.t[k:k + size], c.truth[k:k + size], c.phase[k:k + size],
                   {name: v[k:k + size] for name, v in c.probes.items()}) for k in range(0, len(c.t), size)]
    return Recording(rec.meta, parts)


def _close(a, b, rel=1e-12, path="") -> None:
    """Equal to round-off: the same keys and lists, floats within ``rel``."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for k in a:
            _close(a[k], b[k], rel, f"{path}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _close(x, y, rel, f"{path}[{i}]")
    elif isinstance(a, float) and not (np.isnan(a) and np.isnan(b)):
        assert a == pytest.approx(b, rel=rel, abs=1e-300), path
    else:
        assert a == b or (a != a and b != b), path


def test_streamed_sections_equal_the_whole_run_computation():
    rec = _swarm()
    out = metrics.summary(_chunked(rec, 23))  # chunks end mid-phase and in the chase start's step
    t, est, cov = rec.t, rec.estimate, rec.covariance
    keep = t >= rec.chase_start - 1e-9
    err = (est - rec.target[:, None, :])[keep]  # (K', N, 4)
    phase = rec.phase[keep]
    for p, name in enumerate(["a", "b"]):
        rmse = np.sqrt((err[phase == p] ** 2).mean(axis=0)).mean(axis=0)
        _close(list(out["rmse"][name].values()), rmse.tolist())
    _close(list(out["rmse"]["total"].values()), np.sqrt((err ** 2).mean(axis=0)).mean(axis=0).tolist())
    _close(out["position_rmse_per_uav"], np.sqrt((err[..., :2] ** 2).sum(-1).mean(axis=0)).tolist())
    _close(list(out["spread"].values()), err.std(axis=0).mean(axis=0).tolist(), rel=1e-10)
    std = np.sqrt(np.diagonal(cov[keep], axis1=-2, axis2=-1)).mean(axis=(0, 1))
    _close(list(out["reported_std"].values()), std.tolist())
    nees = np.sum(err * np.linalg.solve(cov[keep], err[..., None])[..., 0], axis=-1)  # LAPACK, whole run
    _close(out["nees"], float(nees.mean()))
    _close(out["consistency"]["b"]["nees"], float(nees[phase == 1].mean()))
    nis = rec._chunks[0].probes["nis"][keep]
    _close(out["consistency"]["total"]["nis"], float(np.nanmean(nis)))
    _close(out["mean_error"]["all"], float(np.hypot(err[..., 0], err[..., 1]).mean()))
    dist = np.linalg.norm(rec.uav[keep][:, :, :2] - rec.target[keep][:, None, :2], axis=-1)
    _close(out["target_distance"], {"mean": float(dist.mean()), "max": float(dist.max())})


def test_one_pass_equals_each_section_computed_alone_and_any_chunking():
    rec = _swarm()
    whole = metrics.summary(rec)
    _close(whole, metrics.summary(_chunked(rec, 7)))
    _close(whole, metrics.summary(_chunked(rec, 1)))
    for name in ("rmse", "spread", "reported_std", "consistency", "mean_error"):
        _close(whole[name], metrics.section(_chunked(rec, 11), name))  # no shared values: each computes its own
    _close(whole["series"], metrics.series(_chunked(rec, 11)))
    _close(whole["inter_agent_distance"], metrics.spacing(_chunked(rec, 11)))
    kinds = [w["kind"] for w in whole["warnings"]]
    assert "no_detection" in kinds  # the three blind UAVs, found by the health check in the same pass


def test_time_series_nees_is_lapacks_to_round_off():
    rec = _swarm()
    out = metrics.series(_chunked(rec, 13))
    err = rec.estimate - rec.target[:, None, :]
    nees = np.sum(err * np.linalg.solve(rec.covariance, err[..., None])[..., 0], axis=-1).mean(axis=1)
    bins = np.floor(rec.t / out["bin_s"] + 1e-9).astype(int)
    _close(out["nees"], [float(nees[bins == b].mean()) for b in range(len(out["t"]))], rel=1e-11)


def _kdtree_spacing(rec: Recording, last: float = 10.0) -> dict:
    """The spacing of a large swarm as it was computed before the grid: a KD-tree per step."""
    tail_from = rec.t_last - last
    d_min, offsets = np.inf, []
    for c in rec.chunks(probes_wanted=False):
        for t, q in zip(c.t, c.truth[:, rec.uav_slice, :2], strict=True):
            tree = cKDTree(q)
            d_min = min(d_min, float(tree.query(q, k=2)[0][:, 1].min()))
            if t >= tail_from:
                pairs = tree.query_pairs(rec.r_comm, output_type="ndarray")
                dist = np.linalg.norm(q[pairs[:, 0]] - q[pairs[:, 1]], axis=1)
                near = dist < rec.r_comm
                if near.any():
                    offsets.append(float(np.mean(np.abs(dist[near] - rec.d))))
    return {"min": d_min, "offset": float(np.mean(offsets)) if offsets else float("nan"), "open_pairs": None,
            "overshoot": None}


@pytest.mark.parametrize("last", [10.0, 2.0])  # every step in the tail; a tail of 2 s (steps before: nearest only)
def test_large_swarm_spacing_equals_the_kd_tree_computation(last):
    rec = _swarm(N=120, spread=40.0)
    (c,) = rec._chunks
    c.truth[50, rec.uav_slice, :2] *= 100.0  # one step scattered: no pair within r_comm (the KD-tree fallback)
    c.truth[60, rec.uav_slice.start + 1, :2] = c.truth[60, rec.uav_slice.start, :2]  # two UAVs in one place
    got = metrics.spacing(_chunked(rec, 17), last)
    want = _kdtree_spacing(rec, last)
    assert got["min"] == want["min"] == 0.0
    _close(got, want, rel=1e-12)


@pytest.mark.parametrize("spread", [0.5, 3.0, 40.0, 5e4])  # all in one cell ... far more cells than UAVs (argsort)
def test_close_pairs_find_every_pair_closer_than_r(spread):
    rng = np.random.default_rng(7)
    q = rng.uniform(-spread, spread, (4, 300, 2))
    q[1] = np.round(q[1])  # positions on a grid: many pairs exactly r apart and exactly 0 apart
    q[2, :, 1] = 0.0  # on one line
    r = np.array([4.8, 1.0, 2.0, 4.8])
    best, total, count = metrics.close_pairs(q, r, 4.0)
    for k, step in enumerate(q):
        i, j = np.triu_indices(len(step), 1)
        dist = np.linalg.norm(step[i] - step[j], axis=-1)
        near = dist[dist < r[k]]
        assert count[k] == len(near)
        assert best[k] == (near.min() if len(near) else np.inf)  # the same distance, bit for bit
        assert total[k] == pytest.approx(np.abs(near - 4.0).sum(), rel=1e-12, abs=0.0)


def test_close_pairs_beyond_the_grid_keys_use_the_kd_tree():
    """Positions spread over more cells than 64-bit keys number are measured by a KD-tree, with the same answers."""
    rng = np.random.default_rng(2)
    q = np.empty((2, 40, 2))
    q[:, ::2] = rng.uniform(-1e13, 1e13, (2, 20, 2))
    q[:, 1::2] = q[:, ::2] + rng.uniform(-3.0, 3.0, (2, 20, 2))
    best, total, count = metrics.close_pairs(q, 4.8, 4.0)
    for k, step in enumerate(q):
        i, j = np.triu_indices(len(step), 1)
        dist = np.linalg.norm(step[i] - step[j], axis=-1)
        near = dist[dist < 4.8]
        assert (count[k], best[k]) == (len(near), near.min())
        assert total[k] == pytest.approx(np.abs(near - 4.0).sum(), rel=1e-12)


def test_nees_per_uav_equals_lapacks_solve_and_refuses_a_singular_covariance():
    rng = np.random.default_rng(1)
    root = rng.standard_normal((50, 7, 4, 4))
    cov = root @ np.swapaxes(root, -1, -2) + 1e-3 * np.eye(4)
    cov[0, 0] = np.diag([1e6, 1e6, 1e-4, 1e-4])  # an information filter's start beside a converged one
    err = rng.standard_normal((50, 7, 4))
    want = np.sum(err * np.linalg.solve(cov, err[..., None])[..., 0], axis=-1)
    np.testing.assert_allclose(gaussian.nees_per_uav(err, cov), want, rtol=1e-10)
    np.testing.assert_allclose(gaussian.nees_per_uav(err[..., :2], cov[..., :2, :2]),
                               np.sum(err[..., :2] * np.linalg.solve(cov[..., :2, :2], err[..., :2, None])[..., 0], -1),
                               rtol=1e-10)
    cov[3, 2] = np.nan
    assert np.isnan(gaussian.nees_per_uav(err, cov)[3, 2])
    cov[3, 2] = 0.0
    with pytest.raises(np.linalg.LinAlgError, match="Singular"):
        gaussian.nees_per_uav(err, cov)
    ro = cov[:1, 1:].copy()
    ro.flags.writeable = False  # a chunk read from disk: read-only arrays
    np.testing.assert_allclose(gaussian.nees_per_uav(err[:1, 1:], ro), want[:1, 1:], rtol=1e-10)


def test_a_chunk_of_a_recording_on_disk_gives_the_same_summary(tmp_path):
    """A recording written to disk (writer thread, chunks read back ahead of the pass) gives the summary of the one
    in memory."""
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim import recorder
    from swarmtrack.sim.engine import simulate

    scn = load_scenario("l24-cv", ["duration=3", "swarm.n_uavs=70", "network.topology=proximity",
                                   "swarm.spawn_half_width=20", "target.profile=hover"])
    memory = metrics.summary(simulate(scn))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(recorder, "CHUNK_ROWS", 71 * 9)  # chunks of 9 steps
        disk = metrics.summary(simulate(scn, record_to=tmp_path / "rec"))
    _close(memory, disk)


def test_network_health_windows_equal_the_whole_run_computation():
    rec = _swarm(K=50, N=6)
    (c,) = rec._chunks
    rng = np.random.default_rng(5)
    rejected = (rng.random((50, 6)) > 0.9).astype(float)
    rejected[:, 4] = 0.0  # never gated
    probes = {**c.probes, "rejected": rejected, "delivered": np.full((50, 6), 2.0), "gated": rejected.copy()}
    meta = {**rec.meta, "probes": {**rec.meta["probes"], **dict.fromkeys(("rejected", "delivered", "gated"), [])}}
    whole = Recording(meta, [Chunk(0, c.t, c.truth, c.phase, probes)])
    out = metrics.section(_chunked(whole, 7), "network")
    for j in range(6):
        at = c.t[rejected[:, j] > 0]
        assert out["rejected_window"][j] == (None if not len(at) else [float(at[0]), float(at[-1])])
    assert out["rejected_per_uav"] == rejected.sum(axis=0).tolist()
