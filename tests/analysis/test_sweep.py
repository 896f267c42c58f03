"""swarmtrack sweep: the cross product x seeds into a per-run Parquet store; resume, failures, bad input."""

import json

import pytest
from click.testing import CliRunner

from swarmtrack.analysis import sweep as sw
from swarmtrack.analysis.metrics import summary
from swarmtrack.cli import main
from swarmtrack.scenarios import load_scenario
from swarmtrack.scenarios.loader import ScenarioError
from swarmtrack.sim.engine import simulate

SHORT = ("duration=4",)


def test_grid_values_split_on_top_level_commas_only():
    grid = sw.parse_grid(["network.topology=line,full", "estimator.models=[cv,ca,ct],[ct,ct,ct]"])
    assert grid == {"network.topology": ["line", "full"], "estimator.models": ["[cv,ca,ct]", "[ct,ct,ct]"]}
    assert len(sw.settings(grid)) == 4
    for bad in (["network.topology"], ["network.topology=line,,full"], ["a=1", "a=2"], ["=1"]):
        with pytest.raises(ScenarioError):
            sw.parse_grid(bad)


def test_every_setting_and_seed_is_stored_once_with_the_metrics_of_its_run(tmp_path):
    grid = {"network.topology": ["line", "full"]}
    sw.sweep("l24-cv", grid, 2, tmp_path / "s", workers=1, overrides=SHORT)
    table = sw.load_results(tmp_path / "s").sort_values(["param.network.topology", "seed"])
    assert len(table) == 4 and set(table["status"]) == {"ok"}
    row = table[(table["param.network.topology"] == "full") & (table["seed"] == 2)].iloc[0]
    alone = summary(simulate(load_scenario("l24-cv", [*SHORT, "network.topology=full"], seed=2)))
    assert row["rmse_total_x"] == alone["rmse"]["total"]["x"]  # the same run, bit for bit
    assert row["version"] and row["wall_s"] > 0
    assert row["series.bin_s"] == alone["series"]["bin_s"]
    for q in ("t", "position_error", "nees"):  # the time series, bit for bit
        assert list(row[f"series.{q}"]) == alone["series"][q]


def test_resume_runs_only_what_is_missing_and_never_twice(tmp_path):
    out = tmp_path / "s"
    sw.sweep("l24-cv", {"network.topology": ["line"]}, 2, out, workers=1, overrides=SHORT)
    before = {p.name: p.stat().st_mtime_ns for p in (out / "results").iterdir()}
    with pytest.raises(ScenarioError, match="--resume"):
        sw.sweep("l24-cv", {"network.topology": ["line"]}, 3, out, workers=1, overrides=SHORT)
    seen = []
    sw.sweep("l24-cv", {"network.topology": ["line"]}, 3, out, workers=1, overrides=SHORT, resume=True,
             on_done=lambda done, total: seen.append((done, total)))
    assert seen == [(2, 3), (3, 3)]  # two found, one run
    after = {p.name: p.stat().st_mtime_ns for p in (out / "results").iterdir()}
    assert len(after) == 3 and all(after[k] == v for k, v in before.items())  # finished rows untouched
    table = sw.load_results(out)
    assert len(table) == 3 and all(len(v) == 4 for v in table["series.position_error"])  # 4 s: 4 bins of 1 s


def test_a_run_that_raises_is_stored_as_failed_and_the_sweep_goes_on(tmp_path, monkeypatch):
    import swarmtrack.sim.engine as engine

    real = engine.simulate

    def flaky(scenario, *a, **k):
        if scenario.seed == 2:
            raise RuntimeError("a broken run")
        return real(scenario, *a, **k)

    monkeypatch.setattr(engine, "simulate", flaky)
    _batches_run_alone(monkeypatch)
    sw.sweep("l24-cv", {"network.topology": ["line"]}, 3, tmp_path / "s", workers=1, overrides=SHORT)
    table = sw.load_results(tmp_path / "s").set_index("seed")
    assert table.loc[2, "status"] == "failed" and "a broken run" in table.loc[2, "error"]
    assert list(table.loc[[1, 3], "status"]) == ["ok", "ok"]


def _batches_run_alone(monkeypatch):
    """A batch of worlds runs its scenarios through ``engine.simulate`` (as patched by the test), so a run that raises
    breaks its batch, which is then run again one job at a time."""
    import swarmtrack.sim.batch as batch
    import swarmtrack.sim.engine as engine

    monkeypatch.setattr(batch, "simulate_batch", lambda scenarios: [engine.simulate(s) for s in scenarios])


def test_seeds_run_as_batched_worlds_give_the_rows_of_single_runs(tmp_path, monkeypatch):
    sw.sweep("l24-cv", {"network.topology": ["line"]}, 3, tmp_path / "b", workers=1, overrides=SHORT)
    batched = sw.load_results(tmp_path / "b").set_index("seed").sort_index()
    monkeypatch.setattr(sw, "batches", lambda scenarios, workers=1: [[k] for k in range(len(scenarios))])
    sw.sweep("l24-cv", {"network.topology": ["line"]}, 3, tmp_path / "s", workers=1, overrides=SHORT)
    single = sw.load_results(tmp_path / "s").set_index("seed").sort_index()
    assert batched["batch"].tolist() == [3, 3, 3] and single["batch"].tolist() == [1, 1, 1]
    for col in ("rmse_total_x", "nees", "spacing_offset"):
        assert batched[col].tolist() == single[col].tolist()


def test_bad_grid_keys_and_values_exit_2_before_anything_is_written(tmp_path):
    for grid in ("network.topolgy=line", "sensor.latency=abc"):
        result = CliRunner().invoke(main, ["sweep", "l24-cv", "--grid", grid, "--out", str(tmp_path / "s")])
        assert result.exit_code == 2, result.output
        assert grid.split("=")[0] in result.output and "Traceback" not in result.output
        assert not (tmp_path / "s").exists()


def test_a_folder_that_is_not_a_store_is_refused(tmp_path):
    (tmp_path / "mine.txt").write_text("user data")
    with pytest.raises(ScenarioError, match="not a sweep"):
        sw.sweep("l24-cv", {"network.topology": ["line"]}, 1, tmp_path, workers=1, overrides=SHORT)
    assert (tmp_path / "mine.txt").read_text() == "user data"


def test_parallel_workers_give_the_rows_of_one_process(tmp_path):
    grid = {"sensor.latency": ["0", "0.15"]}
    sw.sweep("l24-cv", grid, 2, tmp_path / "a", workers=1, overrides=SHORT)
    sw.sweep("l24-cv", grid, 2, tmp_path / "b", workers=2, overrides=SHORT)
    cols = ["param.sensor.latency", "seed", "rmse_total_x", "rmse_total_vy", "nees"]
    a = sw.load_results(tmp_path / "a")[cols].sort_values(cols[:2]).reset_index(drop=True)
    b = sw.load_results(tmp_path / "b")[cols].sort_values(cols[:2]).reset_index(drop=True)
    assert a.equals(b)


@pytest.mark.slow
def test_summarize_gives_mean_std_and_interval_per_setting_in_the_grid_order(tmp_path):
    out = tmp_path / "s"
    sw.sweep("l24-cv", {"sensor.latency": ["0.15", "0"]}, 3, out, workers=1, overrides=SHORT)
    sw.sweep("l24-cv", {"sensor.latency": ["0.3"]}, 3, out, workers=1, overrides=SHORT, resume=True)
    md, numbers = sw.summarize(out)
    assert [e["setting"]["sensor.latency"] for e in numbers["settings"]] == ["0.15", "0", "0.3"]
    table = sw.load_results(out)
    x = table[table["param.sensor.latency"] == "0.3"]["rmse_total_x"]
    got = numbers["settings"][2]["metrics"]["rmse_total_x"]
    assert got["mean"] == pytest.approx(x.mean()) and got["std"] == pytest.approx(x.std(ddof=0))
    assert got["ci95"][0] < got["mean"] < got["ci95"][1] and got["n"] == 3
    assert "| 0.3 | 3/3 |" in md
    assert len(sw.plot_summary(numbers, tmp_path / "fig")) == len(numbers["metrics"])


def test_a_resume_with_another_scenario_is_refused(tmp_path):
    sw.sweep("l24-cv", {"sensor.latency": ["0"]}, 1, tmp_path / "s", workers=1, overrides=SHORT)
    with pytest.raises(ScenarioError, match="same scenario"):
        sw.sweep("l24-ct", {"sensor.latency": ["0"]}, 1, tmp_path / "s", workers=1, overrides=SHORT, resume=True)


@pytest.mark.slow
def test_a_dask_local_cluster_gives_the_rows_of_local_processes(tmp_path):
    grid = {"sensor.latency": ["0", "0.15"]}
    sw.sweep("l24-cv", grid, 2, tmp_path / "a", workers=1, overrides=SHORT)
    sw.sweep("l24-cv", grid, 2, tmp_path / "b", workers=2, overrides=SHORT, cluster="local")
    cols = ["param.sensor.latency", "seed", "status", "rmse_total_x", "rmse_total_vy", "nees", "key"]
    a = sw.load_results(tmp_path / "a")[cols].sort_values(cols[:2]).reset_index(drop=True)
    b = sw.load_results(tmp_path / "b")[cols].sort_values(cols[:2]).reset_index(drop=True)
    assert a.equals(b)


@pytest.mark.slow
def test_an_unreachable_scheduler_exits_2_before_anything_is_written(tmp_path):
    result = CliRunner().invoke(main, ["sweep", "l24-cv", "--grid", "sensor.latency=0", "--runs", "1",
                                       "--out", str(tmp_path / "s"), "--cluster", "tcp://127.0.0.1:1"])
    assert result.exit_code == 2, result.output
    assert "tcp://127.0.0.1:1" in result.output and "Traceback" not in result.output
    assert not (tmp_path / "s").exists()


@pytest.mark.slow
def test_reproduce_runs_through_dask_with_the_same_results(tmp_path):
    from swarmtrack.analysis.reproduce import run_all

    jobs = [("l23-no-fusion", 1), ("l23-no-fusion", 2)]
    local = run_all(jobs, tmp_path / "a", workers=1, overrides=SHORT)
    dask = run_all(jobs, tmp_path / "b", workers=2, overrides=SHORT, cluster="local")
    assert {j: m["rmse"] for j, m in local.items()} == {j: m["rmse"] for j, m in dask.items()}


def _store(out, rows, grid, fmt=sw.STORE_FORMAT):
    """A hand-made result store: ``sweep.json`` of format ``fmt`` and one Parquet row per dict in ``rows``."""
    (out / "results").mkdir(parents=True)
    (out / "sweep.json").write_text(json.dumps({"format": fmt, "scenario": "l24-cv", "grid": grid, "runs": 3,
                                                "overrides": [], "written_by": "test"}))
    for k, row in enumerate(rows):
        base = {"seed": k + 1, "status": "ok", "error": None, "wall_s": 0.1, "version": "x", "key": f"k{k:02d}"}
        sw._write_row(out / "results" / f"k{k:02d}.parquet", {**base, **row})


#: Two settings; a=1: two runs of 1-s bins, one shorter, and a failed run; a=2: a 1-s run and a 2-s run (a long one).
SYNTHETIC = [
    {"param.a": "1", "rmse_total_x": 1.0, "series.bin_s": 1.0, "series.t": [0.5, 1.5, 2.5, 3.5],
     "series.position_error": [1.0, 2.0, 3.0, None]},
    {"param.a": "1", "rmse_total_x": 2.0, "series.bin_s": 1.0, "series.t": [0.5, 1.5],
     "series.position_error": [3.0, 4.0]},
    {"param.a": "1", "status": "failed", "error": "RuntimeError: broken"},
    {"param.a": "2", "rmse_total_x": 3.0, "series.bin_s": 1.0, "series.t": [0.5, 1.5, 2.5, 3.5],
     "series.position_error": [1.0, 2.0, 3.0, None]},
    {"param.a": "2", "rmse_total_x": 4.0, "series.bin_s": 2.0, "series.t": [1.0, 3.0],
     "series.position_error": [2.0, 6.0], "series.nees": [4.0, None]},
]


@pytest.mark.slow
def test_time_series_bands_are_the_mean_and_std_over_seeds_of_the_aligned_bins(tmp_path):
    out = tmp_path / "s"
    _store(out, SYNTHETIC, {"a": ["1", "2"]})
    md, numbers = sw.summarize(out)
    one, two = numbers["series"]["position_error"]
    assert one["setting"] == {"a": "1"} and one["runs"] == 2 and one["bin_s"] == 1.0
    assert one["t"] == [0.5, 1.5, 2.5, 3.5] and one["n"] == [2, 2, 1, 0]  # the short run has 2 bins
    assert one["mean"] == [2.0, 3.0, 3.0, None] and one["std"] == [1.0, 1.0, 0.0, None]
    # a=2: the 1-s run merged into the 2-s run's bins ([1, 2] -> 1.5, [3, None] -> 3)
    assert two["t"] == [1.0, 3.0] and two["n"] == [2, 2]
    assert two["mean"] == pytest.approx([1.75, 4.5]) and two["std"] == pytest.approx([0.25, 1.5])
    (nees,) = numbers["series"]["nees"]  # only a=2 recorded it, one run
    assert nees["setting"] == {"a": "2"} and nees["mean"] == [4.0, None] and nees["n"] == [1, 0]
    assert "`position_error`" in md and "`nees`" in md and "tracking_error" not in md

    result = CliRunner().invoke(main, ["summarize", str(out)])
    assert result.exit_code == 0, result.output
    text = (out / "summary.md").read_text()
    for name in ("position_error_over_time.png", "nees_over_time.png", "rmse_total_x_vs_a.png"):
        assert (out / "summary" / name).stat().st_size > 0 and f"summary/{name}" in text
    assert json.loads((out / "summary.json").read_text())["series"]["position_error"][0]["std"] == [1, 1, 0, None]


@pytest.mark.slow
def test_time_series_bands_over_many_settings_go_to_several_figures(tmp_path):
    rows = [{"param.a": str(k), "series.bin_s": 1.0, "series.t": [0.5, 1.5], "series.position_error": [k, 2.0]}
            for k in range(sw.BANDS_PER_FIGURE + 1)]
    _store(tmp_path / "s", rows, {"a": [str(k) for k in range(len(rows))]})
    paths = sw.plot_series(sw.summarize(tmp_path / "s")[1], tmp_path / "fig")
    assert [p.name for p in paths] == ["position_error_over_time.png", "position_error_over_time_2.png"]


def test_summarize_of_a_store_without_time_series_says_so(tmp_path, monkeypatch):
    import swarmtrack.sim.engine as engine

    def broken(scenario, *a, **k):
        raise RuntimeError("a broken run")

    monkeypatch.setattr(engine, "simulate", broken)
    _batches_run_alone(monkeypatch)
    out = tmp_path / "s"
    sw.sweep("l24-cv", {"sensor.latency": ["0"]}, 2, out, workers=1, overrides=SHORT)
    result = CliRunner().invoke(main, ["summarize", str(out)])
    assert result.exit_code == 0, result.output
    assert "No time series: no stored run finished" in result.output
    assert json.loads((out / "summary.json").read_text())["series"] == {}
    assert "| 0 | 0/2 |" in (out / "summary.md").read_text()


def test_a_store_of_another_format_or_with_incomplete_rows_exits_2_with_the_cause(tmp_path):
    old = tmp_path / "old"
    _store(old, [{k: v for k, v in SYNTHETIC[0].items() if not k.startswith("series.")}], {"a": ["1"]}, fmt=1)
    for args in (["summarize", str(old)],
                 ["sweep", "l24-cv", "--grid", "sensor.latency=0", "--runs", "1", "--out", str(old), "--resume"]):
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 2, result.output
        assert "format 1" in result.output and f"format {sw.STORE_FORMAT}" in result.output
        assert "Traceback" not in result.output
    lacking = tmp_path / "lacking"  # the manifest of this version, a row of an older one
    _store(lacking, [SYNTHETIC[0], {k: v for k, v in SYNTHETIC[1].items() if k != "series.t"}], {"a": ["1"]})
    result = CliRunner().invoke(main, ["summarize", str(lacking)])
    assert result.exit_code == 2, result.output
    assert "k01.parquet" in result.output and "series.t" in result.output and "Traceback" not in result.output
    assert not (lacking / "summary.md").exists()


@pytest.mark.slow
def test_dask_workers_are_warmed_with_the_sweeps_scenario_before_the_first_job():
    def compiled():  # defined here, so Dask ships it by value and the worker imports nothing of this test
        from swarmtrack.estimation import kernels

        return bool(kernels.cv_cycle.signatures)

    cold = sw.dask_client("local", 1)  # imports only
    try:
        assert list(cold.run(compiled).values()) == [False]
    finally:
        sw.close_client(cold)
    client = sw.dask_client("local", 2, warm_with=load_scenario("l24-cv", SHORT))
    try:
        assert list(client.run(compiled).values()) == [True, True]  # the compiled kernels loaded in each worker
    finally:
        sw.close_client(client)
