import pytest

from swarmtrack.scenarios import ScenarioError, builtin_names, load_scenario
from swarmtrack.scenarios.loader import apply_override


def test_every_builtin_scenario_validates():
    names = builtin_names()
    for expected in ("l24-cv", "l24-ct", "l24-fs", "l23-no-fusion", "l23-full-fusion",
                     "l23-flocking-standard", "l23-flocking-integral", "l23-flocking-tailored"):
        assert expected in names
    for name in names:
        assert load_scenario(name).name == name


def test_overrides_reach_nested_keys_and_parse_values():
    scn = load_scenario("l24-cv", ["network.topology=full", "estimator.share=measurements", "swarm.n_uavs=5",
                                   "estimator.model=fs"], seed=9)
    assert scn.network.topology == "full" and scn.estimator.share == "measurements"
    assert scn.swarm.n_uavs == 5 and scn.estimator.model == "fs" and scn.seed == 9


@pytest.mark.parametrize("override, field", [
    (["rates.estimation=-20"], "rates.estimation"),
    (["swarm.n_uavs=three"], "swarm.n_uavs"),
    (["estimator.bogus=1"], "estimator.bogus"),
    (["estimator.q=[0.1, -0.1, 0.1, 0.1]"], "estimator.q"),
    (["estimator.q=[0.1, 0.1]"], "estimator.q"),
    (["network.topology=edges", "network.edges=[[1, 7]]"], "network.edges"),
    (["sensor.sigma_range=.nan"], "sensor.sigma_range"),
    (["rates.control=7"], "rates.control"),
])
def test_bad_values_name_the_field(override, field):
    with pytest.raises(ScenarioError, match=field.split(".")[-1]):
        load_scenario("l24-cv", override)


def test_malformed_override_and_missing_file_are_clear():
    with pytest.raises(ScenarioError, match="dotted.key=value"):
        apply_override({}, "network.topology")
    with pytest.raises(ScenarioError, match="does not parse"):
        apply_override({}, "a.b=[1, 2")
    with pytest.raises(ScenarioError, match="no built-in scenario or file"):
        load_scenario("no-such-scenario")


def test_yaml_file_with_unknown_key(tmp_path):
    f = tmp_path / "s.yaml"
    f.write_text("name: x\nswarm: {n_uavs: 3, colour: red}\n")
    with pytest.raises(ScenarioError, match="swarm.colour"):
        load_scenario(str(f))


def test_unknown_flocking_gain_and_bad_gain_value_are_named():
    with pytest.raises(ScenarioError, match="controller.gains: unknown gain"):
        load_scenario("l24-cv", ["controller.gains.K_zz=1"])
    with pytest.raises(ScenarioError, match="controller.gains: eps must be in"):
        load_scenario("l24-cv", ["controller.gains.eps=2"])
    assert load_scenario("l24-cv", ["controller.gains.K_int=0.3"]).controller.gains == {"K_int": 0.3}


def test_runs_too_large_to_record_are_refused_before_running():
    with pytest.raises(ScenarioError, match="too large to record"):
        load_scenario("l24-cv", ["duration=1e7"])  # the longest duration allowed
