"""IB21 set-membership runs: the summary's ``set_membership`` section, its time series and its warnings, checked
against hand computations on the recording's table and on edited recordings."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from swarmtrack.analysis import health, metrics
from swarmtrack.capabilities.set_membership import metrics as sm_metrics
from swarmtrack.sim.recorder import Chunk, Recording


@pytest.fixture
def recorded(ib21_run):
    return ib21_run


def _whole(rec: Recording, edit=None) -> Recording:
    """The recording as one chunk in memory; ``edit(probes, t)`` may change its probes first."""
    parts = list(rec.chunks())
    probes = {k: np.concatenate([c.probes[k] for c in parts]) for k in parts[0].probes}
    t = np.concatenate([c.t for c in parts])
    if edit is not None:
        edit(probes, t)
    chunk = Chunk(0, t, np.concatenate([c.truth for c in parts]), np.concatenate([c.phase for c in parts]), probes)
    return Recording(rec.meta, [chunk])


def _rechunked(rec: Recording, size: int) -> Recording:
    """The same steps in chunks of ``size`` (in memory)."""
    (whole,) = _whole(rec)._chunks
    chunks = [Chunk(k, whole.t[k:k + size], whole.truth[k:k + size], whole.phase[k:k + size],
                    {n: v[k:k + size] for n, v in whole.probes.items()}) for k in range(0, len(whole.t), size)]
    return Recording(rec.meta, chunks)


@pytest.mark.slow
def test_set_membership_section_equals_a_hand_computation_on_the_uav_table(recorded):
    sm = metrics.summary(recorded)["set_membership"]
    df = recorded.frame("uavs")
    by_step = df.groupby("step")
    bar = by_step["phi"].mean()  # Φ̄ = mean over UAVs (eq. 11)
    last = df[df.step == df.step.max()]
    assert sm["phi_bar_final"] == pytest.approx(bar.iloc[-1], rel=1e-12)
    assert sm["phi_bar_mean"] == pytest.approx(bar.mean(), rel=1e-12)
    assert sm["area"] == 400.0 * 400.0
    assert sm["phi_bar_final_fraction"] == pytest.approx(bar.iloc[-1] / 160000.0, rel=1e-12)
    for part, col in sm_metrics.PHI_PARTS.items():
        assert sm["parts_final"][part] == pytest.approx(last[col].mean(), rel=1e-12, abs=1e-9)
    assert sm["identified_final"] == pytest.approx(last["n_identified"].mean())
    violations = by_step["guarantee_violations"].sum()
    assert sm["guarantee_violations"] == violations.sum() == 0  # a matched bound: the guarantee holds
    assert sm["max_violations_per_step"] == violations.max()
    assert sm["empty_set_alarms"] == int((df.groupby("uav")["alarm_all_empty"].max() > 0).sum())
    assert sm["alarms_unexplained"] == last["alarm_unexplained"].sum()
    cleared = bar.index[by_step["phi_unexplored"].mean().to_numpy() == 0]
    assert sm["time_unexplored_cleared"] is None and not len(cleared)  # 4 s cannot clear 400 m × 400 m


def test_plans_are_found_from_the_period_and_their_solve_times_summed_over_the_fleet(recorded):
    df = recorded.frame("uavs")
    wide = df.pivot(index="step", columns="uav", values="solve_time")
    changed = (wide.diff().fillna(wide) != 0).all(axis=1).to_numpy()  # a new plan: every UAV's time changes
    t = df.groupby("step")["t"].first().to_numpy()
    plan = sm_metrics.plan_steps(t, recorded.dt, 0.5)
    assert plan.sum() == 8 and np.array_equal(plan, changed)  # plans at 0, 0.5 … 3.5 s, seen one step later
    fleet = wide.to_numpy()[plan].sum(axis=1)
    got = metrics.summary(recorded)["set_membership"]["solve_time"]
    assert got["plans"] == 8
    assert got["fleet_mean"] == pytest.approx(fleet.mean(), rel=1e-12)
    assert got["fleet_max"] == pytest.approx(fleet.max(), rel=1e-12)
    assert got["per_uav_mean"] == pytest.approx(wide.to_numpy()[plan].mean(axis=0).tolist(), rel=1e-12)
    assert got["per_uav_max"] == pytest.approx(wide.to_numpy()[plan].max(axis=0).tolist(), rel=1e-12)


def test_plan_steps_respect_a_start_and_periods_longer_than_a_step():
    t = np.arange(40) * 0.05
    assert np.flatnonzero(sm_metrics.plan_steps(t, 0.05, 0.5)).tolist() == [1, 11, 21, 31]
    assert np.flatnonzero(sm_metrics.plan_steps(t, 0.05, 0.5, start=1.0)).tolist() == [21, 31]
    assert np.flatnonzero(sm_metrics.plan_steps(np.arange(6) * 0.5, 0.5, 0.5)).tolist() == [1, 2, 3, 4, 5]


def test_uncertainty_series_are_per_bin_means_of_the_mean_over_uavs(recorded):
    s = metrics.summary(recorded)["series"]
    assert {"phi_bar", "phi_unexplored", "phi_unidentified", "phi_identified", "solve_time"} <= set(s)
    assert "nees" not in s  # no Gaussian estimate
    df = recorded.frame("uavs")
    per_step = df.groupby("step").agg(t=("t", "first"), phi=("phi", "mean"), u=("phi_unexplored", "mean"))
    b = np.floor(per_step["t"] + 1e-9).astype(int)
    assert s["phi_bar"] == pytest.approx(per_step.groupby(b)["phi"].mean().tolist(), rel=1e-12)
    assert s["phi_unexplored"] == pytest.approx(per_step.groupby(b)["u"].mean().tolist(), rel=1e-12)
    assert s["phi_bar"][-1] < s["phi_bar"][0]  # the search shrinks the uncertainty


def _assert_close(a, b, where=""):
    """Equal structure, numbers equal up to rounding (sums in another order)."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            _assert_close(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b, strict=True)):
            _assert_close(x, y, f"{where}[{k}]")
    else:
        assert b == (a if a is None else pytest.approx(a, rel=1e-12)), where


def test_the_summary_does_not_depend_on_the_chunking(recorded):
    chunked = metrics.summary(recorded)  # 7-step chunks on disk
    for rec in (_whole(recorded), _rechunked(recorded, 3), _rechunked(recorded, 1)):
        other = metrics.summary(rec)
        for part in ("series", "set_membership", "warnings"):
            _assert_close(chunked[part], other[part], part)


def _violated(probes, t):
    probes["guarantee_violations"][30, 2] = 2  # UAV 3 missed two targets at step 30
    probes["guarantee_violations"][50, [0, 4]] = 1
    probes["alarm_all_empty"][40:, 1] += np.arange(1, 41)  # UAV 2 lost every set at step 40, and stays so


def test_a_violation_and_an_all_empty_alarm_are_counted_and_warned(recorded):
    rec = _whole(recorded, _violated)
    out = metrics.summary(rec)
    sm = out["set_membership"]
    assert sm["guarantee_violations"] == 4 and sm["max_violations_per_step"] == 2
    assert sm["first_violation_t"] == pytest.approx(1.5)
    assert sm["empty_set_alarms"] == 1 and sm["empty_set_alarm_t"][1] == pytest.approx(2.0)
    assert sm["all_empty_events"] == 40
    kinds = {w["kind"]: w for w in out["warnings"]}
    assert set(kinds) == {"guarantee_violated", "all_sets_empty"}
    assert kinds["guarantee_violated"]["message"].startswith("guarantee violated: 4 checks found a true target")
    assert kinds["guarantee_violated"]["t_start"] == pytest.approx(1.5)
    assert kinds["guarantee_violated"]["t_end"] == pytest.approx(2.5)
    empty = kinds["all_sets_empty"]
    assert empty["uav"] == 2 and "UAV 2 became empty at t = 2.00 s" in empty["message"]
    assert "noise bound may be too small" in empty["message"]
    assert health.check(rec) == out["warnings"]  # the same warnings without the metrics
    assert health.check(recorded) == []


def test_unexplained_detections_warn_only_without_decoys(recorded):
    def unexplained(probes, t):
        probes["alarm_unexplained"][60:, 0] = 3

    rec = _whole(recorded, unexplained)
    assert metrics.summary(rec)["set_membership"]["alarms_unexplained"] == 3
    assert health.check(rec) == []  # with decoys: a decoy seen again after it was identified as one
    meta = {**rec.meta, "groups": {**rec.meta["groups"], "decoys": [6, 6]}}  # the same run said to have none
    warnings = health.check(Recording(meta, rec._chunks))
    assert [w["kind"] for w in warnings] == ["unexplained_without_decoys"]


def test_a_run_without_plans_or_monitor_reports_none(recorded):
    meta = {**recorded.meta, "probes": {k: v for k, v in recorded.meta["probes"].items()
                                        if k not in ("solve_time", "guarantee_violations")}}
    (whole,) = _whole(recorded)._chunks
    chunk = dataclasses.replace(whole, probes={k: whole.probes[k] for k in meta["probes"]})
    out = metrics.summary(Recording(meta, [chunk]))
    assert out["set_membership"]["solve_time"] is None and out["set_membership"]["guarantee_violations"] is None
    assert "solve_time" not in out["series"] and "phi_bar" in out["series"]
