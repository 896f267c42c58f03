"""The many-targets study's claims (analysis/papers/mtt.py) read the runs' numbers and flip with them; its variants
are valid scenarios named after the experiment."""

import pytest

from swarmtrack.analysis.papers import mtt
from swarmtrack.scenarios import load_scenario


def _run(gospa, rmse=0.03, warnings=()):
    return {"gospa": {"gospa": gospa, "localisation": gospa, "missed": 0.0, "false": 0.0, "position_rmse": rmse},
            "continuity": {"label_switches": 0.0}, "tracking": {"bytes_per_uav_step": 100.0},
            "rmse": {"total": {"x": 0.03, "y": 0.04}}, "warnings": list(warnings)}


def _by(fused_hard=6.0, centre_hard=6.0, lmb=0.03, bad=False):
    by = {name: [_run(5.5)] * 2 for name in mtt.EXPERIMENTS}
    by["mtt-box-hard"] = [_run(fused_hard)] * 2
    by["mtt-box-hard-centre"] = [_run(centre_hard)] * 2
    by["l24-ct-lmb"] = [_run(0.0, lmb)] * 2
    if bad:
        by["mtt-swarm"] = [_run(9.0, warnings=[{"kind": "tracks_not_finite"}]), _run(9.0)]
    return by


@pytest.mark.parametrize("kwargs, failing", [
    ({}, set()),
    ({"fused_hard": 8.5, "centre_hard": 8.5}, {"mtt-hard-gospa"}),
    ({"fused_hard": 7.0, "centre_hard": 6.0}, {"mtt-hard-centralised"}),
    ({"lmb": 0.06}, {"mtt-one-target"}),  # the information filter's 0.05
    ({"bad": True}, {"mtt-no-divergence"}),
])
def test_the_claims_flip_with_the_numbers(kwargs, failing):
    claims, md, numbers = mtt.analyse(_by(**kwargs))
    assert {c.id for c in claims if not c.holds} == failing
    assert "GA-LMB" in md and numbers["one_target"]["information_position_rmse"] == pytest.approx(0.05)


def test_every_variant_is_a_valid_scenario_named_after_its_experiment():
    for name in mtt.PAPER.experiments:
        scenario = load_scenario(*mtt.PAPER.resolve(name, ["duration=5"]))
        assert scenario.name == name
