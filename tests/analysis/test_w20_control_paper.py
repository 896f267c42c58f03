"""The W20 Ch. 5 paper: claims on synthetic metrics (each can flip), registry, and its experiments are built in."""

import pytest

from swarmtrack.analysis.papers import PAPERS, w20_control
from swarmtrack.scenarios import builtin_names

# per-UAV mean tracking errors (m) where every simulation claim holds
GOOD = {"w20-mpc-single": [0.065], "w20-mpc-single-cv": [0.064], "w20-mpc-single-h20": [0.050],
        "w20-mpc-single-cv-h20": [0.056], "w20-mpc-formation": [1.0, 1.0, 1.5],
        "w20-mpc-occlusion": [1.02, 0.98, 2.5], "w20-mpc-formation-estimated": [1.1, 1.1, 1.6],
        "w20-mpc-collision": [0.5, 1.2], "w20-mpc-collision-off": [0.2, 1.2], "w20-mpc-indoor": [0.1]}
CLOSEST = {"w20-mpc-collision": 1.2, "w20-mpc-collision-off": 0.05}


def metrics(name: str, errors: list[float], seed: int) -> dict:
    n = len(errors)
    return {"formation": {"tracking_error": [e * (1 + 0.001 * seed) for e in errors],
                          "tracking_error_xy": [[e, e] for e in errors],
                          "tracking_error_by_phase": {"cv": errors[0], "ct": errors[0]},
                          "solver": {"solves": 100, "fallbacks": [0] * n, "mean_solve_us": 90.0,
                                     "mean_iterations": 25.0}},
            "inter_agent_distance": {"min": CLOSEST.get(name, 10.0) + 0.01 * seed if n > 1 else None},
            "mean_error": {"all": 0.02}}


def by_scenario(change: dict | None = None, seeds: int = 3) -> dict:
    values = {**GOOD, **(change or {})}
    return {name: [metrics(name, values[name], s) for s in range(seeds)] for name in w20_control.EXPERIMENTS}


IDS = ["w20-mpc-multi-equals-single", "w20-mpc-formation-order", "w20-mpc-occlusion-only-uav3",
       "w20-mpc-collision-safe", "w20-identification", "w20-mpc-longer-horizon"]


@pytest.fixture(autouse=True)
def _quick_identification(monkeypatch):
    """The identification claim is real (known-model recovery, the quadrotor's fit); cached across the tests."""
    result = w20_control._identification_claim()
    monkeypatch.setattr(w20_control, "_identification_claim", lambda: result)


def verdicts(data: dict) -> dict[str, bool]:
    claims, md, _ = w20_control.analyse(data)
    assert "Table 5.6" in md and "Table 5.9" in md
    return {c.id: c.holds for c in claims}


def test_every_claim_holds_on_favourable_numbers():
    assert verdicts(by_scenario()) == dict.fromkeys(IDS, True)


@pytest.mark.slow
@pytest.mark.parametrize(("change", "broken"), [
    ({"w20-mpc-single-cv": [0.05]}, {"w20-mpc-multi-equals-single"}),
    ({"w20-mpc-formation": [0.6, 1.0, 1.5], "w20-mpc-occlusion": [0.61, 0.98, 2.5]}, {"w20-mpc-formation-order"}),
    ({"w20-mpc-occlusion": [1.02, 0.98, 1.6]}, {"w20-mpc-occlusion-only-uav3"}),
    ({"w20-mpc-occlusion": [1.2, 0.98, 2.5]}, {"w20-mpc-occlusion-only-uav3"}),
    ({"w20-mpc-single-h20": [0.057]}, {"w20-mpc-longer-horizon"}),
])
def test_each_claim_flips_with_its_numbers(change, broken):
    got = verdicts(by_scenario(change))
    assert {k for k, v in got.items() if not v} == broken


@pytest.mark.slow
def test_the_collision_claim_needs_both_the_safe_and_the_unsafe_run(monkeypatch):
    monkeypatch.setitem(CLOSEST, "w20-mpc-collision", 0.9)
    assert not verdicts(by_scenario())["w20-mpc-collision-safe"]
    monkeypatch.setitem(CLOSEST, "w20-mpc-collision", 1.2)
    monkeypatch.setitem(CLOSEST, "w20-mpc-collision-off", 1.5)
    assert not verdicts(by_scenario())["w20-mpc-collision-safe"]


def test_the_identification_claim_is_measured_not_assumed():
    claim, numbers = w20_control._identification_claim()
    assert numbers["largest error of a recovered entry"] < 1e-9
    assert 90.0 <= numbers["quadrotor fit x (%)"] < 100.0


def test_registered_with_builtin_experiments():
    paper = PAPERS["w20-control"]
    assert set(paper.experiments) <= set(builtin_names())
