import json
import signal
import subprocess
import sys
import time

import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from swarmtrack.analysis.metrics import summary
from swarmtrack.cli import main
from swarmtrack.outputs import finite
from swarmtrack.sim.recorder import Recording

SHORT = ["--set", "duration=6", "--set", "target.profile=l23"]


@pytest.mark.slow
def test_run_writes_resolved_scenario_metrics_timeseries_and_figures(tmp_path):
    out = tmp_path / "run"
    res = CliRunner().invoke(main, ["run", "l24-cv", "--out", str(out), "--seed", "4", *SHORT])
    assert res.exit_code == 0, res.output
    assert "RMSE" in res.output
    assert {p.name for p in out.iterdir()} >= {"scenario.yaml", "metrics.json", "recording", "estimates.png",
                                                "inter_agent_distances.png", "manifest.json"}
    metrics = json.loads((out / "metrics.json").read_text())
    assert set(metrics["rmse"]["total"]) == {"x", "y", "vx", "vy"}
    rec = Recording.load(out / "recording")
    assert rec.estimate.shape == (120, 3, 4) and rec.uav.shape == (120, 3, 4) and rec.target.shape == (120, 4)
    assert finite(summary(rec)) == {k: v for k, v in metrics.items() if k != "written_by"}  # the recording's
    assert metrics["written_by"].startswith("swarmtrack ")
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


@pytest.mark.slow
def test_impossible_spawn_box_is_a_clear_error(tmp_path):
    res = CliRunner().invoke(main, ["run", "l24-cv", "--out", str(tmp_path / "o"), "--no-plots",
                                    "--set", "swarm.spawn_half_width=0.1"])
    assert res.exit_code == 2 and "swarm.spawn_half_width" in res.output and "Traceback" not in res.output


def test_a_run_that_never_chases_still_reports(tmp_path):
    res = CliRunner().invoke(main, ["run", "l24-cv", "--out", str(tmp_path / "o"), "--no-plots",
                                    "--set", "duration=3", "--set", "controller.chase_after_steps=1000000"])
    assert res.exit_code == 0, res.output


def _run(*args):
    return CliRunner().invoke(main, ["run", "l24-cv", "--no-plots", "--set", "duration=1", *args])


def test_an_existing_folder_is_never_wiped(tmp_path):
    mine = tmp_path / "notes.txt"
    mine.write_text("my thesis")
    res = _run("--out", str(tmp_path))
    assert res.exit_code == 2 and "not empty" in res.output and "Traceback" not in res.output
    assert mine.read_text() == "my thesis" and sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_overwrite_replaces_only_the_files_of_the_earlier_run(tmp_path):
    out = tmp_path / "run"
    assert _run("--out", str(out)).exit_code == 0
    (out / "notes.txt").write_text("mine")
    again = _run("--out", str(out))
    assert again.exit_code == 2 and "--overwrite" in again.output
    assert _run("--out", str(out), "--overwrite", "--seed", "7").exit_code == 0
    assert (out / "notes.txt").read_text() == "mine"
    assert "seed: 7" in (out / "scenario.yaml").read_text()
    manifest = json.loads((out / "manifest.json").read_text())
    assert "recording/uavs.parquet" in manifest["files"] and "notes.txt" not in manifest["files"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no staging folder left


def test_without_out_each_run_gets_its_own_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert _run().exit_code == 0 and _run("--seed", "2").exit_code == 0
    assert _run("--set", "swarm.n_uavs=2").exit_code == 0
    folders = sorted(p.name for p in (tmp_path / "runs").iterdir())
    assert len(folders) == 3 and all(f.startswith("l24-cv-seed") for f in folders)
    assert _run().exit_code == 2  # the same resolved scenario again: its folder holds that run


@pytest.mark.parametrize("name", ["..", ".", "", "/tmp/x", "a/b"])
def test_a_scenario_name_is_a_label_not_a_path(tmp_path, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    res = _run("--set", f"name={name!r}" if name else "name=''")
    assert res.exit_code == 2 and "name" in res.output
    assert not any(tmp_path.iterdir())


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_an_interrupted_run_leaves_nothing_half_written(tmp_path, sig):
    out = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-m", "swarmtrack.cli", "run", "l24-fs", "--out", str(out), "--no-plots"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline and not any(p.name.endswith(".partial") for p in tmp_path.iterdir()):
        time.sleep(0.05)  # wait until the run is writing into its staging folder
    time.sleep(0.5)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "nothing was written" in err, (proc.returncode, err[-3000:])
    assert list(tmp_path.iterdir()) == []  # no staging folder, no partial run


def test_metrics_json_is_strict_json_with_null_for_undefined_numbers(tmp_path):
    out = tmp_path / "run"
    res = _run("--out", str(out), "--set", "swarm.n_uavs=2", "--set", "swarm.initial_positions=[[0, 0], [90, 0]]",
               "--set", "controller.chase_after_steps=100000")  # two UAVs that never become neighbours
    assert res.exit_code == 0, res.output

    def refuse(constant):
        raise AssertionError(f"{constant} in metrics.json")

    metrics = json.loads((out / "metrics.json").read_text(), parse_constant=refuse)
    assert metrics["inter_agent_distance"]["offset"] is None  # no neighbour pair: undefined, not NaN


def test_a_run_that_never_sees_the_target_warns_and_strict_fails_it(tmp_path):
    args = ["--set", "sensor.max_range=0.5", "--set", "duration=4", "--set", "sensor.latency=0"]
    res = CliRunner().invoke(main, ["run", "l24-cv", "--no-plots", "--out", str(tmp_path / "a"), *args])
    assert res.exit_code == 0 and "warning: no UAV ever detected the target" in res.output
    metrics = json.loads((tmp_path / "a" / "metrics.json").read_text())
    assert [w["kind"] for w in metrics["warnings"]][:1] == ["never_detected"]
    strict = CliRunner().invoke(main, ["run", "l24-cv", "--no-plots", "--strict", "--out", str(tmp_path / "b"), *args])
    assert strict.exit_code == 3 and (tmp_path / "b" / "metrics.json").is_file()  # the run is kept, and flagged


def test_a_healthy_run_has_no_warnings(tmp_path):
    res = CliRunner().invoke(main, ["run", "l24-cv", "--no-plots", "--strict", "--out", str(tmp_path / "a"), "--set",
                                    "duration=30", "--set", "sensor.latency=0"])
    assert res.exit_code == 0, res.output
    assert json.loads((tmp_path / "a" / "metrics.json").read_text())["warnings"] == []


def test_a_run_loads_back_with_one_based_uavs_and_phase_names(tmp_path):
    import swarmtrack

    out = tmp_path / "run"
    res = CliRunner().invoke(main, ["run", "l24-cv", "--no-plots", "--out", str(out), "--format", "csv", *SHORT])
    assert res.exit_code == 0, res.output
    rec = swarmtrack.load_run(out)
    uavs, objects = rec.frame("uavs"), rec.frame("objects")
    assert sorted(uavs["uav"].unique()) == [1, 2, 3] and len(uavs) == 3 * 120
    target = objects[objects["group"] == "targets"]
    assert set(target["phase"]) == {"sinusoidal"} and set(target["member"]) == {1}
    assert objects[objects["group"] == "uavs"]["phase"].isna().all()
    csv_uavs = (out / "timeseries" / "uavs.csv").read_text().splitlines()
    header = csv_uavs[0].split(",")
    assert {"t", "uav", "estimate_1", "covariance_4_4"} <= set(header) and len(csv_uavs) == 1 + 3 * 120
    assert {"group", "member", "phase", "x"} <= set((out / "timeseries" / "objects.csv").read_text().split("\n")[0]
                                                     .split(","))


@pytest.mark.parametrize("where, why", [("/proc/swarmtrack-run", "/proc"), ("{file}/x", "is a file"),
                                        ("{file}", "is a file")])
def test_an_impossible_out_is_one_clear_error(tmp_path, where, why):
    a_file = tmp_path / "a_file"
    a_file.write_text("keep me")
    res = _run("--out", where.format(file=a_file))
    assert res.exit_code == 2 and why in res.output and "Traceback" not in res.output
    assert a_file.read_text() == "keep me"


def test_another_tools_manifest_is_not_a_licence_to_delete(tmp_path):
    (tmp_path / "manifest.json").write_text(json.dumps({"files": ["thesis.tex"]}))
    (tmp_path / "thesis.tex").write_text("mine")
    res = _run("--out", str(tmp_path), "--overwrite")
    assert res.exit_code == 2 and "holds no swarmtrack run" in res.output
    assert (tmp_path / "thesis.tex").read_text() == "mine"


def test_overwrite_refuses_to_replace_a_file_the_earlier_run_did_not_write(tmp_path):
    out = tmp_path / "run"
    assert _run("--out", str(out)).exit_code == 0
    (out / "timeseries").mkdir()
    (out / "timeseries" / "uavs.csv").write_text("my own table")
    res = _run("--out", str(out), "--overwrite", "--format", "csv")
    assert res.exit_code == 2 and "timeseries/uavs.csv" in res.output and "not written by the earlier run" in res.output
    assert (out / "timeseries" / "uavs.csv").read_text() == "my own table"
    assert (out / "metrics.json").is_file() and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_overwrite_does_not_follow_a_link_put_where_the_earlier_run_had_a_folder(tmp_path):
    """The earlier run wrote recording/uavs.parquet; the user replaced recording/ with a link to their own data.
    --overwrite must not delete through the link (the new run's files then do not fit: a clear refusal)."""
    out = tmp_path / "run"
    assert _run("--out", str(out)).exit_code == 0
    mine = tmp_path / "mine"
    mine.mkdir()
    for f in (out / "recording").iterdir():
        (mine / f.name).write_text("my data")
        f.unlink()
    (out / "recording").rmdir()
    (out / "recording").symlink_to(mine, target_is_directory=True)
    res = _run("--out", str(out), "--overwrite")
    assert res.exit_code == 2 and "symbolic link" in res.output and "Traceback" not in res.output
    assert all(p.read_text() == "my data" for p in mine.iterdir()) and len(list(mine.iterdir())) >= 2


@pytest.mark.parametrize(("scenario", "words"), [("w20-mpc-collision", "distance from each place"),
                                                 ("ib21-fleet-6", "guarantee violations")])
def test_run_prints_the_capabilitys_own_result(tmp_path, scenario, words):
    res = CliRunner().invoke(main, ["run", scenario, "--set", "duration=2", "--out", str(tmp_path / "r"),
                                    "--no-plots"])
    assert res.exit_code == 0 and words in res.output, res.output


def test_a_termination_during_kernel_compilation_waits_until_the_compiler_returns():
    """SIGINT or SIGTERM in numba's code is deferred (retried by a short timer): raising inside LLVM's callbacks
    crashes the process."""
    import os

    from swarmtrack import outputs

    namespace = {"sys": sys}
    code = compile("frame = sys._getframe()", os.path.join("site-packages", "numba", "core", "compiler.py"), "exec")
    exec(code, namespace)
    assert outputs.in_compiler(namespace["frame"])
    assert not outputs.in_compiler(sys._getframe())
    with outputs.terminate_as_exception():
        signal.getsignal(signal.SIGINT)(signal.SIGINT, namespace["frame"])  # deferred: no exception now
        assert signal.getitimer(signal.ITIMER_REAL)[0] > 0
        signal.setitimer(signal.ITIMER_REAL, 0)  # fire the retry by hand (no real alarm inside the test)
        with pytest.raises(outputs.Terminated):
            signal.getsignal(signal.SIGALRM)(signal.SIGALRM, sys._getframe())
    assert signal.getitimer(signal.ITIMER_REAL)[0] == 0


@pytest.mark.slow
def test_two_runs_started_together_with_one_out_never_both_report_success(tmp_path):
    """Without --overwrite the late run never replaces the first's files: it fails (exit 2) naming the cause, or
    was refused at its start; exactly one run's files are there, and they are the ones its manifest lists."""
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "swarmtrack.cli", "run", "l24-cv", "--set", "duration=3", "--out", str(out),
           "--no-plots"]
    procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
    results = [p.communicate(timeout=240) for p in procs]
    codes = sorted(p.returncode for p in procs)
    assert codes == [0, 2], (codes, [err[-2000:] for _, err in results])
    late = next(err for p, (_, err) in zip(procs, results, strict=True) if p.returncode == 2)
    assert "another run wrote its files there" in late or "holds an earlier run" in late, late[-2000:]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["files"] and all((out / f).is_file() for f in manifest["files"])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no staging folder left
