import json

from swarmtrack.analysis.reproduce import reproduce


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


def test_l24_claims_that_the_project_reproduces_hold_on_one_seed():
    from swarmtrack.analysis.metrics import rmse_table
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim.engine import simulate

    rmse = {m: rmse_table(simulate(load_scenario(f"l24-{m}", seed=3))) for m in ("cv", "ct", "fs")}

    def vel(m, phase):
        return (rmse[m][phase]["vx"] + rmse[m][phase]["vy"]) / 2

    assert vel("ct", "circular") <= 0.5 * vel("cv", "circular")  # L24 Sec. 4: "about four times smaller"
    assert vel("cv", "linear") < min(vel("ct", "linear"), vel("fs", "linear"))  # CV best on the linear phase
