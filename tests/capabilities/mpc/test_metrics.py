"""The formation section's bounds, the model's error in flight and their warnings (issue 42)."""

import numpy as np
import pytest

from swarmtrack.analysis.metrics import summary
from swarmtrack.capabilities.mpc.metrics import _formation_warnings
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate


@pytest.fixture(scope="module")
def crossing():
    """Table 5.9's two UAVs for 6 s: UAV 2 sets off across UAV 1's place."""
    scenario = load_scenario("w20-mpc-collision", ["duration=6"])
    return scenario, simulate(scenario)


def test_the_model_error_in_flight_is_the_largest_one_step_error_on_the_true_states(crossing):
    scenario, rec = crossing
    _, A, B = scenario.controller.uav_model()
    chunks = list(rec.chunks())
    x = np.concatenate([c.truth[:, rec.uav_slice, :4] for c in chunks])
    s = np.concatenate([c.probes["setpoint"] for c in chunks])
    err = np.abs(x[:-1] @ A.T + s[:-1] @ B.T - x[1:])
    flown = summary(rec)["formation"]["model_error"]
    assert flown == {"position": pytest.approx(np.nanmax(err[..., :2]), rel=1e-12),
                     "velocity": pytest.approx(np.nanmax(err[..., 2:]), rel=1e-12)}
    assert 0.005 < flown["position"] < 0.025  # the bound the 5° vehicle flies: a few cm in a period


def test_the_section_states_the_bounds_the_mpc_planned_within(crossing):
    scenario, rec = crossing
    f = summary(rec)["formation"]
    assert f["bounds"]["bound"] == f["bounds"]["vehicle_bound"] == 1.041
    assert f["bounds"]["separation"] == 1.0 and f["bounds"]["model_error"] == [0.03, 0.35]
    assert f["solver"]["softened"] == f["solver"]["relaxed"] == [0, 0]
    assert f["bounds"]["margins"] == pytest.approx(scenario.controller.margins(scenario))


def _formation(relaxed=(0, 0), flown=(0.02, 0.2), separation=1.0):
    return {"solver": {"fallbacks": [0, 0], "relaxed": list(relaxed)},
            "bounds": {"separation": separation, "model_error": [0.025, 0.25]},
            "model_error": {"position": flown[0], "velocity": flown[1]}}


@pytest.mark.parametrize("formation, unflyable, kinds", [
    (_formation(), [], []),
    (_formation(relaxed=(0, 3)), [], ["separation_relaxed"]),
    (_formation(flown=(0.03, 0.2)), [], ["model_error_exceeded"]),
    (_formation(flown=(0.02, 0.3)), [], ["model_error_exceeded"]),
    (_formation(flown=(0.05, 0.5), separation=None), ["controller.bound = 2 m is more ..."], ["unflyable_bound"]),
])
def test_each_warning_comes_from_its_own_cause(formation, unflyable, kinds):
    got = _formation_warnings(formation, 5.0, unflyable)
    assert [w["kind"] for w in got] == kinds
    if "separation_relaxed" in kinds:
        assert got[0]["uav"] == 2 and "3 time(s)" in got[0]["message"]
