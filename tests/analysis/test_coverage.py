"""Samples that did not come are absent, not errors: every metric is over the samples that came and the steps with
truth, says how many it covers, and a present filter that diverged is still caught."""

import warnings

import numpy as np
import pytest

from swarmtrack.analysis import metrics
from swarmtrack.capabilities.tracking_swarm import metrics as gaussian
from swarmtrack.sim.recorder import Recorder, Recording

K, N, DT = 400, 5, 0.05


def _arrays(seed=1):
    """A target moving along x, N UAVs whose consistent filters err by their covariance (0.04 m² per axis)."""
    rng = np.random.default_rng(seed)
    t = np.arange(K) * DT
    target = np.zeros((K, 4))
    target[:, 0], target[:, 2] = 0.5 * t, 0.5
    uav = np.zeros((K, N, 4))
    uav[:, :, 0] = np.arange(N) * 3.0
    cov = np.broadcast_to(0.04 * np.eye(4), (K, N, 4, 4)).copy()
    est = target[:, None, :] + 0.2 * rng.standard_normal((K, N, 4))
    return t, target, uav, est, cov


def _recording(present=None, est=None, target=None, chunks=1) -> Recording:
    t, target0, uav, est0, cov = _arrays()
    target = target0 if target is None else target
    rec = Recording.from_arrays(t=t, phase=np.zeros(K, dtype=int), phase_names=["all"], target=target, uav=uav,
                                estimate=est0 if est is None else est, covariance=cov, d=3.0, r_comm=10.0,
                                chase_start=1.0, present=present)
    if chunks == 1:
        return rec
    (c,) = rec._chunks
    size = -(-K // chunks)
    parts = [type(c)(k, c.t[k:k + size], c.truth[k:k + size], c.phase[k:k + size],
                     {n: v[k:k + size] for n, v in c.probes.items()}, None,
                     None if c.present is None else c.present[k:k + size]) for k in range(0, K, size)]
    return Recording(rec.meta, parts)


def _lost_uav(after=150, uav=2):
    """UAV ``uav``'s samples stop at step ``after``: NaN probes, marked absent."""
    t, target, _, est, _ = _arrays()
    est = est.copy()
    est[after:, uav] = np.nan
    present = np.ones((K, N), dtype=bool)
    present[after:, uav] = False
    return est, present


def _direct_position_rmse(est, target, keep):
    """Each UAV's position RMSE over the samples ``keep`` (K, N), mean over the UAVs: the numpy formula."""
    e2 = ((est[..., :2] - target[:, None, :2]) ** 2).sum(-1)
    return [float(np.sqrt(e2[keep[:, i], i].mean())) for i in range(N)]


@pytest.mark.parametrize("chunks", [1, 7])
def test_a_lost_uav_leaves_finite_numbers_over_the_samples_that_came(chunks):
    est, present = _lost_uav()
    out = metrics.summary(_recording(present, est, chunks=chunks))
    assert all(np.isfinite(v) for v in out["rmse"]["total"].values())
    assert np.isfinite(out["nees"]) and np.isfinite(out["mean_error"]["all"])
    t, target = np.arange(K) * DT, _arrays()[1]
    keep = present & (t >= 1.0 - 1e-9)[:, None]
    assert out["position_rmse_per_uav"] == pytest.approx(_direct_position_rmse(est, target, keep), rel=1e-12)
    assert out["coverage"]["samples"] == present.sum() and out["coverage"]["of"] == K * N
    assert out["coverage"]["per_uav"][2] == pytest.approx(150 / K)
    assert out["coverage"]["sections"]["rmse"] == keep.sum()
    kinds = [w["kind"] for w in out["warnings"]]
    assert "lost_target" not in kinds and "inconsistent" not in kinds and "no_detection" not in kinds
    (absent,) = [w for w in out["warnings"] if w["kind"] == "absent_samples"]
    assert absent["uav"] == 3 and absent["t_start"] == pytest.approx(150 * DT)
    assert "UAV 3" in absent["message"] and "the others tracked" in absent["message"]


def test_the_same_run_with_every_sample_present_gives_the_numbers_of_a_recording_without_a_mask():
    with_mask = metrics.summary(_recording(np.ones((K, N), dtype=bool)))
    without = metrics.summary(_recording())
    with_mask.pop("coverage"), without.pop("coverage")
    assert with_mask == without


def test_a_present_filter_that_diverged_is_still_lost_and_inconsistent():
    t, target, _, est, _ = _arrays()
    est = est.copy()
    est[200:, 1] = np.nan  # present, but its filter produced NaN
    out = metrics.summary(_recording(None, est))
    assert np.isnan(out["rmse"]["total"]["x"])
    kinds = {w["kind"]: w for w in out["warnings"]}
    assert kinds["inconsistent"]["t_start"] == pytest.approx(200 * DT, abs=0.11)
    assert "diverged" in kinds["inconsistent"]["message"]
    est[200:, :] = np.inf  # every UAV: the median error is infinite
    out = metrics.summary(_recording(None, est))
    assert any(w["kind"] == "lost_target" for w in out["warnings"])


def test_errors_are_computed_where_the_truth_is_known_and_coverage_says_where():
    t, target, _, est, _ = _arrays()
    partial = target.copy()
    partial[240:] = np.nan  # the log's truth ends at 12 s
    out = metrics.summary(_recording(None, est, partial))
    keep = np.broadcast_to(((t >= 1.0 - 1e-9) & (t < 12.0 - 1e-9))[:, None], (K, N))
    assert out["position_rmse_per_uav"] == pytest.approx(_direct_position_rmse(est, target, keep), rel=1e-12)
    assert out["coverage"]["truth_steps"] == 240 and out["coverage"]["truth_fraction"] == pytest.approx(0.6)
    kinds = [w["kind"] for w in out["warnings"]]
    assert "lost_target" not in kinds and "partial_truth" in kinds
    assert out["target_distance"]["mean"] is not None and np.isfinite(out["target_distance"]["mean"])


def test_a_filter_without_an_estimate_yet_is_not_called_inconsistent_and_no_python_warning_is_raised():
    t, target, _, est, _ = _arrays()
    est = est.copy()
    est[:30] = np.nan  # no detection before 1.5 s: no estimate
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = metrics.summary(_recording(None, est))
        assert not [w for w in out["warnings"] if w["kind"] in ("inconsistent", "lost_target")]
        est[:] = np.nan  # no estimate at all
        out = metrics.summary(_recording(None, est))
    assert not [w for w in out["warnings"] if w["kind"] == "inconsistent"]


def test_every_warning_states_numbers_that_agree_with_it():
    t, target, _, est, _ = _arrays()
    est = est.copy()
    est[100:200, :, :2] += 3.0  # 3 m off on both axes: NEES far above its band
    out = metrics.summary(_recording(None, est))
    (w,) = [w for w in out["warnings"] if w["kind"] == "inconsistent"]
    band = float(w["message"].split("band (")[1].split(" for")[0])
    peak = float(w["message"].split("peak ")[1].rstrip(")"))
    assert peak > gaussian.FAR * band


def test_a_recording_of_no_steps_summarizes_without_error():
    rec = Recorder({"dt": DT, "groups": {"targets": [0, 1], "uavs": [1, 1 + N]}, "tracked": 0,
                    "phase_names": ["all"], "object_phases": [["all"]] + [[]] * N, "d": 3.0, "r_comm": 10.0},
                   N + 1, N, {"estimate": (4,), "covariance": (4, 4)}, presence=True).close()
    out = metrics.summary(rec)
    assert out["coverage"]["samples"] == 0 and out["rmse"] == {}


def test_the_present_mask_round_trips_through_parquet(tmp_path):
    est, present = _lost_uav()
    _, target, uav, _, cov = _arrays()
    meta = {"dt": DT, "groups": {"targets": [0, 1], "uavs": [1, 1 + N]}, "tracked": 0, "phase_names": ["all"],
            "object_phases": [["all"]] + [[]] * N, "d": 3.0, "r_comm": 10.0}
    recorder = Recorder(meta, N + 1, N, {"estimate": (4,), "covariance": (4, 4)}, tmp_path, presence=True)
    phase = np.array([0] + [-1] * N, dtype=np.int16)  # the target's one phase; the UAVs have none
    for k in range(K):
        truth = np.concatenate([target[k:k + 1], uav[k]])
        recorder.record(k * DT, truth, phase, {"estimate": est[k], "covariance": cov[k]},
                        present=present[k])
    recorder.close()
    loaded = Recording.load(tmp_path)
    assert np.array_equal(np.concatenate([c.present for c in loaded.chunks()]), present)
    assert metrics.summary(loaded)["coverage"]["samples"] == present.sum()


def test_every_figure_of_a_run_with_a_lost_uav_is_drawn(tmp_path):
    from swarmtrack.analysis.plots import save_run_figures

    est, present = _lost_uav()
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        paths = save_run_figures(_recording(present, est), tmp_path)
    assert paths and all(p.stat().st_size > 0 for p in paths)


def test_a_uavs_last_value_is_taken_at_its_last_sample_that_came():
    from swarmtrack.analysis.coverage import at_last_came

    x = np.arange(12.0).reshape(4, 3)  # 4 steps, 3 UAVs: a cumulative count
    present = np.array([[1, 1, 0], [1, 0, 0], [1, 1, 0], [1, 0, 0]], dtype=bool)
    assert at_last_came(present, x, np.array([-1.0, -1.0, -7.0])).tolist() == [9.0, 7.0, -7.0]
