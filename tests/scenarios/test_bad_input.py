"""Bad scenario input: every case is one :class:`ScenarioError` naming the field or the cause."""

import os

import pytest
import yaml

from swarmtrack.scenarios import ScenarioError, builtin_names, load_scenario
from swarmtrack.scenarios.loader import apply_override, load_raw, validate


def _file(tmp_path, content: bytes | str, name: str = "s.yaml") -> str:
    f = tmp_path / name
    f.write_bytes(content if isinstance(content, bytes) else content.encode())
    return str(f)


# --- the file itself -------------------------------------------------------------------------------------------

@pytest.mark.parametrize("content, message", [
    (b"\xff\xfe\x00\x01binary\x00", "not a UTF-8 text file"),
    ("name: caf\u00e9\n".encode("latin-1"), r"not a UTF-8 text file \(byte 0xe9 at offset 9\)"),
    (b"name: x\x00\n", "not valid YAML"),
    (b"", "empty scenario file"),
    (b"# only a comment\n\n   # and another\n", "empty scenario file"),
    (b"---\n", "empty scenario file"),
    (b"[" * 10_000 + b"]" * 10_000, "nested more than 50 levels deep"),
    (b"swarm:\n" + b"".join(b"  " * k + b"a:\n" for k in range(1, 2000)), "nested more than 50 levels deep"),
    (b"name: a\nseed: 1\nname: b\n", r"duplicate key 'name' \(first given on line 1\) \(line 3"),
    (b"swarm:\n  n_uavs: 3\n  n_uavs: 5\n", r"duplicate key 'n_uavs' \(first given on line 2\)"),
    (b"swarm: {n_uavs: 3, n_uavs: 5}\n", "duplicate key 'n_uavs'"),
    (b"- 1\n- 2\n", "must be a mapping"),
    (b"a: 1\n---\nb: 2\n", "not valid YAML: expected a single document in the stream: but found another document"),
])
def test_bad_files_are_one_message(tmp_path, content, message):
    path = _file(tmp_path, content)
    with pytest.raises(ScenarioError, match=message) as err:
        load_scenario(path)
    assert str(err.value).startswith(path) and len(str(err.value).splitlines()) == 1


def test_a_byte_order_mark_and_merge_keys_are_fine(tmp_path):
    path = _file(tmp_path, "\ufeffname: bom\nswarm: {<<: {n_uavs: 4, vehicle: quadrotor}, n_uavs: 5}\n".encode())
    scn = load_scenario(path)
    assert scn.name == "bom" and scn.swarm.n_uavs == 5


def test_explicit_empty_mapping_runs_the_defaults(tmp_path):
    assert load_scenario(_file(tmp_path, "{}\n")).name == "custom"


def test_a_folder_is_not_a_scenario(tmp_path):
    (tmp_path / "d.yaml").mkdir()
    with pytest.raises(ScenarioError, match="is a folder, not a scenario file"):
        load_raw(str(tmp_path / "d.yaml"))


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root reads a chmod 000 file")
def test_an_unreadable_file_is_named(tmp_path):
    path = _file(tmp_path, "name: x\n")
    os.chmod(path, 0)
    try:
        with pytest.raises(ScenarioError, match="cannot be read"):
            load_raw(path)
    finally:
        os.chmod(path, 0o644)


def test_a_read_error_is_named_even_as_root(tmp_path, monkeypatch):
    path = _file(tmp_path, "name: x\n")

    def denied(self):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(type(tmp_path), "read_bytes", denied)
    with pytest.raises(ScenarioError, match=r"s.yaml: cannot be read \(Permission denied\)$"):
        load_raw(path)


def test_override_values_get_the_same_checks():
    with pytest.raises(ScenarioError, match="duplicate key 'n_uavs'"):
        apply_override({}, "swarm={n_uavs: 3, n_uavs: 4}")
    with pytest.raises(ScenarioError, match="nested more than"):
        apply_override({}, "estimator.q=" + "[" * 5000 + "]" * 5000)


# --- values --------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("override, message", [
    (["swarm.n_uavs=true"], "swarm.n_uavs: true/false is not a number"),
    (["seed=false"], "seed: true/false is not a number"),
    (["controller.d=true"], "controller.d: true/false is not a number"),
    (["target.start=[true, 0]"], "target.start: true/false is not a number"),
    (["controller.gains.K_d=true"], "controller.gains: true/false is not a number"),
    (["rates.physics=true"], "rates.physics: true/false is not a number"),
    (["estimator.q=[1, true, 1, 1]"], "estimator.q: true/false is not a number"),
    (["swarm.initial_positions=[[0, 0], [5, 0], [10, false]]"], "swarm.initial_positions: true/false"),
])
def test_booleans_are_not_numbers(override, message):
    with pytest.raises(ScenarioError, match=message.replace("[", r"\[")):
        load_scenario("l24-cv", override)


@pytest.mark.parametrize("override, message", [
    (["network.topology=edges", "network.edges=[[1, 1]]"], r"network.edges: \[1, 1\] is a self-loop"),
    (["network.topology=edges", "network.edges=[[1, 2], [3, 3]]"], r"network.edges: \[3, 3\] is a self-loop"),
    (["network.topology=edges", "network.edges=[[0, 2]]"], "network.edges names UAV 0, but the swarm has UAVs 1..3"),
])
def test_edges_are_reported_as_written(override, message):
    with pytest.raises(ScenarioError, match=message):
        load_scenario("l24-cv", override)


@pytest.mark.parametrize("override, message", [
    (["controller.d=1e160"], "controller.d: 1e+160 m is beyond the limit of 1e6 m"),
    (["controller.gains.K_d=1e300"], "controller.gains.K_d: 1e+300 is beyond the limit of 1e6"),
    (["controller.gains.D_dt=-1e300"], "controller.gains.D_dt: -1e+300 is beyond"),
    (["target.start=[1e300, 0]"], r"target.start\[0\]: 1e\+300 m is beyond the limit of 1e6 m"),
    (["target.profile=custom", "target.phases=[{name: a, duration: 5, omega: [1e308, 0]}]"],
     r"target.phases\[0\].omega\[0\]: 1e\+308 rad/s is beyond the limit of 1e3 rad/s"),
    (["target.profile=custom", "target.phases=[{name: a, duration: 5, c: [0, -2e3]}]"],
     r"target.phases\[0\].c\[1\]: -2000 m/s is beyond the limit of 1e3 m/s"),
    (["swarm.spawn_center=[0, 1e7]"], r"swarm.spawn_center\[1\]: 1e\+07 m"),
    (["network.r_comm=1e200"], "network.r_comm: 1e+200 m"),
    (["sensor.sigma_range=1e9"], "sensor.sigma_range: 1e+09 m"),
    (["rates.physics=1e300"], "rates.physics: 1e+300 Hz is beyond the limit of 1e4 Hz"),
    (["duration=1e9"], "duration: 1e+09 s is beyond the limit of 1e7 s"),
    (["controller.chase_after_steps=1e30"], "controller.chase_after_steps"),
])
def test_huge_finite_values_are_refused_with_their_unit(override, message):
    with pytest.raises(ScenarioError, match=message.replace("+", r"\+") if "\\" not in message else message):
        load_scenario("l24-cv", override)


def test_values_at_the_bounds_are_accepted():
    scn = load_scenario("l24-cv", ["controller.d=1e6", "controller.gains.K_d=1e6", "target.start=[-1e6, 1e6]",
                                   "rates.physics=1e4", "rates.estimation=1e4", "rates.control=1e4",
                                   "duration=0.5"])
    assert scn.controller.d == 1e6 and scn.targets.members[0].start == (-1e6, 1e6)


# --- keys the chosen option ignores ------------------------------------------------------------------------------

@pytest.mark.parametrize("override, message", [
    (["network.edges=[[1, 2]]"], "network.edges: given, but network.topology is 'line'"),
    (["network.topology=full", "network.edges=[[1, 2]]"], "network.edges: given, but network.topology is 'full'"),
    (["target.phases=[{name: a, duration: 5}]"], "target.phases: given, but profile is 'l24'"),
    (["target.hover_duration=5"], "target.hover_duration: given, but profile is 'l24'"),
    (["target.profile=custom", "target.phases=[{name: a, duration: 5}]", "target.hover_duration=5"],
     "target.hover_duration: given, but profile is 'custom'"),
    (["swarm.initial_positions=[[0, 0], [5, 0], [10, 0]]", "swarm.spawn_center=[1, 1]"],
     "swarm.spawn_center: given, but swarm.initial_positions places the UAVs"),
    (["swarm.initial_positions=[[0, 0], [5, 0], [10, 0]]", "swarm.spawn_half_width=9"], "swarm.spawn_half_width"),
    (["swarm.initial_positions=[[0, 0], [5, 0], [10, 0]]", "swarm.min_separation=2"], "swarm.min_separation"),
])
def test_keys_the_chosen_option_ignores_are_errors(override, message):
    with pytest.raises(ScenarioError, match=message):
        load_scenario("l24-cv", override)


def test_ignored_keys_are_named_in_the_groups_too():
    data = {"targets": {"members": [{"profile": "hover", "hover_duration": 9},
                                    {"profile": "l23", "phases": [{"name": "a", "duration": 5}]}]}}
    with pytest.raises(ScenarioError, match=r"targets.members\[1\].phases: given, but profile is 'l23'"):
        validate(data)
    data = {"decoys": {"members": [{"profile": "l24", "hover_duration": 9}]}}
    with pytest.raises(ScenarioError, match=r"decoys.members\[0\].hover_duration: given"):
        validate(data)


def test_the_flocking_shorthand_is_named_as_written():
    with pytest.raises(ScenarioError, match="flocking.d: 1e"):
        validate({"flocking": {"d": 1e9}})
    with pytest.raises(ScenarioError, match="target.velocity_gain: true/false"):
        validate({"target": {"velocity_gain": True}})


def test_options_that_use_the_keys_still_take_them():
    scn = load_scenario("l24-cv", ["network.topology=edges", "network.edges=[[1, 3]]", "target.profile=hover",
                                   "target.hover_duration=5"])
    assert scn.network.edges == [(1, 3)] and scn.targets.members[0].hover_duration == 5
    scn = load_scenario("l24-cv", ["swarm.initial_positions=[[0, 0], [5, 0], [10, 0]]", "duration=2"])
    assert scn.swarm.initial_positions == [(0, 0), (5, 0), (10, 0)]


@pytest.mark.slow
@pytest.mark.parametrize("name, extra", [(name, []) for name in builtin_names()] + [
    ("l24-cv", ["network.topology=edges", "network.edges=[[1, 3]]"]),
    ("l24-cv", ["target.profile=custom", "target.phases=[{name: a, duration: 5, c: [0.5, 0]}]"]),
    ("l24-cv", ["target.profile=hover", "target.hover_duration=5"]),
    ("l24-cv", ["swarm.initial_positions=[[0, 0], [5, 0], [10, 0]]"]),
])
def test_a_resolved_scenario_loads_again(name, extra):
    """``run`` writes the resolved scenario (every default spelled out, ignored keys included); rerunning it
    must still validate, so an ignored key at its default value is let through."""
    scn = load_scenario(name, extra)
    again = validate(yaml.safe_load(yaml.safe_dump(scn.model_dump(mode="json"))))
    assert again == scn
