"""IB21 Figs. 8-11 from a reproduction's runs: every band drawn is the mean and std over the runs' own series,
diverged runs are left out, ``reproduce --figure 8`` runs only Fig. 8's experiments, and ``analyse`` copes with a
figure's subset of the experiments."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from swarmtrack.analysis import metrics
from swarmtrack.analysis import reproduce as rep
from swarmtrack.analysis.papers import ib21
from swarmtrack.capabilities.set_membership import figures as sm_figures
from swarmtrack.capabilities.set_membership import metrics as sm_metrics
from swarmtrack.cli import main

N_BINS = 12
QUANTITIES = ("phi_bar", *sm_metrics.PHI_PARTS.values(), "solve_time")


def series_of(name: str, seed: int) -> dict:
    """A run's series, different for every experiment, seed and quantity (so a mixed-up band cannot pass)."""
    k = ib21.EXPERIMENTS.index(name) + 1
    t = np.arange(N_BINS)
    out = {"bin_s": 1.0, "t": (t + 0.5).tolist()}
    for j, q in enumerate(QUANTITIES):
        out[q] = (1000.0 * k * (j + 1) * np.exp(-t / (5 + seed)) + 37.0 * seed * (j + 1)).tolist()
    return out


def run_of(name: str, seed: int) -> dict:
    return {"set_membership": {"time_unexplored_cleared": None, "guarantee_violations": 0, "empty_set_alarms": 0,
                               "solve_time": {"fleet_mean": 0.003}}, "series": series_of(name, seed)}


def study(runs: int = 3) -> dict[str, list[dict]]:
    return {e: [run_of(e, s) for s in range(1, runs + 1)] for e in ib21.EXPERIMENTS}


@pytest.fixture
def bands(monkeypatch):
    """Every band :func:`plots.plot_band` draws: (label, t, mean, std), still drawn."""
    drawn = []
    real = sm_figures.plot_band

    def spy(ax, t, mean, std, label, color=None, alpha=0.25):
        drawn.append((label, np.asarray(t), np.asarray(mean), np.asarray(std)))
        return real(ax, t, mean, std, label, color=color, alpha=alpha)

    monkeypatch.setattr(sm_figures, "plot_band", spy)
    return drawn


def _assert_png(path):
    assert path.is_file() and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 1000


@pytest.mark.slow
def test_fig8_bands_are_the_mean_and_std_of_the_runs_series(tmp_path, bands):
    paths = ib21.figures(tmp_path, (), study(), "8")
    assert [p.name for p in paths] == ["ib21-fig8-left.png", "ib21-fig8-left-std.png", "ib21-fig8-right.png"]
    for p in paths:
        _assert_png(p)
    left = bands[:5]  # Fig. 8 left: Φ̄ for 2..6 UAVs, in that order
    assert [b[0] for b in left] == [f"$N_u$ = {n} (3 runs)" for n in (2, 3, 4, 5, 6)]
    for (_, t, mean, std), name in zip(left, ib21.FLEET, strict=True):
        values = np.array([series_of(name, s)["phi_bar"] for s in (1, 2, 3)])
        assert t == pytest.approx(np.arange(N_BINS) + 0.5)
        assert mean == pytest.approx(values.mean(axis=0), rel=1e-12)
        assert std == pytest.approx(values.std(axis=0), rel=1e-12) and std.max() > 0
    right = bands[5:]  # one panel per part, the settings 2, 4 and 6 UAVs in each
    assert len(right) == 9
    for k, part in enumerate(sm_metrics.PHI_PARTS.values()):
        for (_, _, mean, _), name in zip(right[3 * k:3 * k + 3], ("ib21-fleet-2", "ib21-fleet-4", "ib21-fleet-6"),
                                         strict=True):
            assert mean == pytest.approx(np.mean([series_of(name, s)[part] for s in (1, 2, 3)], axis=0))


@pytest.mark.slow
def test_fig11_right_draws_the_solve_time_of_one_to_three_uavs_and_of_each_fleet(tmp_path, bands):
    for panel, settings in zip(ib21.FIGURES["11"][1:], (ib21.COMPUTE, ib21.FLEET), strict=True):
        bands.clear()
        _assert_png(ib21.draw_panel(panel, study(), tmp_path))
        assert len(bands) == len(settings)
        for (_, _, mean, _), name in zip(bands, settings, strict=True):  # drawn in ms
            assert mean == pytest.approx(1000 * np.mean([series_of(name, s)["solve_time"] for s in (1, 2, 3)], axis=0))


@pytest.mark.slow
def test_the_compute_figure_gives_each_uavs_time_and_the_ratio_to_one_uav(tmp_path, monkeypatch):
    """Fig. 11 right's bars are each UAV's mean time over the runs; the legend's ratio is to one UAV's time."""
    bars, labels = [], []
    real_bar = sm_figures.Axes.bar

    def spy(self, x, height, *args, **kwargs):
        bars.append((kwargs.get("label"), np.asarray(height)))
        return real_bar(self, x, height, *args, **kwargs)

    monkeypatch.setattr(sm_figures.Axes, "bar", spy)
    monkeypatch.setattr(sm_figures, "plot_band", lambda ax, t, m, s, label, color=None: labels.append(label)
                        or ax.plot(t, m, label=label)[0])
    data = study(runs=2)
    for name, n in ib21.COMPUTE.items():
        for seed, r in enumerate(data[name]):
            r["set_membership"]["solve_time"] = {"fleet_mean": 0.0, "per_uav_mean": [0.001 * (i + 1) + 0.001 * seed
                                                                                   for i in range(n)]}
    ib21.draw_panel(ib21.FIGURES["11"][1], data, tmp_path)
    assert [b[0] for b in bars] == [f"$N_u$ = {n}" for n in (1, 2, 3)]
    assert bars[2][1] == pytest.approx([1.5, 2.5, 3.5])  # ms: UAV i's mean over the two seeds
    # fleet time: 1 UAV 1.5 ms, 3 UAVs 7.5 ms: 5.00x, beside the paper's 5x
    assert "1.50 ms, 1.00x" in labels[0] and "7.50 ms, 5.00x, paper 5x" in labels[2]


@pytest.mark.slow
def test_the_spread_figure_draws_the_std_over_the_runs(tmp_path, monkeypatch):
    lines = []
    real = sm_figures.Axes.plot

    def spy(self, *args, **kwargs):
        if "label" in kwargs:
            lines.append((kwargs["label"], np.asarray(args[1], dtype=float)))
        return real(self, *args, **kwargs)

    monkeypatch.setattr(sm_figures.Axes, "plot", spy)
    data = study()
    ib21.draw_panel(ib21.FIGURES["8"][1], data, tmp_path)
    assert len(lines) == 5
    values = np.array([series_of("ib21-fleet-4", s)["phi_bar"] for s in (1, 2, 3)])
    assert lines[2][1] == pytest.approx(values.std(axis=0)) and lines[2][0].startswith("$N_u$ = 4 (3 runs")


def test_diverged_runs_are_left_out_of_the_bands(tmp_path, bands):
    data = study()
    data["ib21-fleet-2"][1] = {"diverged": "test"}
    ib21.draw_panel(ib21.FIGURES["8"][0], data, tmp_path)
    label, _, mean, _ = bands[0]
    assert label == "$N_u$ = 2 (2 runs)"
    assert mean == pytest.approx(np.mean([series_of("ib21-fleet-2", s)["phi_bar"] for s in (1, 3)], axis=0))


@pytest.mark.slow
def test_every_figure_group_draws_its_panels_from_its_own_experiments(tmp_path):
    data = study(runs=2)
    for figure, panels in ib21.FIGURES.items():
        group = {e: data[e] for e in ib21.FIGURE_GROUPS[figure]}
        assert [p.name for p in ib21.figures(tmp_path, (), group, figure)] == [f"{p.name}.png" for p in panels]
    assert ib21.figures(tmp_path, ()) == []  # no runs, nothing to draw
    assert ib21.draw_panel(ib21.FIGURES["9"][0], {}, tmp_path) is None


@pytest.mark.slow
def test_a_real_runs_summary_draws_every_quantity(ib21_run, tmp_path, bands):
    """The summary `reproduce` caches carries what the figures read: Φ̄, its parts and the solve time."""
    summary = metrics.summary(ib21_run)
    ib21.draw_panel(ib21.FIGURES["8"][2], {"ib21-fleet-6": [summary]}, tmp_path)
    ib21.draw_panel(ib21.FIGURES["11"][2], {"ib21-fleet-6": [summary]}, tmp_path)
    assert len(bands) == 4
    for (_, _, mean, std), q in zip(bands, [*sm_metrics.PHI_PARTS.values(), "solve_time"], strict=True):
        scale = 1000 if q == "solve_time" else 1  # the control time is drawn in ms
        assert mean == pytest.approx(scale * np.array(summary["series"][q], dtype=float), nan_ok=True)
        assert np.nanmax(std) == 0  # one run: no spread


def test_the_parts_figure_needs_a_setting(tmp_path):
    with pytest.raises(ValueError):
        sm_figures.plot_phi_parts_bands({}, tmp_path / "none.png")


# --- analyse on one figure's experiments ---

def test_analyse_keeps_only_the_claims_whose_experiments_ran():
    data = study()
    claims, md, numbers = ib21.analyse({e: data[e] for e in ib21.FIGURE_GROUPS["10"]})
    assert {c.id for c in claims} == {"ib21-fig10-over-slowest", "ib21-fig10-under-lost", "ib21-guarantee",
                                      "ib21-fig10-twenty-above-five"}
    assert set(numbers["cleared"]) == set(ib21.NOISE) and "`ib21-fleet-6`" not in md
    everything, _, _ = ib21.analyse(data)
    assert {c.id for c in everything} == set(ib21.CLAIM_NEEDS)


# --- reproduce --figure ---

@pytest.fixture
def fake_runs(monkeypatch):
    """Replaces the simulation by :func:`run_of`; records the scenarios run."""
    seen = []

    def fake_run_one(scenario):
        seen.append((scenario.name, scenario.seed, scenario.duration))
        return run_of(scenario.name, scenario.seed)

    monkeypatch.setattr(rep, "run_one", fake_run_one)
    monkeypatch.setattr(rep, "run_batch", lambda scenarios: [fake_run_one(s) for s in scenarios])
    return seen


@pytest.mark.slow
def test_figure_8_runs_only_fig8s_experiments_and_draws_only_its_figures(tmp_path, fake_runs):
    report = rep.reproduce("ib21", tmp_path, runs=2, workers=1, quiet=True, figure="8", overrides=["duration=12"])
    assert sorted(fake_runs) == sorted((e, s, 12.0) for e in ib21.FLEET for s in (1, 2))
    assert report["figure"] == "8" and set(report["numbers"]["cleared"]) == set(ib21.FLEET)
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["ib21-fig8-left-std.png", "ib21-fig8-left.png",
                                                            "ib21-fig8-right.png"]
    assert json.loads((tmp_path / "reproduction-fig8.json").read_text()) == json.loads(json.dumps(report))
    assert not (tmp_path / "reproduction.json").exists()  # a part never replaces the full report
    md = (tmp_path / "reproduction-fig8.md").read_text()
    assert "Fig. 8's experiments only" in md and "ib21-fig8-left.png" in md and "ib21-fig9" not in md


def test_the_cli_refuses_a_figure_the_paper_does_not_group(tmp_path, fake_runs):
    res = CliRunner().invoke(main, ["reproduce", "ib21", "--figure", "12", "--out", str(tmp_path)])
    assert res.exit_code == 2 and "8, 9, 10, 11" in res.output, res.output
    res = CliRunner().invoke(main, ["reproduce", "l24", "--figure", "8", "--out", str(tmp_path)])
    assert res.exit_code == 2 and "without --figure" in res.output, res.output
    assert fake_runs == [] and not any(tmp_path.iterdir())


def test_the_cli_runs_one_figure(tmp_path, fake_runs):
    res = CliRunner().invoke(main, ["reproduce", "ib21", "--figure", "10", "--runs", "1", "--workers", "1",
                                    "--out", str(tmp_path), "--no-figures"])
    assert res.exit_code == 0, res.output
    assert sorted(name for name, _, _ in fake_runs) == sorted(ib21.NOISE)
    assert not list(tmp_path.glob("*.png"))
