"""IB21 figures: a run that recorded Φ gets its uncertainty figures and map (and no capability-1 figures, which
need a followed target); a run that did not gets none of them; the bands over runs are the runs' mean and std."""

from __future__ import annotations

import numpy as np
import pytest

from swarmtrack.analysis import metrics, plots
from swarmtrack.capabilities.set_membership import figures as sm_figures
from swarmtrack.capabilities.set_membership import metrics as sm_metrics
from swarmtrack.sim.recorder import Chunk, Recording

IB21_FIGURES = ["uncertainty.png", "uncertainty_per_uav.png", "search_map.png"]


def _assert_png(path):
    assert path.is_file() and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 1000


@pytest.mark.slow
def test_an_ib21_run_gets_its_uncertainty_figures_and_map(ib21_run, tmp_path):
    paths = plots.save_run_figures(ib21_run, tmp_path)
    assert [p.name for p in paths] == IB21_FIGURES
    for p in paths:
        _assert_png(p)


@pytest.mark.slow
def test_a_followed_target_run_gets_none_of_them(tmp_path):
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim.engine import simulate

    names = {p.name for p in plots.save_run_figures(simulate(load_scenario("l24-cv", ["duration=3"])), tmp_path)}
    assert "estimates.png" in names and not names & set(IB21_FIGURES)


def test_long_runs_are_decimated_to_the_point_budget(ib21_run, monkeypatch):
    monkeypatch.setattr(sm_figures, "MAX_POINTS", 30)
    s = sm_figures._SetSeries(ib21_run)
    assert s.every == 3 and len(s.t) == 27 and s.phi.shape == (27, 6)  # steps 0, 3, … 78 of 80
    assert s.paths["targets"].shape == (27, 3, 2) and s.paths["uavs"].shape == (27, 6, 2)
    assert s.health.counts()["guarantee_violations"] == 0  # counted over every step, not the kept ones


def _scaled(rec: Recording, factor: float) -> Recording:
    """The run with every Φ probe times ``factor`` (one chunk in memory)."""
    parts = list(rec.chunks())
    probes = {k: np.concatenate([c.probes[k] for c in parts]) for k in parts[0].probes}
    for k in ("phi", *sm_metrics.PHI_PARTS.values()):
        probes[k] = probes[k] * factor
    chunk = Chunk(0, np.concatenate([c.t for c in parts]), np.concatenate([c.truth for c in parts]),
                  np.concatenate([c.phase for c in parts]), probes)
    return Recording(rec.meta, [chunk])


@pytest.mark.slow
def test_phi_bands_are_the_mean_and_std_over_runs(ib21_run, tmp_path):
    runs = [ib21_run, _scaled(ib21_run, 1.5), metrics.summary(_scaled(ib21_run, 2.0))]  # recordings or summaries
    band = sm_figures.phi_bands(runs, "phi_bar")
    base = np.asarray(metrics.series(ib21_run)["phi_bar"])
    assert band["runs"] == 3 and band["n"] == [3] * len(base)
    assert band["mean"] == pytest.approx((1.5 * base).tolist(), rel=1e-12)
    assert band["std"] == pytest.approx((np.std([1.0, 1.5, 2.0]) * base).tolist(), rel=1e-12)
    out = sm_figures.plot_phi_bands({"N_u = 6": runs, "half": [_scaled(ib21_run, 0.5)]}, tmp_path / "fig8.png")
    _assert_png(out)
    parts = sm_figures.plot_phi_bands({"N_u = 6": runs}, tmp_path / "fig8_right.png",
                                 quantities=list(sm_metrics.PHI_PARTS.values()))
    _assert_png(parts)
    _assert_png(sm_figures.plot_phi_bands({"6 UAVs": [ib21_run]}, tmp_path / "fig11.png", quantities=["solve_time"]))
    with pytest.raises(ValueError):
        sm_figures.plot_phi_bands({}, tmp_path / "none.png")
