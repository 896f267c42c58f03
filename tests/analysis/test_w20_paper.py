"""The W20 Ch. 4 paper: claims on synthetic metrics (each can flip), the thesis tables, registry and figures."""

import pytest

from swarmtrack.analysis.papers import PAPERS, w20
from swarmtrack.scenarios import builtin_names

# mean error (m) of each experiment in every seed where all five claims hold
GOOD = {"w20-switching": 0.010, "w20-switching-cv": 0.012, "w20-switching-ca": 0.013, "w20-switching-ct": 0.011,
        "w20-evasive": 0.020, "w20-evasive-ml": 0.022, "w20-evasive-imm-thesis": 0.024, "w20-evasive-imm": 0.021,
        "w20-occlusion": 0.0300, "w20-occlusion-trace": 0.0302, "w20-occlusion-eigenvalue": 0.0304}
GOOD_OCCLUDED = {"w20-occlusion": 0.10, "w20-occlusion-trace": 0.12, "w20-occlusion-eigenvalue": 0.13}
# total RMSE [x, y, vx, vy] of the information-form IMM and the single-model L24 runs, the IMM best in each
GOOD_RMSE = {"l24-imm": [0.142, 0.184, 0.090, 0.130], "l24-cv": [0.143, 0.186, 0.224, 0.274],
             "l24-ct": [0.143, 0.185, 0.095, 0.134], "l24-fs": [0.143, 0.185, 0.244, 0.236]}


def metrics(all_: float, occluded: float | None = None, switches: float = 40.0) -> dict:
    return {"mean_error": {"all": all_, "occluded": occluded, "occluded_steps": 0 if occluded is None else 120},
            "model_use": {"share": [0.2, 0.3, 0.5], "switches": switches}}


def by_scenario(seeds: int = 3, change: dict | None = None, change_occluded: dict | None = None,
                change_rmse: dict | None = None) -> dict:
    """Every seed has the GOOD numbers (times 1 + 0.001 * seed), with ``change`` overriding some experiments."""
    values = {**GOOD, **(change or {})}
    occluded = {**GOOD_OCCLUDED, **(change_occluded or {})}
    out = {name: [metrics(values[name] * (1 + 0.001 * s), occluded.get(name)) for s in range(seeds)]
           for name in w20.EXPERIMENTS if name not in GOOD_RMSE}
    for name, rmse in {**GOOD_RMSE, **(change_rmse or {})}.items():
        out[name] = [{**metrics(0.1), "rmse": {"total": dict(zip(("x", "y", "vx", "vy"), rmse, strict=True))}}
                     for _ in range(seeds)]
    return out


def verdicts(data: dict) -> dict[str, bool]:
    claims, _, _ = w20.analyse(data)
    return {c.id: c.holds for c in claims}


IDS = ["w20-mixed-team-best", "w20-ttest-lowest", "w20-ml-beats-imm", "w20-last-model-best-occluded",
       "w20-policies-close-overall", "l24-imm-no-worse"]


def test_every_claim_holds_on_favourable_numbers():
    assert verdicts(by_scenario()) == dict.fromkeys(IDS, True)


@pytest.mark.parametrize(("change", "change_occluded", "broken"), [
    ({"w20-switching-ct": 0.009}, None, {"w20-mixed-team-best"}),
    ({"w20-switching-cv": 0.0099}, None, {"w20-mixed-team-best"}),
    ({"w20-evasive-ml": 0.019}, None, {"w20-ttest-lowest"}),
    ({"w20-evasive-imm-thesis": 0.019}, None, {"w20-ttest-lowest", "w20-ml-beats-imm"}),
    ({"w20-evasive-ml": 0.025}, None, {"w20-ml-beats-imm"}),
    (None, {"w20-occlusion-trace": 0.09}, {"w20-last-model-best-occluded"}),
    (None, {"w20-occlusion": 0.125}, {"w20-last-model-best-occluded"}),
    ({"w20-occlusion-eigenvalue": 0.0330}, None, {"w20-policies-close-overall"}),
    ({"w20-occlusion": 0.0280}, None, {"w20-policies-close-overall"}),
])
def test_each_claim_flips_with_its_numbers(change, change_occluded, broken):
    got = verdicts(by_scenario(change=change, change_occluded=change_occluded))
    assert {k for k, v in got.items() if not v} == broken


@pytest.mark.parametrize("component", [0, 1, 2, 3])
def test_the_information_imm_claim_fails_when_one_component_is_worse_than_a_single_model(component):
    worse = list(GOOD_RMSE["l24-imm"])
    worse[component] = GOOD_RMSE["l24-ct"][component] + 0.001
    got = verdicts(by_scenario(change_rmse={"l24-imm": worse}))
    assert {k for k, v in got.items() if not v} == {"l24-imm-no-worse"}


def test_the_standard_imm_extra_is_not_part_of_the_ttest_claim():
    assert verdicts(by_scenario(change={"w20-evasive-imm": 0.001}))["w20-ttest-lowest"]


def test_per_seed_fractions_pair_by_seed_and_skip_diverged_runs():
    data = by_scenario(seeds=4)
    data["w20-switching"][1] = metrics(0.5)  # seed 2: the mixed team is worse than the single-model teams
    data["w20-switching-cv"][3] = {"diverged": "filter diverged"}  # seed 4 is left out of the pairing
    claims, _, numbers = w20.analyse(data)
    assert numbers["seeds_holding"]["w20-mixed-team-best"] == {"holds": 2, "seeds": 3, "fraction": 2 / 3}
    mixed = next(c for c in claims if c.id == "w20-mixed-team-best")
    assert mixed.project["seeds where it holds"] == "2/3" and not mixed.holds  # the seed-2 outlier moves the mean
    assert numbers["mean_error"]["w20-switching-cv"]["n"] == 3
    assert numbers["seeds_holding"]["w20-ttest-lowest"] == {"holds": 4, "seeds": 4, "fraction": 1.0}


def test_the_tables_hold_the_thesis_numbers_beside_ours():
    claims, md, numbers = w20.analyse(by_scenario())
    for cm in ("18.5", "18.7", "18.4", "17.5", "19.4", "19.9", "18.3", "74.0", "76.5", "28.0", "28.1"):
        assert f"| {cm} |" in md
    assert "1.00 ± 0.00" in md  # the mixed team, 1.0 cm in every seed (to 0.1 %)
    assert f"Fig. 4.9 counts {w20.TRANSITIONS}" in md and "40.0 ± 0.0" in md
    assert "n/a (weighted output)" in md and "n/a (covariance fusion of all)" in md  # no output switches
    ttest = next(c for c in claims if c.id == "w20-ttest-lowest")
    assert ttest.paper == pytest.approx({"T-test": 18.3, "max-likelihood": 19.4, "IMM-DEKF (thesis, no mixing)": 19.9})
    assert ttest.project["T-test"] == pytest.approx(2.0, rel=0.01)  # cm
    assert numbers["mean_error_occluded"]["w20-occlusion"]["ci95"][0] < 0.1 < \
        numbers["mean_error_occluded"]["w20-occlusion"]["ci95"][1] + 1e-3


def test_a_claim_without_any_occlusion_does_not_hold():
    data = by_scenario(change_occluded=dict.fromkeys(GOOD_OCCLUDED))
    got = verdicts(data)
    assert got["w20-last-model-best-occluded"] is False and got["w20-policies-close-overall"]


def test_the_paper_is_registered_with_builtin_scenarios():
    paper = PAPERS["w20-estimation"]
    # 11 W20 experiments, the IMM and its 3 peers; the 11 with the ideal camera and the 6 error-budget variants
    assert paper is w20.PAPER and len(paper.experiments) == 15 + 11 + 6
    assert {paper.resolve(e)[0] for e in paper.experiments} <= set(builtin_names())


@pytest.mark.slow
def test_figures_of_a_shortened_run(tmp_path):
    paths = w20.figures(tmp_path, ["duration=4", "estimator.solo_steps=30"])  # seven 4 s runs
    assert len(paths) == 9 and all(p.is_file() and p.stat().st_size > 10_000 for p in paths)
