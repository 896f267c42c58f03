import pytest
import yaml
from click.testing import CliRunner

from swarmtrack import registry
from swarmtrack.cli import main
from swarmtrack.scenarios import Scenario, builtin_names, load_scenario


def test_validate_prints_the_resolved_scenario_that_loads_back_to_the_same(tmp_path):
    res = CliRunner().invoke(main, ["validate", "l24-ct", "--set", "network.topology=full", "--set",
                                    "estimator.model=cv", "--seed", "7"])
    assert res.exit_code == 0, res.output
    expected = load_scenario("l24-ct", ["network.topology=full", "estimator.model=cv"], seed=7)
    assert Scenario.model_validate(yaml.safe_load(res.output)) == expected
    # the printed file is itself a scenario: validating it again prints the same text
    path = tmp_path / "resolved.yaml"
    path.write_text(res.output)
    again = CliRunner().invoke(main, ["validate", str(path)])
    assert again.exit_code == 0 and again.output == res.output


@pytest.mark.slow
def test_validate_every_builtin():
    for name in builtin_names():
        res = CliRunner().invoke(main, ["validate", name])
        assert res.exit_code == 0, res.output
        assert Scenario.model_validate(yaml.safe_load(res.output)) == load_scenario(name)


def test_validate_bad_input_exits_2_with_the_loaders_message(tmp_path):
    cases = [
        (["l24-ct", "--set", "swarm.n_uavs=three"], "swarm.n_uavs"),
        (["l24-ct", "--set", "estimator.bogus=1"], "estimator.bogus"),
        (["l24-ct", "--set", "novalue"], "dotted.key=value"),
        (["no-such-scenario"], "no built-in scenario or file"),
    ]
    for args, field in cases:
        res = CliRunner().invoke(main, ["validate", *args])
        assert res.exit_code == 2, (args, res.output)
        assert field in res.output and "Traceback" not in res.output


def test_schema_lists_every_section_kind_and_key():
    res = CliRunner().invoke(main, ["schema"])
    assert res.exit_code == 0, res.output
    out = res.output
    for key in ("network.topology", "swarm.spawn_center", "sensor.latency", "rates.physics", "seed", "kernels",
                "targets.members[].profile", "decoys.members[].phases[].omega", "controller.gains"):
        assert f"  {key}:" in out, key
    for role in registry.ROLES:
        for kind in registry.kinds(role):
            assert f"{role} (kind: {kind})" in out
    assert "none, line, ring, full, proximity, edges" in out  # allowed values
    assert "[-2.0, -6.0]" in out  # a default
    assert "target:" in out and "flocking:" in out  # the shorthands


def test_schema_markdown_is_tables():
    res = CliRunner().invoke(main, ["schema", "--format", "markdown"])
    assert res.exit_code == 0, res.output
    assert "### estimator (kind: centralized)" in res.output
    assert "| `network.topology` | string | `line` | none, line, ring, full, proximity, edges |" in res.output
    assert CliRunner().invoke(main, ["schema", "--format", "html"]).exit_code == 2
