import json

import pyarrow.parquet as pq
from click.testing import CliRunner

from swarmtrack.analysis.metrics import summary
from swarmtrack.cli import main
from swarmtrack.sim.recorder import Recording

SHORT = ["--set", "duration=6", "--set", "target.profile=l23"]


def test_run_writes_resolved_scenario_metrics_timeseries_and_figures(tmp_path):
    out = tmp_path / "run"
    res = CliRunner().invoke(main, ["run", "l24-cv", "--out", str(out), "--seed", "4", *SHORT])
    assert res.exit_code == 0, res.output
    assert "RMSE" in res.output
    assert {p.name for p in out.iterdir()} >= {"scenario.yaml", "metrics.json", "recording", "estimates.png",
                                                "inter_agent_distances.png"}
    metrics = json.loads((out / "metrics.json").read_text())
    assert set(metrics["rmse"]["total"]) == {"x", "y", "vx", "vy"}
    rec = Recording.load(out / "recording")
    assert rec.estimate.shape == (120, 3, 4) and rec.uav.shape == (120, 3, 4) and rec.target.shape == (120, 4)
    assert summary(rec) == metrics  # the metrics are those of the recording on disk
    rows = pq.read_table(out / "recording" / "uavs.parquet")
    assert rows.num_rows == 3 * 120 and {"step", "uav", "estimate", "covariance"} <= set(rows.column_names)
    assert "seed: 4" in (out / "scenario.yaml").read_text()


def test_same_seed_same_numbers_bit_for_bit(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    for out in (a, b):
        assert CliRunner().invoke(main, ["run", "l24-ct", "--out", str(out), "--no-plots", *SHORT]).exit_code == 0
    for name in ("uavs.parquet", "objects.parquet", "meta.json"):
        assert (a / "recording" / name).read_bytes() == (b / "recording" / name).read_bytes()


def test_bad_input_exits_2_with_one_message_and_writes_nothing(tmp_path):
    out = tmp_path / "bad"
    cases = [
        ["--set", "rates.estimation=-1"],
        ["--set", "estimator.q=[1, 1, 0, 1]"],
        ["--set", "network.topology=edges", "--set", "network.edges=[[1, 4]]"],
        ["--set", "nonsense"],
        ["--set", "estimator.colour=blue"],
    ]
    for extra in cases:
        res = CliRunner().invoke(main, ["run", "l24-cv", "--out", str(out), "--no-plots", *extra])
        assert res.exit_code == 2, (extra, res.output)
        assert "Traceback" not in res.output and "Error" in res.output
        assert not out.exists()
    res = CliRunner().invoke(main, ["run", "missing.yaml", "--out", str(out)])
    assert res.exit_code == 2 and "no built-in scenario or file" in res.output


def test_scenarios_lists_builtins():
    res = CliRunner().invoke(main, ["scenarios"])
    assert res.exit_code == 0 and "l24-fs" in res.output and "l23-flocking-tailored" in res.output


def test_impossible_spawn_box_is_a_clear_error(tmp_path):
    res = CliRunner().invoke(main, ["run", "l24-cv", "--out", str(tmp_path / "o"), "--no-plots",
                                    "--set", "swarm.spawn_half_width=0.1"])
    assert res.exit_code == 2 and "swarm.spawn_half_width" in res.output and "Traceback" not in res.output


def test_a_run_that_never_chases_still_reports(tmp_path):
    res = CliRunner().invoke(main, ["run", "l24-cv", "--out", str(tmp_path / "o"), "--no-plots",
                                    "--set", "duration=3", "--set", "controller.chase_after_steps=1000000"])
    assert res.exit_code == 0, res.output
