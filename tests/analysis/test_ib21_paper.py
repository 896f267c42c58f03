"""The IB21 paper: each claim holds on favourable synthetic metrics and flips with its numbers."""

import numpy as np
import pytest

from swarmtrack.analysis.papers import PAPERS, ib21
from swarmtrack.scenarios import builtin_names

# per experiment: (runs that clear X̄ out of 3, time-mean Φ̄, violations per run, alarm per run, fleet solve time)
GOOD = {"ib21-fleet-2": (0, 60000), "ib21-fleet-3": (0, 40000), "ib21-fleet-4": (1, 20000), "ib21-fleet-5": (3, 9000),
        "ib21-fleet-6": (3, 5000), "ib21-speed-1.6": (2, 9000), "ib21-speed-1.8": (0, 15000),
        "ib21-decoys-0": (2, 15000), "ib21-decoys-6": (0, 30000), "ib21-noise-5": (3, 8000),
        "ib21-noise-20": (3, 12000), "ib21-noise-over": (3, 16000), "ib21-noise-under": (3, 7000),
        "ib21-comm-50": (0, 20000), "ib21-comm-100": (1, 10000), "ib21-comm-600": (3, 4000),
        "ib21-compute-1": (3, 8000), "ib21-compute-2": (3, 7000), "ib21-compute-3": (3, 6000)}
PARTS = {"ib21-decoys-0": (5000, 2000, 1000), "ib21-fleet-4": (5000, 6000, 1500), "ib21-decoys-6": (5000, 9000, 2000)}
#: the fleet's control time per plan (s): 1, 3 and 5 times one UAV's, as the paper's Fig. 11 right
SOLVE = {"ib21-compute-1": 0.002, "ib21-compute-2": 0.006, "ib21-compute-3": 0.010}
BINS, BIN_S = 31, 10.0  # 300 s series


def run(name, k, change):
    ok, phi = change.get(name, GOOD[name])
    n_uavs = ib21.FLEET.get(name, ib21.COMPUTE.get(name, 6))
    unexplored, unidentified, identified = PARTS.get(name, (phi / 2, phi / 4, phi / 8))
    under = name == "ib21-noise-under"
    spread = 0.5 if name == "ib21-fleet-4" else 0.1  # Fig. 8: the runs of 4 UAVs differ most (10,000 m² std)
    fleet = SOLVE.get(name, 0.003 * n_uavs)
    return {"set_membership": {"time_unexplored_cleared": 100.0 if k < ok else None,
                               "guarantee_violations": 2 if under else 0, "empty_set_alarms": 1 if under else 0,
                               "solve_time": {"fleet_mean": fleet, "per_uav_mean": [fleet / n_uavs] * n_uavs}},
            "series": {"bin_s": BIN_S, "phi_bar": [phi * (1 + spread * (k - 1))] * BINS,
                       "phi_unexplored": [unexplored] * BINS, "phi_unidentified": [unidentified] * BINS,
                       "phi_identified": [identified] * BINS, "solve_time": [fleet] * BINS}}


def study(change=None):
    return {e: [run(e, k, change or {}) for k in range(3)] for e in ib21.EXPERIMENTS}


def verdicts_of(data):
    claims, md, _ = ib21.analyse(data)
    assert "X̄ cleared" in md
    return {c.id: c.holds for c in claims}


def verdicts(change=None):
    return verdicts_of(study(change))


def broken(data):
    return {k for k, v in verdicts_of(data).items() if not v}


def test_every_claim_holds_on_favourable_numbers():
    assert all(verdicts().values()), verdicts()


@pytest.mark.parametrize(("change", "broken"), [
    ({"ib21-fleet-3": (1, 40000)}, "ib21-fig8-three-or-fewer"),
    ({"ib21-fleet-4": (3, 20000)}, "ib21-fig8-four-some"),
    ({"ib21-fleet-5": (2, 9000)}, "ib21-fig8-five-or-more"),
    ({"ib21-speed-1.8": (1, 15000)}, "ib21-fig9-speed"),
    ({"ib21-decoys-6": (0, 14000)}, "ib21-fig9-decoys"),
    ({"ib21-noise-20": (3, 17000)}, "ib21-fig10-over-slowest"),
    ({"ib21-comm-100": (1, 30000)}, "ib21-fig11-range"),
])
def test_each_claim_flips_with_its_numbers(change, broken):
    got = verdicts(change)
    assert {k for k, v in got.items() if not v} == {broken}


def test_a_violation_with_a_matched_bound_breaks_the_guarantee_claim(monkeypatch):
    data = {e: [run(e, k, {}) for k in range(3)] for e in ib21.EXPERIMENTS}
    data["ib21-fleet-6"][1]["set_membership"]["guarantee_violations"] = 1
    claims, _, _ = ib21.analyse(data)
    assert not next(c for c in claims if c.id == "ib21-guarantee").holds


def test_registered_with_builtin_experiments():
    assert set(PAPERS["ib21"].experiments) <= set(builtin_names())


# --- the four statements of Sec. 6 on the curves (issue 27) ---

def test_the_variance_claim_fails_when_another_fleet_size_spreads_most():
    data = study()
    for k, r in enumerate(data["ib21-fleet-3"]):
        r["series"]["phi_bar"] = [40000 * (1 + 0.5 * (k - 1))] * BINS
    assert broken(data) == {"ib21-fig8-variance-four"}
    claims, _, numbers = ib21.analyse(data)
    assert numbers["phi_bar_spread"][3]["band_std_time_mean"] > numbers["phi_bar_spread"][4]["band_std_time_mean"]
    assert next(c for c in claims if c.id == "ib21-fig8-variance-four").project["widest for"] == 3


def test_the_initial_growth_claim_reads_only_the_first_tenth_of_the_run():
    data = study()
    for r in data["ib21-fleet-6"]:  # φ(X) above φ(Xᵁ) after the first tenth only: still holds
        r["series"]["phi_identified"] = [0.0] * 3 + [9e9] * (BINS - 3)
    assert broken(data) == set()
    for r in data["ib21-fleet-6"][:2]:  # above in the first tenth in 2 runs of 3: the mean curve decides
        r["series"]["phi_identified"] = [9e9] * BINS
    assert broken(data) == {"ib21-fig8-unidentified-first"}
    _, _, numbers = ib21.analyse(data)
    assert numbers["initial_growth"][6]["faster_runs"] == 1 and numbers["initial_growth"][6]["runs"] == 3


def test_the_fig10_claim_needs_the_20_m_curve_above_at_every_bin_after_100_s():
    data = study()
    for r in data["ib21-noise-20"]:  # below the ±5 m curve before 100 s only: still holds
        r["series"]["phi_bar"] = [1.0] * 10 + [12000.0] * (BINS - 10)
    assert broken(data) == set()
    for r in data["ib21-noise-20"]:  # one bin after 100 s below
        r["series"]["phi_bar"][20] = 1.0
    assert broken(data) == {"ib21-fig10-twenty-above-five"}
    late = ib21.analyse(data)[2]["noise_20_above_5_after_100s"]
    assert (late["bins_above"], late["bins"], late["seeds_above"], late["seeds"]) == (20, 21, 3, 3)


def test_the_constant_time_claim_fails_when_the_control_time_drifts():
    data = study()
    for r in data["ib21-compute-2"]:
        r["series"]["solve_time"] = np.linspace(0.003, 0.009, BINS).tolist()
    assert broken(data) == {"ib21-fig11-right-constant"}
    for r in data["ib21-compute-2"]:  # ±20 % around its mean: almost constant
        r["series"]["solve_time"] = [0.0048, 0.0072] * 15 + [0.006]
    assert broken(data) == set()


@pytest.mark.parametrize(("two", "three", "holds"), [(0.006, 0.010, True), (0.0055, 0.0115, True),
                                                     (0.004, 0.006, False), (0.0048, 0.010, False),
                                                     (0.006, 0.0079, False)])
def test_the_ratio_claim_holds_only_nearer_the_papers_ratios_than_linear_growth(two, three, holds):
    data = study()
    for name, t in (("ib21-compute-2", two), ("ib21-compute-3", three)):
        for r in data[name]:
            r["set_membership"]["solve_time"]["fleet_mean"] = t
    assert verdicts_of(data)["ib21-fig11-right-ratios"] is holds
    claim = next(c for c in ib21.analyse(data)[0] if c.id == "ib21-fig11-right-ratios")
    assert claim.project["ratio to 1 UAV"] == pytest.approx({2: two / 0.002, 3: three / 0.002})
    assert claim.project["seeds nearer the paper's ratio"][2] == ("3/3" if abs(two / 0.002 - 3) < 0.5 else "0/3")


def test_the_new_claims_are_left_out_without_their_experiments():
    data = study()
    claims, md, numbers = ib21.analyse({e: data[e] for e in ib21.FLEET})
    ids = {c.id for c in claims}
    assert {"ib21-fig8-variance-four", "ib21-fig8-unidentified-first"} <= ids
    assert not ids & {"ib21-fig10-twenty-above-five", "ib21-fig11-right-constant", "ib21-fig11-right-ratios"}
    assert "Fig. 11 right" not in md and numbers["compute"] == {}
    _, md, numbers = ib21.analyse({e: data[e] for e in ib21.COMPUTE})
    assert "Fig. 11 right" in md and numbers["compute"][3]["per_uav_time"] == pytest.approx([0.010 / 3] * 3)


def test_band_merges_finer_bins_and_leaves_out_diverged_runs():
    fine = {"series": {"bin_s": 1.0, "phi_bar": [1.0, 3.0, 5.0, None, 7.0]}}
    coarse = {"series": {"bin_s": 2.0, "phi_bar": [4.0, 4.0, 5.0]}}
    b = ib21.band([fine, coarse, {"diverged": "x"}], "phi_bar")
    assert b["bin_s"] == 2.0 and b["runs"] == 2
    assert b["mean"] == pytest.approx([3.0, 4.5, 6.0]) and b["n"].tolist() == [2, 2, 2]
    assert b["std"] == pytest.approx([1.0, 0.5, 1.0])
    assert ib21.band([{"series": {"bin_s": 1.0}}], "phi_bar") is None


@pytest.mark.slow
def test_the_fig11_right_scenarios_run_and_give_the_claims_their_numbers():
    """IB21 Fig. 11 right's set-up (1-3 UAVs, 3 targets, no decoys) runs; short raster runs (the claims' logic does
    not depend on the sets' kind) give every UAV's control time and the fleet's series."""
    from swarmtrack.analysis.runs import run_one
    from swarmtrack.scenarios import load_scenario

    data = {}
    for name, n in ib21.COMPUTE.items():
        scenario = load_scenario(name, ["duration=6", "estimator.sets=raster"])
        assert (scenario.swarm.n_uavs, scenario.targets.count, scenario.decoys.count) == (n, 3, 0)
        data[name] = [run_one(scenario)]
    claims, md, numbers = ib21.analyse(data)
    assert {c.id for c in claims} == {"ib21-fig11-right-constant", "ib21-fig11-right-ratios", "ib21-guarantee"}
    for n in (1, 2, 3):
        got = numbers["compute"][n]
        assert len(got["per_uav_time"]) == n and all(v > 0 for v in got["per_uav_time"])
        assert got["fleet_time_per_plan"] == pytest.approx(sum(got["per_uav_time"]))
        assert len(got["quarters"]) == 4
    assert numbers["compute"][3]["ratio_to_one"] == pytest.approx(numbers["compute"][3]["fleet_time_per_plan"]
                                                                  / numbers["compute"][1]["fleet_time_per_plan"])
    assert next(c for c in claims if c.id == "ib21-guarantee").holds
    assert "Fig. 11 right" in md
