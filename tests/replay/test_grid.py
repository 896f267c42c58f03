"""Imperfect time-stamped logs (issue 35): a CSV grouped by kind replays as the sorted file, truth for part of a
flight or at a low rate gives truth wherever two samples bracket a step (NaN beyond) and its coverage, a gap in
the logs is refused before any step, the number of steps is known before the first, and every skip cause says what
to do about it."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import swarmtrack
from swarmtrack.cli import main
from swarmtrack.replay import grid, timestamped
from swarmtrack.replay.engine import replay, replay_logs
from swarmtrack.replay.mapping import ReplayMap
from swarmtrack.replay.steps import LogError
from swarmtrack.sim.engine import simulate


def _csv_helpers():
    """``flight`` and ``write_csv`` of tests/replay/test_csv_log.py (a test file, not a package)."""
    path = Path(__file__).resolve().parent / "test_csv_log.py"
    spec = importlib.util.spec_from_file_location("_csv_log_helpers", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.flight, module.write_csv


flight, write_csv = _csv_helpers()

SCENARIO = ["duration=12", "sensor.latency=0"]


@pytest.fixture(scope="module")
def flown():
    """A 12 s l24-ct flight (seed 3) without sensor latency and its logged rows (10 % dropped, 5 % reordered)."""
    scenario = swarmtrack.load_scenario("l24-ct", SCENARIO, seed=3)
    rec = simulate(scenario, inputs=True)
    return scenario, rec, flight(rec)


def _arrays(rec) -> dict:
    chunks = list(rec.chunks())
    return {"t": np.concatenate([c.t for c in chunks]), "truth": np.concatenate([c.truth for c in chunks]),
            **{k: np.concatenate([c.probes[k] for c in chunks]) for k in chunks[0].probes}}


def _target(rec) -> np.ndarray:
    return np.concatenate([c.truth[:, rec.tracked] for c in rec.chunks()])


def test_a_csv_grouped_by_kind_gives_the_sorted_csvs_recording(tmp_path, flown):
    scenario, _, rows = flown
    order = {"truth": 0, "navigation": 1, "detection": 2}
    grouped = sorted(rows, key=lambda r: order[r["kind"]])  # each block stays sorted, the blocks one after another
    assert grouped != rows
    a_counts, b_counts = {}, {}
    a = replay(scenario, timestamped.steps([write_csv(tmp_path / "sorted.csv", rows)], scenario, None, a_counts),
               phases=False)
    b = replay(scenario, timestamped.steps([write_csv(tmp_path / "grouped.csv", grouped)], scenario, None, b_counts),
               phases=False)
    assert a_counts == b_counts and "came later than the replay window" not in b_counts
    want, got = _arrays(a), _arrays(b)
    assert want.keys() == got.keys()
    for name in want:
        assert np.array_equal(want[name], got[name], equal_nan=True), name


def test_truth_is_interpolated_between_samples_within_truth_gap_and_absent_beyond(tmp_path, flown):
    scenario, rec, rows = flown
    dt = 1.0 / scenario.rates.estimation
    # truth every 1.5 s (longer than the 1 s window: the steps between wait for the next sample), only from 2 to 8 s,
    # and none between 5 and 7.9 s (a gap longer than truth_gap)
    keep = [r for r in rows if r["kind"] != "truth"]
    stamps = [t for t in np.arange(2.0, 8.01, 1.5) if not 5.0 < t < 7.9]  # 2, 3.5, 5, 8
    by_t = {round(r["t"] / dt): r for r in flight(rec, drop=0.0, reorder=0.0) if r["kind"] == "truth"}
    truth = [{**by_t[round(t / dt)], "t": t} for t in stamps]
    log = write_csv(tmp_path / "part.csv", sorted(keep + truth, key=lambda r: r["t"]))
    got = replay_logs([log], scenario)
    t, target = np.concatenate([c.t for c in got.chunks()]), _target(got)
    known = np.isfinite(target).all(axis=1)
    # the log's t = 0 is its first stamp, within the first step of the flight's
    t0 = min(r["t"] for r in keep + truth)
    # known from the 2 s sample to the 5 s one; the lone 8 s sample (no other within truth_gap) gives no velocity
    inside = (t + t0 >= 2.0 - 1e-9) & (t + t0 <= 5.0 + 1e-9)
    assert np.array_equal(known, inside), (t[known != inside] + t0, t0)
    xs = [r["x"] for r in truth]
    assert np.allclose(target[known, 0], np.interp(t[known] + t0, stamps, xs))
    between = known & (np.abs(t + t0 - 3.5) > 1e-6)  # the velocity: the two samples' finite difference
    interval = np.minimum((t[between] + t0 - 2.0) // 1.5, 1).astype(int)
    assert np.allclose(target[between, 2], np.diff(xs)[interval] / 1.5)
    assert grid.TRUTH_GAP == 2.0
    cover = got.meta["replay"]["truth"]
    assert cover == {"steps": int(known.sum()), "of_steps": len(t), "seconds": known.sum() * dt,
                     "fraction": known.sum() / len(t)}
    assert 0.2 < cover["fraction"] < 0.3


def test_a_gap_longer_than_max_gap_is_refused_before_any_step_naming_its_times(tmp_path, flown):
    scenario, _, rows = flown
    later = [{**r, "t": r["t"] + 10.0} if r["t"] > 6 else r for r in rows]  # nothing logged for 10 s after 6 s
    log = write_csv(tmp_path / "gap.csv", later)
    uavs = {i: {"navigation": "unused"} for i in (1, 2, 3)}
    with pytest.raises(LogError, match=r"gap.csv: no message from 6\.\d+ s \(.*\) to 16\.\d+ s .*a gap of 10\.\d+ s, "
                                       r"longer than the replay's max_gap of 5 s"):
        timestamped.steps([log], scenario, ReplayMap.checked({"uavs": uavs, "max_gap": 5}, scenario), {})
    # the default bound (60 s) steps through it; the number of steps is known before the first
    steps = timestamped.steps([log], scenario, None, {})
    seen = []
    got = replay(scenario, steps, phases=False, planned=seen.append)
    assert seen == [steps.n_steps] == [got.meta["n_steps"]]
    span = max(r["t"] for r in later) - min(r["t"] for r in later)
    assert got.meta["n_steps"] == pytest.approx(span * scenario.rates.estimation, abs=1)


def test_the_number_of_steps_is_planned_before_the_replay_and_a_1e9_stamp_never_stepped(tmp_path, flown):
    scenario, _, rows = flown
    log = write_csv(tmp_path / "stamp.csv", [*rows, {**rows[-1], "t": 1e9}])
    out = tmp_path / "never"
    res = CliRunner().invoke(main, ["replay", str(log), "--scenario", "l24-ct", "--out", str(out)])
    assert res.exit_code == 2 and "Traceback" not in res.output and not out.exists()
    assert f"{log}: no message from" in res.output and "to 1000000000.000000 s" in res.output
    assert not list(tmp_path.glob(".never*"))  # no staging folder left


def test_every_skip_cause_says_what_to_do_and_every_reader_counts_through_it(flown):
    for cause, remedy in grid.SKIPS.items():
        assert remedy and re.search(r"raise|fix|sort|align|log |map|copy|drop|nothing to do|name", remedy), cause
    assert grid.remedy("came later than the replay window") == grid.SKIPS["came later than the replay window"]
    assert "the map's window" in grid.remedy("came later than the replay window")
    assert "rates.estimation" in grid.remedy("a second detection of the target by one UAV in one estimation step")
    assert "uavs.N.log" in grid.remedy("navigation rows in x.csv of a UAV whose navigation is its ULog's")
    with pytest.raises(KeyError, match="no remedy"):
        grid.skip({}, "a cause nobody documented")
    folder = Path(grid.__file__).parent
    for source in folder.glob("*.py"):  # counts are kept by grid.skip alone, so each cause has its remedy
        text = source.read_text()
        assert source.name == "grid.py" or "counts[" not in text, source


def test_a_replays_warnings_carry_the_remedy(tmp_path, flown):
    scenario, _, rows = flown
    doubled = rows + [{**r, "t": r["t"] + 0.01} for r in rows if r["kind"] == "detection"][:5]
    log = write_csv(tmp_path / "doubled.csv", doubled)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["replay", str(log), "--scenario", "l24-ct", *sum((["--set", s] for s in SCENARIO),
                                                                                   []), "--no-plots", "--out",
                                    str(out)])
    assert res.exit_code == 0, res.output
    line = next(x for x in res.output.splitlines() if "a second detection" in x)
    assert "raise the scenario's rates.estimation" in line
