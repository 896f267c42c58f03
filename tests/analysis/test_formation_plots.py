"""W20 Ch. 5 formation figures: written for MPC runs, registered on the ``setpoint`` probe, and drawing the numbers
the metrics report."""

from __future__ import annotations

import numpy as np
import pytest

from swarmtrack.analysis import figure_style, metrics, plots
from swarmtrack.capabilities.mpc import figures as mpc_figures
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
FORMATION_FIGURES = ["formation_paths.png", "formation_xy.png", "slot_distances.png", "mpc_inputs.png",
                     "min_separation.png"]
FIGURE_FUNCTIONS = [mpc_figures.plot_formation_paths, mpc_figures.plot_formation_xy_time,
                    mpc_figures.plot_slot_distance, mpc_figures.plot_mpc_inputs, mpc_figures.plot_min_separation]


@pytest.fixture(scope="module")
def formation():
    """Three UAVs; the MPC starts at 20 s."""
    return simulate(load_scenario("w20-mpc-formation", overrides=["duration=22"]))


@pytest.fixture(scope="module")
def collision():
    """Two UAVs; UAV 2 passes UAV 1 within r_s in the first seconds."""
    return simulate(load_scenario("w20-mpc-collision", overrides=["duration=6"]))


@pytest.fixture(scope="module")
def occlusion():
    """UAV 3 blind from 40 s (the run ends at 42 s)."""
    return simulate(load_scenario("w20-mpc-occlusion", overrides=["duration=42"]))


def assert_png(path):
    assert path.exists() and path.stat().st_size > 1000
    assert path.read_bytes()[:8] == PNG_MAGIC


@pytest.mark.slow
@pytest.mark.parametrize("fn", FIGURE_FUNCTIONS, ids=lambda fn: fn.__name__)
@pytest.mark.parametrize("run", ["formation"])
def test_every_formation_figure_writes_a_png(fn, run, request, tmp_path):
    rec = request.getfixturevalue(run)
    assert_png(fn(rec, tmp_path / "figure.png"))


@pytest.mark.slow
def test_mpc_runs_get_the_formation_figures(collision, tmp_path):
    names = [p.name for p in plots.save_run_figures(collision, tmp_path)]
    assert [n for n in names if n in FORMATION_FIGURES] == FORMATION_FIGURES
    for name in FORMATION_FIGURES:
        assert_png(tmp_path / name)


@pytest.mark.slow
def test_a_single_uav_gets_no_separation_figure(tmp_path):
    rec = simulate(load_scenario("w20-mpc-single", overrides=["duration=3"]))
    names = [p.name for p in plots.save_run_figures(rec, tmp_path)]
    assert [n for n in names if n in FORMATION_FIGURES] == FORMATION_FIGURES[:-1]
    assert not (tmp_path / "min_separation.png").exists()


@pytest.mark.slow
def test_a_flocking_run_gets_no_formation_figures(tmp_path):
    rec = simulate(load_scenario("l24-cv", overrides=["duration=2"]))
    names = {p.name for p in plots.save_run_figures(rec, tmp_path)}
    assert names and not names & set(FORMATION_FIGURES)


def test_slot_distances_match_a_hand_computation_and_the_tracking_error(formation):
    dist = mpc_figures.slot_distances(formation)
    offsets = np.array(formation.meta["controller"]["offsets"], dtype=float)
    k = 3 * len(formation.t) // 4
    for i in range(formation.n_agents):
        dx = formation.uav[k, i, 0] - (formation.target[k, 0] + offsets[i, 0])
        dy = formation.uav[k, i, 1] - (formation.target[k, 1] + offsets[i, 1])
        assert dist[k, i] == pytest.approx(np.hypot(dx, dy), abs=1e-12)
    after = formation.t >= formation.meta["controller"]["start"] - 1e-9
    tracking = metrics.summary(formation)["formation"]["tracking_error"]
    np.testing.assert_allclose(dist[after].mean(axis=0), tracking, rtol=1e-12)


def test_the_slot_distance_figure_draws_slot_distances(formation):
    dist = mpc_figures.slot_distances(formation)
    np.testing.assert_array_equal(mpc_figures._FormationSeries(formation, every=1).distance, dist)
    np.testing.assert_array_equal(mpc_figures._FormationSeries(formation, every=4).distance, dist[::4])


def test_the_drawn_minimum_separation_keeps_the_closest_pass(collision):
    closest = metrics.spacing(collision)["min"]
    at = int(np.argmin(mpc_figures._FormationSeries(collision, every=1).separation))
    stride = next(k for k in (8, 7, 5, 3) if at % k)  # a stride whose kept steps skip the closest pass
    for every in (1, stride):
        drawn = mpc_figures._FormationSeries(collision, every=every).separation
        assert len(drawn) == -(-len(collision.t) // every)
        assert drawn.min() == pytest.approx(closest, abs=1e-12)


@pytest.mark.slow
def test_the_input_is_the_setpoint_relative_to_the_position_before_the_plan(formation):
    s = mpc_figures._FormationSeries(formation, every=1)
    setpoint, solves = figure_style.whole_probe(formation, "setpoint"), figure_style.whole_probe(formation, "solves")
    i = 1
    rises = np.flatnonzero(np.diff(solves[:, i]) > 0) + 1  # steps that show a new plan's setpoint
    # the record of step k precedes that step's plan: a setpoint first shown at step k was planned at step k − 1
    for k in rises[3:6]:
        np.testing.assert_allclose(s.u[k, i], setpoint[k, i] - formation.uav[k - 1, i, :2], atol=1e-12)
    held = rises[(rises + 1 < len(solves)) & ~np.isin(rises + 1, rises)]  # a plan still shown one step later
    for k in held[:3]:
        np.testing.assert_allclose(s.u[k + 1, i], setpoint[k + 1, i] - formation.uav[k - 1, i, :2], atol=1e-12)
    slow = simulate(load_scenario("w20-mpc-formation", overrides=["duration=22", "rates.estimation=10"]))
    long = mpc_figures._FormationSeries(slow, every=1)
    sp, so = figure_style.whole_probe(slow, "setpoint"), figure_style.whole_probe(slow, "solves")
    k = int(np.flatnonzero(np.diff(so[:, i]) > 0)[3] + 1)
    assert not np.diff(so[:, i])[k]  # at 10 Hz the plan period is two steps: step k + 1 still shows plan k − 1's
    np.testing.assert_allclose(long.u[k + 1, i], sp[k + 1, i] - slow.uav[k - 1, i, :2], atol=1e-12)
    assert np.isnan(s.u[: rises[0], i]).all()  # no input before the first plan
    bound = formation.meta["controller"]["bound"]
    assert np.nanmax(np.abs(s.u)) <= bound + 0.1  # within the bound up to the navigation noise


@pytest.mark.slow
def test_a_blind_uav_has_its_own_blind_interval(occlusion):
    s = mpc_figures._FormationSeries(occlusion)
    assert s.blind[0] == [] and s.blind[1] == []
    ((t0, t1),) = s.blind[2]
    assert (t0, t1) == (pytest.approx(40.0), pytest.approx(42.0))
