import numpy as np
import pytest

from swarmtrack.analysis import metrics
from swarmtrack.capabilities.mpc import metrics as mpc_metrics
from swarmtrack.sim.recorder import Recording


def _rec(K=2000, N=3, err_std=(0.1, 0.2, 0.3, 0.4), seed=0, spacing=4.0, d=4.0, edit_uav=None):
    rng = np.random.default_rng(seed)
    t = np.arange(K) * 0.05
    target = np.zeros((K, 4))
    target[:, 0] = 0.5 * t
    target[:, 2] = 0.5
    cov = np.broadcast_to(np.diag(np.square(err_std)), (K, N, 4, 4)).copy()
    est = target[:, None, :] + rng.standard_normal((K, N, 4)) * np.asarray(err_std)
    ang = 2 * np.pi * np.arange(N) / N
    r = spacing / (2 * np.sin(np.pi / N))
    uav = np.zeros((K, N, 4))
    uav[:, :, 0] = target[:, None, 0] + r * np.cos(ang)
    uav[:, :, 1] = r * np.sin(ang)
    if edit_uav is not None:
        edit_uav(uav)
    return Recording.from_arrays(t=t, phase=(t > 50).astype(int), phase_names=["a", "b"], target=target, uav=uav,
                                 estimate=est, covariance=cov, d=d, r_comm=4.8, chase_start=1.0)


def test_rmse_per_phase_recovers_the_error_std():
    table = metrics.rmse_table(_rec())
    assert set(table) == {"a", "b", "total"}
    for k, c in enumerate(metrics.COMPONENTS):
        assert abs(table["total"][c] - (0.1, 0.2, 0.3, 0.4)[k]) < 0.02


def test_consistent_errors_give_nees_of_the_dimension():
    assert abs(metrics.nees(_rec()) - 4.0) < 0.2
    assert metrics.nees(_rec(err_std=(0.2, 0.4, 0.6, 0.8))) > 3.5  # covariance follows err_std: still consistent


def test_spacing_offset_measures_distance_from_d_and_ignores_non_neighbours():
    assert metrics.spacing_offset(_rec(spacing=4.0)) < 1e-9
    assert abs(metrics.spacing_offset(_rec(spacing=3.5)) - 0.5) < 1e-9
    def chain(uav):  # chain 1-2-3, outer pair at 8 m
        uav[:, 2, :2] = uav[:, 1, :2] + (uav[:, 1, :2] - uav[:, 0, :2])

    rec = _rec(N=3, edit_uav=chain)
    assert metrics.open_pairs(rec) == 1
    assert metrics.spacing_offset(rec) < 1e-9


def test_overshoot_counts_only_after_the_first_crossing():
    gap = np.concatenate([np.linspace(1.0, 5.0, 200), np.full(200, 4.0)])  # crosses d at 4 m, peaks at 5 m

    def approach(uav):
        uav[:, 1, 0] = uav[:, 0, 0] + gap
        uav[:, 1, 1] = uav[:, 0, 1]

    rec = _rec(N=2, K=400, edit_uav=approach)
    assert abs(metrics.spacing_overshoot(rec) - 1.0) < 0.03


@pytest.mark.slow
def test_consistency_per_phase_shows_what_the_run_wide_nees_averages_away():
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim.engine import simulate

    table = metrics.summary(simulate(load_scenario("l24-cv", ["sensor.latency=0"])))["consistency"]
    below, above = table["linear"], table["circular"]
    assert below["nees"] < below["band"][0]  # CV with L24's Q is too cautious on the straight line
    assert above["nees"] > above["band"][1]  # and overconfident on the circle
    assert abs(table["total"]["nees"] - 4) < abs(above["nees"] - 4)  # the total hides both
    assert set(below["components"]) == set(metrics.COMPONENTS)


def test_consistency_bands_contain_a_consistent_filter():
    table = metrics.summary(_rec())["consistency"]
    for row in table.values():
        lo, hi = row["band"]
        assert lo < row["nees"] < hi


@pytest.mark.slow
def test_nis_of_the_own_measurement_is_reported_per_phase_with_its_band():
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim.engine import simulate

    table = metrics.summary(simulate(load_scenario("l24-cv", ["sensor.latency=0", "duration=40"])))["consistency"]
    lo, hi = table["total"]["nis_band"]
    assert lo < 2 < hi and 0.5 < table["total"]["nis"] < 4  # χ²(2) on average; L24's Q makes CV cautious
    late = metrics.summary(simulate(load_scenario("l24-cv", ["sensor.latency=0.3", "duration=40"])))["consistency"]
    # a pure delay is invisible in the innovations (the filter tracks the delayed track consistently); only the
    # truth-side NEES shows it, which is why both are reported
    assert abs(late["total"]["nis"] - table["total"]["nis"]) < 0.1
    assert late["total"]["nees"] > 4 * table["total"]["nees"]


def _series_by_hand(rec, width=1.0):
    """Per-bin means of the three series, step by step from the whole-run arrays (no streaming)."""
    from collections import defaultdict

    offsets, start, _ = mpc_metrics.formation_spec(rec)
    sums = defaultdict(lambda: defaultdict(list))
    for k, t in enumerate(rec.t):
        b = int(np.floor(t / width + 1e-9))
        e = rec.estimate[k, :, :2] - rec.target[k, :2]
        sums["position_error"][b].append(np.sqrt(np.mean(np.sum(e**2, axis=1))))
        full = rec.estimate[k] - rec.target[k]
        nees = [f @ np.linalg.inv(P) @ f for f, P in zip(full, rec.covariance[k], strict=True)]
        sums["nees"][b].append(np.mean(nees))
        if t >= start - 1e-9:
            slots = rec.target[k, :2] + offsets
            sums["tracking_error"][b].append(np.mean(np.linalg.norm(rec.uav[k, :, :2] - slots, axis=1)))
    return {q: {b: np.mean(v) for b, v in per_bin.items()} for q, per_bin in sums.items()}


def test_time_series_equal_a_whole_run_computation_bin_by_bin():
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim.engine import simulate

    for name, sets, wanted in (("l24-cv", [], {"position_error", "nees"}),
                               ("w20-mpc-formation", ["controller.start=2.5"],
                                {"position_error", "nees", "tracking_error"})):
        rec = simulate(load_scenario(name, ["duration=6", *sets]))
        got = metrics.summary(rec)["series"]
        assert got["bin_s"] == 1.0 and got["t"] == [0.5 + k for k in range(len(got["t"]))]
        assert wanted == set(got) - {"bin_s", "t"}
        hand = _series_by_hand(rec)
        for q in wanted:  # (l24-cv has no formation: its hand-made tracking error is not reported)
            assert len(got[q]) == len(got["t"]) == int(rec.t_last) + 1
            for b, v in enumerate(got[q]):
                if b in hand[q]:
                    assert v == pytest.approx(hand[q][b], rel=1e-9), (name, q, b)
                else:
                    assert v is None  # e.g. the tracking error before the MPC starts
        if name == "w20-mpc-formation":  # None before the MPC starts at 2.5 s
            assert got["tracking_error"][:2] == [None, None] and None not in got["tracking_error"][2:]


def test_time_series_bins_do_not_depend_on_the_recordings_chunk_size(tmp_path, monkeypatch):
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim import recorder
    from swarmtrack.sim.engine import simulate

    scn = load_scenario("l24-cv", ["duration=5"])
    whole = metrics.series(simulate(scn, record_to=tmp_path / "a"))
    monkeypatch.setattr(recorder, "CHUNK_ROWS", 7 * 4)  # 7 steps of 4 objects: chunks end mid-bin
    rec = simulate(scn, record_to=tmp_path / "b")
    assert rec.meta["chunk_steps"] == 7 < rec.meta["n_steps"]
    chunked = metrics.series(recorder.Recording.load(tmp_path / "b"))
    assert chunked.keys() == whole.keys()
    for q in whole:
        assert chunked[q] == pytest.approx(whole[q], rel=1e-12)


def test_long_runs_get_at_most_the_bin_limit_in_nesting_widths():
    assert metrics.series_bin_width(153.05) == 1.0
    assert metrics.series_bin_width(199.0) == 1.0
    assert metrics.series_bin_width(199.5) == 2.0
    for t_last in (10.0, 500.0, 3600.0, 86400.0):
        w = metrics.series_bin_width(t_last)
        assert np.log2(w) == int(np.log2(w)) and t_last / w + 1 <= metrics.SERIES_MAX_BINS
    s = metrics.series(_rec(K=8000))  # 400 s at 0.05 s
    assert s["bin_s"] == 4.0 and len(s["t"]) == len(s["nees"]) == 100
    assert abs(np.mean(s["nees"]) - 4) < 0.2
