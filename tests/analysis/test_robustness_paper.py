"""The robustness study's claims (analysis/papers/robustness.py) read the runs' numbers and flip with them; its
variants are valid scenarios named after the experiment."""

import pytest

from swarmtrack.analysis.papers import robustness
from swarmtrack.analysis.papers.robustness import GROUPS, PAPER
from swarmtrack.scenarios import load_scenario


def _run(per_uav, liar=None):
    return {"position_rmse_per_uav": per_uav, "warnings": [], **({} if liar is None else {"liar_uav": liar})}


def _liar_runs(gated: float, ungated: float) -> dict:
    clean = [0.03] * 5

    def with_liar(x):
        return [x, x, 0.03, x, x]

    by = {name: [_run(clean)] * 2 for name in GROUPS["liar"]}
    by["robust-liar-chi2"] = [_run(with_liar(gated), 3)] * 2
    by["robust-liar-random-chi2"] = [_run(with_liar(gated), 3)] * 2
    by["robust-liar-none"] = [_run(with_liar(ungated), 3)] * 2
    by["robust-liar-ci"] = [_run(with_liar(0.05), 3)] * 2
    return by


@pytest.mark.parametrize("gated, ungated, holds", [(0.033, 0.1, True), (0.04, 0.1, False), (0.033, 0.04, False)])
def test_the_liar_claim_reads_the_honest_uavs_only(gated, ungated, holds):
    claims, _, numbers = robustness.analyse(_liar_runs(gated, ungated))
    claim = next(c for c in claims if c.id == "robust-liar-gated")
    assert claim.holds is holds
    assert numbers["liar"]["liar, gating chi2"]["mean"] == pytest.approx(gated)  # the liar's own 0.03 left out


def test_every_variant_is_a_valid_scenario_named_after_its_experiment():
    for name in PAPER.experiments:
        scenario = load_scenario(*PAPER.resolve(name, ["duration=5"]))
        assert scenario.name == name
