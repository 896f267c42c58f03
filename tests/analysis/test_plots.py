"""Smoke tests of the figure functions on a synthetic recording."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from swarmtrack.analysis import figure_style, plots
from swarmtrack.capabilities.tracking_swarm import figures as swarm_figures
from swarmtrack.sim.recorder import Recording

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def make_recording(n_agents: int = 3, k: int = 200, seed: int = 0, meta: dict | None = None) -> Recording:
    """Target on a circle, UAVs on a ring around it, estimates = truth + seeded noise, three phases."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 40.0, k)
    w, radius = 0.15, 20.0
    target = np.column_stack([
        radius * np.cos(w * t), radius * np.sin(w * t),
        -radius * w * np.sin(w * t), radius * w * np.cos(w * t),
    ])
    angles = 2.0 * np.pi * np.arange(n_agents) / n_agents
    offsets = 3.0 * np.column_stack([np.cos(angles), np.sin(angles)])  # (N, 2)
    wobble = 0.3 * np.sin(0.5 * t)[:, None, None]
    uav = np.repeat(target[:, None, :], n_agents, axis=1).copy()
    uav[:, :, :2] += offsets[None] * (1.0 + wobble)
    estimate = target[:, None, :] + rng.normal(scale=[0.5, 0.5, 0.2, 0.2], size=(k, n_agents, 4))
    covariance = np.broadcast_to(np.eye(4), (k, n_agents, 4, 4)).copy()
    phase = np.zeros(k, dtype=int)
    phase[t >= 10.0] = 1
    phase[t >= 25.0] = 2
    return Recording.from_arrays(
        t=t, phase=phase, phase_names=["approach", "sinusoid", "circle"], target=target, uav=uav,
        estimate=estimate, covariance=covariance, d=4.0, r_comm=15.0, chase_start=5.0,
        meta=meta if meta is not None else {"scenario": "synthetic", "model": "ct"},
    )


def assert_png(path: Path) -> None:
    assert path.is_file()
    data = path.read_bytes()
    assert len(data) > 1000
    assert data[:8] == PNG_MAGIC


@pytest.fixture(scope="module")
def rec() -> Recording:
    return make_recording()


@pytest.mark.slow
@pytest.mark.parametrize(
    "func",
    [swarm_figures.plot_estimates, plots.plot_trajectories, plots.plot_target_distances,
     plots.plot_inter_agent_distances, swarm_figures.plot_errors],
)
def test_each_plot_writes_png(rec, tmp_path, func):
    out = func(rec, tmp_path / "sub" / f"{func.__name__}.png")
    assert isinstance(out, Path)
    assert_png(out)


@pytest.mark.slow
def test_trajectories_all_agents_and_bad_agent(rec, tmp_path):
    assert_png(plots.plot_trajectories(rec, tmp_path / "all.png", agent=None))
    assert_png(plots.plot_trajectories(rec, tmp_path / "a2.png", agent=2))
    with pytest.raises(ValueError):
        plots.plot_trajectories(rec, tmp_path / "bad.png", agent=3)


@pytest.mark.slow
def test_a_gaussian_run_following_a_target_gets_the_five_run_figures(rec, tmp_path):
    paths = plots.save_run_figures(rec, tmp_path / "figs")
    assert sorted(p.name for p in paths) == [
        "errors.png", "estimates.png", "inter_agent_distances.png", "target_distances.png", "trajectories.png",
    ]
    for p in paths:
        assert_png(p)


@pytest.mark.slow
def test_flocking_comparison(tmp_path):
    results = {name: make_recording(seed=s) for s, name in enumerate(["standard", "integral", "tailored"])}
    assert_png(swarm_figures.plot_flocking_comparison(results, tmp_path / "flocking.png"))
    with pytest.raises(ValueError):
        swarm_figures.plot_flocking_comparison({}, tmp_path / "empty.png")


@pytest.mark.slow
def test_many_agents(tmp_path):
    rec = make_recording(n_agents=15, k=120, seed=3, meta={})
    paths = plots.save_run_figures(rec, tmp_path)
    assert len(paths) == 5
    for p in paths:
        assert_png(p)
    assert_png(swarm_figures.plot_flocking_comparison({"standard": rec}, tmp_path / "flocking.png"))


def test_pair_labels_follow_the_metrics_pair_order(rec):
    from swarmtrack.analysis.metrics import pair_distances

    assert figure_style.pair_labels(3) == ["1-2", "1-3", "2-3"]
    expected = np.linalg.norm(rec.uav[:, 0, :2] - rec.uav[:, 2, :2], axis=-1)
    np.testing.assert_allclose(pair_distances(rec)[:, 1], expected)  # column "1-3"


def test_plot_band(tmp_path):
    fig = figure_style.new_figure((4, 3))
    ax = fig.subplots()
    t = np.linspace(0, 1, 50)
    line = figure_style.plot_band(ax, t, np.sin(t), 0.1 * np.ones_like(t), label="mean")
    assert line.get_label() == "mean"
    assert len(ax.collections) == 1
    assert_png(figure_style.save_figure(fig, tmp_path / "band.png"))
