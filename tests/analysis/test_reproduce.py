import json

import pytest

from swarmtrack.analysis import reproduce as rep
from swarmtrack.analysis.papers import PAPERS, Claim, Paper
from swarmtrack.analysis.reproduce import CACHE_FORMAT, cache_path, package_version, reproduce, run_all, run_key
from swarmtrack.scenarios import Scenario, load_scenario


@pytest.mark.slow
def test_l23_reproduction_reports_every_claim_and_resumes(tmp_path):
    report = reproduce("l23", tmp_path, runs=1, workers=1, quiet=True)
    assert (tmp_path / "l23_fig1_flocking.png").stat().st_size > 1000
    saved = json.loads((tmp_path / "reproduction.json").read_text())
    assert saved["claims"] == report["claims"]
    ids = {c["id"] for c in saved["claims"]}
    assert ids == {"l23-fusion-halves-spread", "l23-standard-offset-removed", "l23-tailored-smoother"}
    for claim in saved["claims"]:
        assert set(claim) == {"id", "text", "paper", "project", "holds"}
        assert isinstance(claim["holds"], bool)
    flock = {c["id"]: c for c in saved["claims"]}["l23-standard-offset-removed"]["project"]
    assert flock["standard"] > 0.1 > flock["tailored"]
    md = (tmp_path / "reproduction.md").read_text()
    assert "no-fusion" in md and "0.2647" in md  # the paper's number beside ours
    cached = sorted((tmp_path / "runs").glob("*.json"))
    assert len(cached) == 5
    stamps = [p.stat().st_mtime_ns for p in cached]
    reproduce("l23", tmp_path, runs=1, workers=1, quiet=True, figures=False)  # finished runs are reused, not rerun
    assert [p.stat().st_mtime_ns for p in cached] == stamps


@pytest.mark.slow
def test_l24_claims_that_the_project_reproduces_hold_on_one_seed():
    from swarmtrack.analysis.metrics import rmse_table
    from swarmtrack.sim.engine import simulate

    rmse = {m: rmse_table(simulate(load_scenario(f"l24-{m}", seed=3))) for m in ("cv", "ct", "fs")}

    def vel(m, phase):
        return (rmse[m][phase]["vx"] + rmse[m][phase]["vy"]) / 2

    assert vel("ct", "circular") <= 0.5 * vel("cv", "circular")  # L24 Sec. 4: "about four times smaller"
    assert vel("cv", "linear") < min(vel("ct", "linear"), vel("fs", "linear"))  # CV best on the linear phase


# --- run cache (no simulation: run_one is replaced by a recorder) ---

@pytest.fixture
def runs(monkeypatch):
    """Replaces the simulation; records the resolved scenarios it is given."""
    seen = []

    def fake_run_one(scenario):
        assert isinstance(scenario, Scenario)  # the resolved scenario, not a name
        seen.append(scenario)
        return {"seed": scenario.seed, "duration": scenario.duration}

    monkeypatch.setattr(rep, "run_one", fake_run_one)
    monkeypatch.setattr(rep, "run_batch", lambda scenarios: [fake_run_one(s) for s in scenarios])
    return seen


def entry_path(cache, name="l24-cv", seed=1):
    scn = load_scenario(name, seed=seed)
    return cache_path(cache, scn, run_key(scn))


def test_a_cached_run_is_reused_and_carries_its_key(tmp_path, runs, capsys):
    first = run_all([("l24-cv", 1), ("l24-cv", 2)], tmp_path, workers=1)
    assert [s.seed for s in runs] == [1, 2]
    path = entry_path(tmp_path)
    entry = json.loads(path.read_text())
    key = run_key(load_scenario("l24-cv", seed=1))
    assert entry.pop("written_by").startswith(f"swarmtrack {package_version()}")  # and the git commit if any
    assert entry == {"format": CACHE_FORMAT, "version": package_version(), "key": key, "scenario": "l24-cv",
                     "seed": 1, "metrics": {"seed": 1, "duration": None}}
    assert path.name == f"l24-cv-seed1-{entry['key'][:12]}.json"
    stamp = path.stat().st_mtime_ns
    again = run_all([("l24-cv", 1), ("l24-cv", 2)], tmp_path, workers=1)
    assert again == first and len(runs) == 2  # nothing ran again
    assert path.stat().st_mtime_ns == stamp
    assert capsys.readouterr().err == ""
    assert not list(tmp_path.glob("*.tmp"))


@pytest.mark.parametrize(("damage", "reason"), [
    (lambda e: "{not json", "corrupt"),
    (lambda e: "", "corrupt"),
    (lambda e: json.dumps([1, 2]), "corrupt"),
    (lambda e: json.dumps({**e, "version": "0.0.1"}), "stale"),
    (lambda e: json.dumps({**e, "key": "0" * 64}), "foreign"),
    (lambda e: json.dumps({**e, "format": CACHE_FORMAT + 1}), "foreign"),
    (lambda e: json.dumps({**e, "metrics": None}), "corrupt"),
], ids=["not-json", "empty", "not-an-object", "other-version", "other-key", "other-format", "no-metrics"])
def test_a_bad_cache_entry_is_run_again_with_one_warning_line(tmp_path, runs, capsys, damage, reason):
    run_all([("l24-cv", 1)], tmp_path, workers=1)
    path = entry_path(tmp_path)
    path.write_text(damage(json.loads(path.read_text())))
    result = run_all([("l24-cv", 1)], tmp_path, workers=1)
    assert len(runs) == 2 and result == {("l24-cv", 1): {"seed": 1, "duration": None}}
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"warning: cached run {path} is {reason} (") and err.endswith("; running it again\n")
    assert json.loads(path.read_text())["version"] == package_version()  # rewritten, valid again
    run_all([("l24-cv", 1)], tmp_path, workers=1)
    assert len(runs) == 2 and capsys.readouterr().err == ""


def test_the_key_follows_the_resolved_scenario_and_the_version():
    base = load_scenario("l24-cv", seed=1)
    assert run_key(base) == run_key(load_scenario("l24-cv", seed=1))
    assert run_key(base) != run_key(load_scenario("l24-cv", seed=2))
    assert run_key(base) != run_key(load_scenario("l24-cv", ["duration=7"], seed=1))
    assert run_key(base, "0.1.0") != run_key(base, "9.9.9")


def test_an_edited_scenario_is_not_served_from_the_old_entry(tmp_path, runs, capsys, monkeypatch):
    run_all([("l24-cv", 1)], tmp_path, workers=1)
    old = entry_path(tmp_path)
    # the built-in file changes under the same name: the loader now resolves another scenario
    def shortened(name, overrides=(), seed=None):
        return load_scenario(name, ["duration=7", *overrides], seed)

    monkeypatch.setattr(rep, "load_scenario", shortened)
    result = run_all([("l24-cv", 1)], tmp_path, workers=1)
    assert result[("l24-cv", 1)] == {"seed": 1, "duration": 7.0}
    assert [s.duration for s in runs] == [None, 7.0]
    assert len(list(tmp_path.glob("l24-cv-seed1-*.json"))) == 2 and old.is_file()
    assert capsys.readouterr().err == f"warning: cached run {old} is stale (the scenario changed); running it again\n"


def test_an_unkeyed_entry_from_an_older_layout_is_not_reused(tmp_path, runs, capsys):
    (tmp_path / "l24-cv-seed1.json").write_text(json.dumps({"rmse": {}}))
    assert run_all([("l24-cv", 1)], tmp_path, workers=1) == {("l24-cv", 1): {"seed": 1, "duration": None}}
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is stale (written before runs were keyed" in err


def test_a_broken_scenario_fails_before_anything_runs(tmp_path, runs):
    from swarmtrack.scenarios import ScenarioError

    with pytest.raises(ScenarioError):
        run_all([("l24-cv", 1), ("no-such-scenario", 1)], tmp_path, workers=1)
    assert runs == []


def test_worker_processes_run_the_resolved_scenario(tmp_path, monkeypatch):
    def shortened(name, overrides=(), seed=None):
        return load_scenario(name, ["duration=3", *overrides], seed)

    monkeypatch.setattr(rep, "load_scenario", shortened)
    parallel = run_all([("l24-cv", 1), ("l24-cv", 2)], tmp_path, workers=2)
    assert parallel[("l24-cv", 2)] == rep.run_one(load_scenario("l24-cv", ["duration=3"], 2))


# --- the registry drives reproduce() ---

def test_a_registered_paper_is_reproduced_by_the_generic_machinery(tmp_path, runs, monkeypatch):
    def analyse(by_scenario):
        seeds = [r["seed"] for r in by_scenario["l24-cv"]]
        return [Claim("zz-seeds", "Every seed ran", [1, 2], seeds, seeds == [1, 2])], "| table |", {"n": len(seeds)}

    def figures(out, overrides=()):
        raise AssertionError("figures=False")

    monkeypatch.setitem(PAPERS, "zz99", Paper("zz99", "A test paper", ("l24-cv",), analyse, figures))
    report = reproduce("zz99", tmp_path, runs=2, workers=1, quiet=True, figures=False)
    assert report == json.loads((tmp_path / "reproduction.json").read_text())
    assert report["claims"] == [{"id": "zz-seeds", "text": "Every seed ran", "paper": [1, 2], "project": [1, 2],
                                 "holds": True}]
    assert report["numbers"] == {"n": 2} and report["diverged"] == {"l24-cv": 0}
    md = (tmp_path / "reproduction.md").read_text()
    assert md.startswith("# Reproduction of ZZ99 (2 seeds per experiment)") and "**holds** `zz-seeds`" in md


def test_overrides_reach_every_run_and_the_report(tmp_path, monkeypatch):
    seen = []

    def fake_run_one(scenario):
        seen.append((scenario.name, scenario.duration, scenario.sensor.latency))
        return {"x": 1.0}

    monkeypatch.setattr(rep, "run_one", fake_run_one)
    monkeypatch.setattr(rep, "run_batch", lambda scenarios: [fake_run_one(s) for s in scenarios])
    results = rep.run_all([("l24-cv", 1), ("l24-ct", 2)], tmp_path, workers=1,
                                       overrides=["duration=3", "sensor.latency=0"])
    assert sorted(seen) == [("l24-ct", 3.0, 0.0), ("l24-cv", 3.0, 0.0)] and len(results) == 2


@pytest.mark.slow
def test_ctrl_c_stops_a_parallel_reproduction_at_once_and_keeps_finished_runs(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "rep"
    proc = subprocess.Popen([sys.executable, "-m", "swarmtrack.cli", "reproduce", "l24", "--runs", "3", "--workers",
                             "2", "--out", str(out), "--no-figures", "--set", "duration=20"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.time() + 120
    while time.time() < deadline and not list((out / "runs").glob("*.json")):
        time.sleep(0.1)  # until the first run is cached
    assert list((out / "runs").glob("*.json")), "no run finished in time"
    os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C at a terminal reaches the whole process group
    t0 = time.time()
    _, err = proc.communicate(timeout=30)
    print(f"reproduce stopped {time.time() - t0:.2f} s after Ctrl-C")
    # the goal is 2 s on a quiet machine; the bound only says it did not wait for the remaining runs (a loaded
    # machine moves the figure, not the property: kept < 9 below)
    assert time.time() - t0 < 20
    assert proc.returncode == 130 and "finished runs are kept" in err and "Traceback" not in err
    kept = list((out / "runs").glob("*.json"))
    assert kept and len(kept) < 9
    assert not (out / "reproduction.json").exists() and not (out / "reproduction.md").exists()
    assert not list(out.glob(".*partial"))
