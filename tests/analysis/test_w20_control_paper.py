"""The W20 Ch. 5 paper: claims on synthetic metrics (each can flip, in each setting), registry, and its experiments are
built in or variants of them."""

import pytest

from swarmtrack.analysis.papers import PAPERS, w20_control
from swarmtrack.scenarios import builtin_names

# per-UAV mean tracking errors (m) where every simulation claim holds
GOOD = {"w20-mpc-single": [0.065], "w20-mpc-single-cv": [0.064], "w20-mpc-single-h20": [0.050],
        "w20-mpc-single-cv-h20": [0.056], "w20-mpc-formation": [1.0, 1.0, 1.5],
        "w20-mpc-occlusion": [1.02, 0.98, 2.5], "w20-mpc-formation-estimated": [1.1, 1.1, 1.6],
        "w20-mpc-collision": [0.5, 1.2], "w20-mpc-collision-off": [0.2, 1.2], "w20-mpc-indoor": [0.1]}
CLOSEST = {"w20-mpc-collision": 1.2, "w20-mpc-collision-off": 0.05}
#: the model's one-step error in flight (m, m/s) and the bound the separation margin assumes
FLOWN, ASSUMED = {"position": 0.02, "velocity": 0.2}, [0.025, 0.25]


def metrics(name: str, errors: list[float], seed: int) -> dict:
    n = len(errors)
    return {"formation": {"tracking_error": [e * (1 + 0.001 * seed) for e in errors],
                          "tracking_error_xy": [[e, e] for e in errors],
                          "tracking_error_by_phase": {"cv": errors[0], "ct": errors[0]},
                          "solver": {"solves": 100, "fallbacks": [0] * n, "mean_solve_us": 90.0,
                                     "mean_iterations": 25.0, "softened": [0] * n, "relaxed": [0] * n},
                          "bounds": {"bound": 1.041, "vehicle_bound": 1.041, "separation": 1.0,
                                     "model_error": ASSUMED},
                          "model_error": dict(FLOWN)},
            "inter_agent_distance": {"min": CLOSEST.get(name, 10.0) + 0.01 * seed if n > 1 else None},
            "mean_error": {"all": 0.02}}


def base(name: str) -> str:
    """The built-in scenario an experiment runs (its own name, or the one a variant changes)."""
    return w20_control.PAPER.resolve(name)[0]


def by_scenario(change: dict | None = None, seeds: int = 3) -> dict:
    """Every experiment's runs, the thesis setting's variants with their scenario's numbers unless ``change`` names
    them."""
    values = {**{n: GOOD[base(n)] for n in w20_control.EXPERIMENTS}, **(change or {})}
    return {name: [metrics(base(name), values[name], s) for s in range(seeds)] for name in w20_control.EXPERIMENTS}


PER_SETTING = ["w20-mpc-multi-equals-single", "w20-mpc-formation-order", "w20-mpc-occlusion-only-uav3",
               "w20-mpc-collision-safe", "w20-mpc-longer-horizon"]
#: the plain ids judge the thesis' setting, ``-vehicle-bound`` the consistent one
IDS = [*PER_SETTING, *(f"{i}-vehicle-bound" for i in PER_SETTING), "w20-mpc-plans-flown", "w20-identification"]


@pytest.fixture(scope="module")
def _identification():
    """The identification claim is real (known-model recovery, the quadrotor's fit), made once for the module."""
    return w20_control._identification_claim()


@pytest.fixture(autouse=True)
def _quick_identification(monkeypatch, _identification):
    monkeypatch.setattr(w20_control, "_identification_claim", lambda: _identification)


def verdicts(data: dict) -> dict[str, bool]:
    claims, md, _ = w20_control.analyse(data)
    assert "Table 5.6" in md and "Table 5.9" in md
    return {c.id: c.holds for c in claims}


def test_every_claim_holds_on_favourable_numbers():
    assert verdicts(by_scenario()) == dict.fromkeys(IDS, True)


@pytest.mark.slow
@pytest.mark.parametrize("suffix", ["", "-thesis"])
@pytest.mark.parametrize(("change", "broken"), [
    ({"w20-mpc-single-cv": [0.05]}, {"w20-mpc-multi-equals-single"}),
    ({"w20-mpc-formation": [0.6, 1.0, 1.5], "w20-mpc-occlusion": [0.61, 0.98, 2.5]}, {"w20-mpc-formation-order"}),
    ({"w20-mpc-occlusion": [1.02, 0.98, 1.6]}, {"w20-mpc-occlusion-only-uav3"}),
    ({"w20-mpc-occlusion": [1.2, 0.98, 2.5]}, {"w20-mpc-occlusion-only-uav3"}),
    ({"w20-mpc-single-h20": [0.057]}, {"w20-mpc-longer-horizon"}),
])
def test_each_claim_flips_with_its_numbers_in_its_own_setting(change, broken, suffix):
    got = verdicts(by_scenario({name + suffix: v for name, v in change.items()}))
    assert {k for k, v in got.items() if not v} == {b + w20_control.CLAIM_SUFFIX[suffix] for b in broken}


def test_the_collision_claim_needs_both_the_safe_and_the_unsafe_run(monkeypatch):
    monkeypatch.setitem(CLOSEST, "w20-mpc-collision", 0.9)
    got = verdicts(by_scenario())
    assert not got["w20-mpc-collision-safe"] and not got["w20-mpc-collision-safe-vehicle-bound"]
    monkeypatch.setitem(CLOSEST, "w20-mpc-collision", 1.2)
    monkeypatch.setitem(CLOSEST, "w20-mpc-collision-off", 1.5)
    got = verdicts(by_scenario())
    assert not got["w20-mpc-collision-safe"] and not got["w20-mpc-collision-safe-vehicle-bound"]


def test_plans_are_not_flown_as_planned_when_the_model_errs_beyond_its_margin_or_a_flown_step_is_relaxed(monkeypatch):
    monkeypatch.setitem(FLOWN, "velocity", 0.3)
    assert not verdicts(by_scenario())["w20-mpc-plans-flown"]
    monkeypatch.setitem(FLOWN, "velocity", 0.2)
    data = by_scenario()
    data["w20-mpc-occlusion"][1]["formation"]["solver"]["softened"] = [0, 3, 0]
    assert verdicts(data)["w20-mpc-plans-flown"]  # the later steps' tightening gave way, the flown step did not
    data["w20-mpc-occlusion"][1]["formation"]["solver"]["relaxed"] = [0, 2, 0]
    claims, md, numbers = w20_control.analyse(data)
    assert not next(c for c in claims if c.id == "w20-mpc-plans-flown").holds
    assert numbers["flown"][""]["plans softened"] == 3 and numbers["flown"][""]["first steps relaxed"] == 2
    data = by_scenario()  # the estimated formation, which set the model's error bound, counts too
    data["w20-mpc-formation-estimated"][0]["formation"]["solver"]["relaxed"] = [1, 0, 0]
    assert not verdicts(data)["w20-mpc-plans-flown"]


def test_the_identification_claim_is_measured_not_assumed():
    claim, numbers = w20_control._identification_claim()
    assert numbers["largest error of a recovered entry"] < 1e-9
    assert 90.0 <= numbers["quadrotor fit x (%)"] < 100.0


def test_registered_with_builtin_experiments_and_their_thesis_setting():
    paper = PAPERS["w20-control"]
    assert {paper.resolve(e)[0] for e in paper.experiments} <= set(builtin_names())
    for name, (scenario, overrides) in w20_control.VARIANTS.items():
        assert name.startswith(scenario) and overrides
        bound = next(o for o in overrides if o.startswith("controller.bound="))
        assert bound == ("controller.bound=10.0" if "single" in scenario else "controller.bound=2.0")
