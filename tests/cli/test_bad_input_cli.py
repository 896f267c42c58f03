"""Bad scenario input through ``swarmtrack run``: exit code 2, one short message, no traceback, nothing written."""

import pytest
from click.testing import CliRunner

from swarmtrack.cli import main


def _run(tmp_path, scenario: str, *extra: str):
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", scenario, "--out", str(out), "--no-plots", *extra])
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output and isinstance(res.exception, SystemExit)
    assert not out.exists() and not any(p.name.startswith(".out.") for p in tmp_path.iterdir())
    lines = res.output.strip().splitlines()
    assert len(lines) <= 2, res.output  # "Error: <origin>: ..." and at most one field line
    return res.output


@pytest.mark.parametrize("content, message", [
    (b"\x00\xff\xfebinary", "not a UTF-8 text file"),
    (b"", "empty scenario file"),
    (b"# nothing but a comment\n", "empty scenario file"),
    (b"[" * 10_000 + b"]" * 10_000, "nested more than 50 levels deep"),
    (b"name: a\nname: b\n", "duplicate key 'name' (first given on line 1)"),
])
def test_bad_files(tmp_path, content, message):
    f = tmp_path / "bad.yaml"
    f.write_bytes(content)
    assert message in _run(tmp_path, str(f))


def test_a_folder(tmp_path):
    (tmp_path / "folder.yaml").mkdir()
    assert "is a folder, not a scenario file" in _run(tmp_path, str(tmp_path / "folder.yaml"))


@pytest.mark.parametrize("overrides, message", [
    (["swarm.n_uavs=true"], "swarm.n_uavs: true/false is not a number"),
    (["network.topology=edges", "network.edges=[[1, 1]]"], "network.edges: [1, 1] is a self-loop"),
    (["controller.d=1e160"], "controller.d: 1e+160 m is beyond the limit of 1e6 m"),
    (["controller.gains.K_d=1e300"], "controller.gains.K_d: 1e+300 is beyond the limit of 1e6"),
    (["target.start=[1e300, 0]"], "target.start[0]: 1e+300 m"),
    (["target.profile=custom", "target.phases=[{name: a, duration: 5, omega: [1e308, 0]}]"],
     "target.phases[0].omega[0]: 1e+308 rad/s"),
    (["network.edges=[[1, 2]]"], "network.edges: given, but network.topology is 'line'"),
    (["target.phases=[{name: a, duration: 5}]"], "target.phases: given, but profile is 'l24'"),
    (["target.hover_duration=5"], "target.hover_duration: given, but profile is 'l24'"),
    (["swarm.initial_positions=[[0, 0], [5, 0], [10, 0]]", "swarm.spawn_center=[1, 1]"],
     "swarm.spawn_center: given, but swarm.initial_positions places the UAVs"),
    (["swarm={n_uavs: 3, n_uavs: 4}"], "duplicate key 'n_uavs'"),
    (["estimator={kind: [1, 2]}"], "estimator: unknown kind [1, 2]; known: centralized"),
    (["controller.kind={a: 1}"], "controller: unknown kind {'a': 1}; known: flocking"),
    (["sensor.kind=[]"], "sensor: unknown kind []; known: camera"),
])
def test_bad_values(tmp_path, overrides, message):
    args = [a for o in overrides for a in ("--set", o)]
    assert message in _run(tmp_path, "l24-cv", *args)


def test_rates_so_low_that_the_run_has_no_step(tmp_path):
    out = _run(tmp_path, "l24-cv", "--set", "duration=4", "--set", "rates.physics=0.1", "--set",
               "rates.estimation=0.1", "--set", "rates.control=0.1")
    assert "duration 4 s is shorter than one estimation step (10 s)" in out
