"""A CSV log of a simulated flight (one row per message, uneven rates, rows out of order) replays to the
simulator's accuracy with no map; bad CSVs are refused naming the file and line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import swarmtrack
from swarmtrack.analysis.metrics import summary
from swarmtrack.cli import main
from swarmtrack.replay import timestamped
from swarmtrack.replay.engine import replay
from swarmtrack.replay.steps import LogError
from swarmtrack.sim.engine import simulate

HEADER = ("t", "uav", "kind", "x", "y", "vx", "vy", "range", "bearing")


def flight(rec, drop: float = 0.1, reorder: float = 0.05, seed: int = 0, polar: bool = False) -> list[dict]:
    """The rows of a simulated run as a flight would log them, by log time: navigation (with velocity), detections
    (relative ``x``, ``y``, or ``range``, ``bearing`` when ``polar``, stamped when taken) and the target's truth; a
    fraction ``drop`` never logged and ``reorder`` logged 50-300 ms late, after later-stamped rows."""
    rng = np.random.default_rng(seed)
    rows = []

    def row(**cells):
        if rng.random() < drop:
            return
        late = rng.uniform(0.05, 0.3) if rng.random() < reorder else rng.uniform(0.001, 0.02)
        rows.append((cells["t"] + late, cells))

    truth = {c.k0 + j: c.truth[j] for c in rec.chunks() for j in range(len(c.t))}
    for k, t, nav, det in rec.inputs():
        for i, (x, y, vx, vy) in enumerate(nav):
            row(t=t, uav=i + 1, kind="navigation", x=x, y=y, vx=vx, vy=vy)
        taken = t if det.taken is None else det.taken
        if taken >= 0:
            for owner, (r, b) in zip(det.owner, det.z, strict=True):
                cells = {"range": r, "bearing": b} if polar else {"x": r * np.cos(b), "y": r * np.sin(b)}
                row(t=taken, uav=int(owner) + 1, kind="detection", **cells)
        x, y = truth[k][rec.tracked, :2]
        row(t=t, uav="", kind="truth", x=x, y=y)
    rows.sort(key=lambda r: r[0])
    return [cells for _, cells in rows]


def write_csv(path: Path, rows: list[dict], header=HEADER) -> Path:
    def cell(v):
        return "" if v is None or v == "" else (str(v) if isinstance(v, (int, str)) else repr(float(v)))

    lines = [",".join(header)] + [",".join(cell(r.get(c)) for c in header) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def _rmse(rec) -> dict:
    return summary(rec)["rmse"]["total"]


@pytest.fixture(scope="module")
def flown():
    """A 30 s l24-ct flight (seed 3) without sensor latency, as tests/replay/test_rosbag.py flies it."""
    scenario = swarmtrack.load_scenario("l24-ct", ["duration=30", "sensor.latency=0"], seed=3)
    return scenario, simulate(scenario, inputs=True)


def test_a_csv_of_a_flight_replays_to_the_simulators_accuracy_with_no_map(tmp_path, flown):
    scenario, rec = flown
    log = write_csv(tmp_path / "flight.csv", flight(rec))
    out = tmp_path / "replayed"
    res = CliRunner().invoke(main, ["replay", str(log), "--scenario", "l24-ct", "--set", "duration=30", "--set",
                                    "sensor.latency=0", "--seed", "3", "--no-plots", "--out", str(out)])
    assert res.exit_code == 0, res.output
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["replay"]["format"] == "csv" and metrics["replay"]["map"] is None
    want, got = _rmse(rec), metrics["rmse"]["total"]
    for axis in ("x", "y"):
        assert abs(got[axis] - want[axis]) <= 0.10 * want[axis], (axis, got, want)
    assert sum(metrics["replay"]["skipped"].values()) <= 5


@pytest.mark.slow
def test_range_and_bearing_detections_and_unusable_rows_are_skipped_and_counted(tmp_path, flown):
    scenario, rec = flown
    rows = flight(rec, polar=True)
    nav = next(j for j, r in enumerate(rows) if r["kind"] == "navigation" and r["uav"] == 2 and r["t"] > 5)
    rows[nav] = {**rows[nav], "x": None}  # an empty cell
    det = next(j for j, r in enumerate(rows) if r["kind"] == "detection" and r["t"] > 8)
    rows[det] = {**rows[det], "range": float("nan")}
    log = write_csv(tmp_path / "flight.csv", rows)
    counts = {}
    again = replay(scenario, timestamped.steps([log], scenario, None, counts), phases=False)
    assert counts.pop(f"NaN or infinite value in a message on navigation of UAV 2 in {log}") == 1
    assert counts.pop(f"NaN or infinite value in a message on detections of UAV {rows[det]['uav']} in {log}") == 1
    assert set(counts) <= {"detection with no navigation of its UAV at its time"}
    want, got = _rmse(rec), _rmse(again)
    for axis in ("x", "y"):
        assert abs(got[axis] - want[axis]) <= 0.10 * want[axis], (axis, got, want)


def _refused(tmp_path, text: str, name: str = "bad.csv") -> str:
    log = tmp_path / name
    log.write_text(text)
    out = tmp_path / "never"
    res = CliRunner().invoke(main, ["replay", str(log), "--scenario", "l24-ct", "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output and not out.exists()
    assert str(log) in res.output
    return res.output


def test_bad_csvs_are_refused_with_one_message_naming_the_file_and_line(tmp_path, flown):
    scenario, rec = flown
    good = write_csv(tmp_path / "good.csv", flight(rec, drop=0.0, reorder=0.0)[:3000]).read_text().splitlines()
    body = "\n".join(good[1:40]) + "\n"
    assert "line 1: no column 'kind'" in _refused(tmp_path, "t,uav,x,y\n0.0,1,1.0,2.0\n")
    assert "line 1: unknown column 'bering'" in _refused(tmp_path, "t,uav,kind,range,bering\n")
    assert "line 1: columns vx and vy come together" in _refused(tmp_path, "t,uav,kind,x,y,vx\n")
    assert "empty" in _refused(tmp_path, "")
    assert "line 4: kind 'radar' is not one of" in _refused(tmp_path, "\n".join(good[:3]) + "\n0.1,1,radar,1,2,,,,\n")
    assert "line 3: uav 4 is not in the scenario" in _refused(tmp_path, good[0] + "\n" + good[1] + "\n"
                                                              "0.0,4,navigation,1,2,,,,\n")
    assert "line 2: column uav: 'one'" in _refused(tmp_path, good[0] + "\n0.0,one,navigation,1,2,,,,\n")
    assert "line 2: a truth row leaves uav empty" in _refused(tmp_path, good[0] + "\n0.0,1,truth,1,2,,,,\n")
    assert "line 2: column x: 'abc' is not a number" in _refused(tmp_path, good[0] + "\n0.0,1,navigation,abc,2,,,,\n")
    msg = _refused(tmp_path, "t,uav,kind\n0.0,1,detection\n")
    assert "line 2: a detection row needs columns x, y or range, bearing" in msg
    # a file cut inside its last row
    assert "line 41: 4 field(s) where the header has 9" in _refused(tmp_path, good[0] + "\n" + body + good[40][:20])
    # a gap longer than max_gap: the one row stamped 1e9 s is refused before any step, naming its times and file
    msg = _refused(tmp_path, good[0] + "\n" + body + "1e9" + good[40][good[40].index(","):] + "\n")
    assert "a gap of 1e+09 s, longer than the replay's max_gap of 60 s" in msg and "1000000000.000000 s" in msg
    res = CliRunner().invoke(main, ["replay", str(tmp_path / "gone.csv"), "--scenario", "l24-ct", "--out",
                                    str(tmp_path / "never")])
    assert res.exit_code == 2 and "gone.csv: no such file or folder" in res.output
    with pytest.raises(LogError, match="gone.csv: no such file or folder"):
        timestamped.steps([tmp_path / "gone.csv"], scenario, None, {})


@pytest.mark.slow
def test_a_csv_with_truth_for_part_of_the_flight_gives_errors_over_that_part(tmp_path, flown):
    """Truth for the first 10 of 30 s, then none: the errors are over those steps (the issue's 889 s bag with 120 s
    of truth gave null RMSE and 'lost the target' to the end), its coverage stated, no lost target."""
    scenario, rec = flown
    rows = [r for r in flight(rec, drop=0.0, reorder=0.0) if r["kind"] != "truth" or r["t"] < 10.0]
    log = write_csv(tmp_path / "partial.csv", rows)
    out = tmp_path / "replayed"
    res = CliRunner().invoke(main, ["replay", str(log), "--scenario", "l24-ct", "--set", "duration=30", "--set",
                                    "sensor.latency=0", "--seed", "3", "--no-plots", "--out", str(out)])
    assert res.exit_code == 0, res.output
    metrics = json.loads((out / "metrics.json").read_text())
    assert all(np.isfinite(v) and v < 0.5 for v in metrics["rmse"]["total"].values()), metrics["rmse"]
    assert np.isfinite(metrics["nees"]) and np.isfinite(metrics["mean_error"]["all"])
    assert metrics["coverage"]["truth_fraction"] == pytest.approx(1 / 3, abs=0.02)
    kinds = [w.get("kind") for w in metrics["warnings"]]
    assert "lost_target" not in kinds and "partial_truth" in kinds
