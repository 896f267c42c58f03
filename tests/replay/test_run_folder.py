"""Replaying a run folder with its own scenario gives the run's estimates bit for bit (the round trip of issue 25)."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import swarmtrack
from swarmtrack.cli import main
from swarmtrack.replay import run_folder
from swarmtrack.replay.engine import replay
from swarmtrack.replay.steps import LogError
from swarmtrack.sim.engine import simulate


def _whole(rec) -> dict:
    """The recording's arrays over all its chunks (a replay's chunks are shorter than a long run's)."""
    chunks = list(rec.chunks())
    return {"t": np.concatenate([c.t for c in chunks]), "truth": np.concatenate([c.truth for c in chunks]),
            "phase": np.concatenate([c.phase for c in chunks]),
            **{f"probe:{k}": np.concatenate([c.probes[k] for c in chunks]) for k in chunks[0].probes}}


def _same_recordings(a, b) -> None:
    """Every probe of the estimator and every truth column of ``a`` (a run) equal in ``b`` (its replay)."""
    whole_a, whole_b = _whole(a), _whole(b)
    assert any(k.startswith("probe:") for k in whole_b)  # the estimator's (the controller did not run)
    for name, values in whole_b.items():
        assert np.array_equal(whole_a[name], values, equal_nan=True), name


def _round_trip(tmp_path, name: str, duration: float | None) -> None:
    overrides = [] if duration is None else [f"duration={duration}"]
    scenario = swarmtrack.load_scenario(name, overrides, seed=3)
    run = simulate(scenario, record_to=tmp_path / "run")
    again = replay(scenario, run_folder.steps([tmp_path / "run"], scenario, None, {}), tmp_path / "replayed")
    assert again.meta["n_steps"] == run.meta["n_steps"] > 0
    _same_recordings(run, again)
    # a replay keeps its inputs: replayed once more, it gives the same numbers again
    twice = replay(scenario, run_folder.steps([tmp_path / "replayed"], scenario, None, {}))
    _same_recordings(again, twice)


@pytest.mark.parametrize("name, duration", [("l24-ct", 12), pytest.param("w20-switching", 8, marks=pytest.mark.slow),
                                            # a quarter of IB21's 400 s (its whole run took 52 s of the suite)
                                            pytest.param("ib21-fleet-2", 100, marks=pytest.mark.slow),
                                            pytest.param("l24-3d-ct", 8, marks=pytest.mark.slow)])  # sensor_z kept
def test_a_replayed_run_folder_gives_the_runs_estimates_bit_for_bit(tmp_path, name, duration):
    _round_trip(tmp_path, name, duration)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["l24-ct", "w20-switching"])
def test_a_whole_run_replayed_gives_its_estimates_bit_for_bit(tmp_path, name):
    _round_trip(tmp_path, name, None)


def test_the_replay_command_writes_a_run_folder_with_the_runs_metrics(tmp_path):
    run, out = tmp_path / "run", tmp_path / "replayed"
    ran = CliRunner().invoke(main, ["run", "l24-ct", "--set", "duration=6", "--no-plots", "--out", str(run)])
    assert ran.exit_code == 0, ran.output
    res = CliRunner().invoke(main, ["replay", str(run), "--no-plots", "--out", str(out)])
    assert res.exit_code == 0, res.output
    a, b = (json.loads((p / "metrics.json").read_text()) for p in (run, out))
    assert a["rmse"] == b["rmse"] and a["consistency"] == b["consistency"]
    assert b["replay"]["format"] == "run" and b["replay"]["skipped"] == {}
    assert (out / "manifest.json").is_file() and (out / "scenario.yaml").is_file()
    # another estimator on the same flight: the question a replay answers
    other = CliRunner().invoke(main, ["replay", str(run), "--set", "estimator.model=cv", "--no-plots",
                                      "--out", str(tmp_path / "cv")])
    assert other.exit_code == 0, other.output
    assert json.loads((tmp_path / "cv" / "metrics.json").read_text())["rmse"] != a["rmse"]


def test_a_run_folder_that_does_not_fit_the_scenario_is_refused_naming_why(tmp_path):
    scenario = swarmtrack.load_scenario("l24-ct", ["duration=1"], seed=3)
    simulate(scenario, record_to=tmp_path / "run")
    bigger = swarmtrack.load_scenario("l24-ct", ["duration=1", "swarm.n_uavs=4"], seed=3)
    with pytest.raises(LogError, match="flew 3 UAVs, the scenario has swarm.n_uavs 4"):
        run_folder.steps([tmp_path / "run"], bigger, None, {})
    rate = 2 * scenario.rates.estimation
    faster = swarmtrack.load_scenario("l24-ct", ["duration=1", f"rates.estimation={rate}", f"rates.control={rate}",
                                                 f"rates.physics={5 * rate}"], seed=3)
    with pytest.raises(LogError, match="rates.estimation"):
        run_folder.steps([tmp_path / "run"], faster, None, {})
    simulate(scenario, record_to=tmp_path / "bare", inputs=False)
    with pytest.raises(LogError, match="kept no navigation and detections"):
        run_folder.steps([tmp_path / "bare"], scenario, None, {})
    res = CliRunner().invoke(main, ["replay", str(tmp_path / "run"), "--scenario", "l24-ct", "--set", "swarm.n_uavs=4",
                                    "--out", str(tmp_path / "x")])
    assert res.exit_code == 2 and "swarm.n_uavs 4" in res.output and "Traceback" not in res.output
    assert not (tmp_path / "x").exists()
    missing = CliRunner().invoke(main, ["replay", str(tmp_path / "nothing"), "--out", str(tmp_path / "y")])
    assert missing.exit_code == 2 and "no such file" in missing.output


@pytest.mark.slow
@pytest.mark.parametrize("name", ["w20-switching", "ib21-fleet-2"])
def test_every_capabilitys_replay_writes_its_metrics_and_figures(tmp_path, name):
    """The command on a W20 and an IB21 run folder: the run's own figures and metrics, the controller's absent
    (it did not run) and IB21's truth-side guarantee check said not to have run."""
    run, out = tmp_path / "run", tmp_path / "replayed"
    assert CliRunner().invoke(main, ["run", name, "--set", "duration=6", "--out", str(run)]).exit_code == 0
    res = CliRunner().invoke(main, ["replay", str(run), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert list(out.glob("*.png"))
    metrics = json.loads((out / "metrics.json").read_text())
    if name == "ib21-fleet-2":
        assert "the guarantee not checked" in res.output and metrics["set_membership"]["guarantee_violations"] is None
        ran = json.loads((run / "metrics.json").read_text())
        assert metrics["set_membership"]["phi_bar_final"] == ran["set_membership"]["phi_bar_final"]


def _damage(folder, how: str) -> str:
    """Damage the run folder ``folder`` as ``how`` says; returns the file the refusal must name."""
    rec = folder / "recording"
    if how == "truncated":
        table = rec / "objects.parquet"
        table.write_bytes(table.read_bytes()[: table.stat().st_size // 2])
        return str(table)
    if how == "empty file":
        (rec / "uavs.parquet").write_bytes(b"")
        return str(rec / "uavs.parquet")
    if how == "junk file":
        (rec / "navigation.parquet").write_bytes(b"\xff\xfenot parquet" * 20)
        (rec / "notes.txt").write_text("a file of the user's, left alone")
        return str(rec / "navigation.parquet")
    if how == "damaged inside":  # the footer whole, the pages not
        table = rec / "objects.parquet"
        data = bytearray(table.read_bytes())
        data[8: len(data) // 2] = b"\xab" * (len(data) // 2 - 8)
        table.write_bytes(bytes(data))
        return str(rec)
    for f in rec.iterdir():
        if how == "empty recording" or f.name == "meta.json":
            f.unlink()
    return str(rec / "meta.json")


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    scenario = swarmtrack.load_scenario("l24-ct", ["duration=2"], seed=3)
    folder = tmp_path_factory.mktemp("small") / "run"
    simulate(scenario, record_to=folder / "recording")
    (folder / "scenario.yaml").write_text(yaml.safe_dump(scenario.model_dump(mode="json")))
    return folder


@pytest.mark.parametrize("how", ["truncated", "empty file", "junk file", "damaged inside", "empty recording",
                                 "no meta.json"])
def test_replay_and_export_of_a_damaged_run_folder_name_the_file_exit_2_and_write_nothing(tmp_path, small_run, how):
    folder = tmp_path / "run"
    shutil.copytree(small_run, folder)
    named = _damage(folder, how)
    for args, out in ((["replay", str(folder), "--no-plots"], tmp_path / "replayed"),
                      (["export", str(folder)], tmp_path / "run.mcap"),
                      (["export", str(folder), "--format", "csv"], tmp_path / "run.csv")):
        res = CliRunner().invoke(main, [*args, "--out", str(out)])
        assert res.exit_code == 2, (args, res.output)
        assert "Traceback" not in res.output and named in res.output and res.output.count("\n") == 1, res.output
        assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # nothing written, no staging left
    if how == "junk file":
        assert (folder / "recording" / "notes.txt").is_file()


def test_opening_a_run_folder_reads_only_its_footers(small_run, monkeypatch):
    """No row is read when a run folder is opened (judged by what it reads, not by a time a busy machine moves)."""
    import pyarrow.parquet as pq

    def refuse(*args, **kwargs):
        raise AssertionError("open_run read rows, not only the footers")

    for name in ("read", "read_row_group", "read_row_groups", "iter_batches"):
        monkeypatch.setattr(pq.ParquetFile, name, refuse)
    monkeypatch.setattr(pq, "read_table", refuse)
    rec = run_folder.open_run(small_run)
    assert rec.meta["n_steps"] > 0 and rec.path == small_run / "recording"


def test_a_run_folder_without_inputs_is_refused_saying_which_command_wrote_it_and_what_to_do(tmp_path):
    scenario = swarmtrack.load_scenario("l24-ct", ["duration=1"], seed=3)
    live = tmp_path / "live"
    simulate(scenario, record_to=live / "recording", inputs=False)
    (live / "metrics.json").write_text(json.dumps({"live": {"rejected": 0}, "written_by": "swarmtrack 9.9"}))
    (live / "scenario.yaml").write_text(yaml.safe_dump(scenario.model_dump(mode="json")))
    res = CliRunner().invoke(main, ["replay", str(live), "--out", str(tmp_path / "x")])
    assert res.exit_code == 2 and "Traceback" not in res.output and not (tmp_path / "x").exists()
    assert "written by swarmtrack live (swarmtrack 9.9), which keeps no navigation and detections" in res.output
    assert "swarmtrack run" in res.output and "before" not in res.output  # no old version blamed
    simulate(scenario, record_to=tmp_path / "bare", inputs=False)  # no metrics.json: what may have made it
    with pytest.raises(LogError, match=r"kept no navigation and detections .*inputs=False.*swarmtrack run"):
        run_folder.steps([tmp_path / "bare"], scenario, None, {})
