import re
from pathlib import Path

import pytest
import yaml

from swarmtrack import registry
from swarmtrack.scenarios import reference
from swarmtrack.scenarios.loader import validate
from swarmtrack.scenarios.schema import Scenario

DOC = Path(__file__).resolve().parents[2] / "docs" / "scenarios.md"


def test_docs_scenarios_md_lists_the_current_schema():
    doc = DOC.read_text()
    assert reference.BEGIN in doc and reference.END in doc, f"{DOC} lost its marker comments"
    assert reference.generated_part(doc) == reference.generated_part(reference.replace_generated(doc)), (
        f"{DOC.name} does not match the scenario schema; regenerate it with "
        "`python -m swarmtrack.scenarios.reference --write docs/scenarios.md` and commit the result")


def test_every_field_of_every_section_and_kind_is_listed():
    listed = {k.key for k in reference.keys()}

    def expect(model, prefix):
        for name, field in model.model_fields.items():
            key = f"{prefix}{name}"
            assert key in listed, key
            item = reference._list_item_model(field.annotation)
            nested = reference._model_of(field.annotation)
            if item is not None:
                expect(item, f"{key}[].")
            elif nested is not None:
                expect(nested, f"{key}.")

    for name, field in Scenario.model_fields.items():
        if name in registry.ROLES:
            continue
        nested = reference._model_of(field.annotation)
        if nested is None:
            assert name in listed
        else:
            expect(nested, f"{name}.")
    sections = {k.section for k in reference.keys()}
    for part in registry.ROLES:
        for kind, registered in registry.kinds(part).items():
            assert f"{part} (kind: {kind})" in sections
            expect(registered.settings, f"{part}.")
    assert "targets.members[].phases[].duration" in listed and {"target", "flocking"} <= listed


def test_defaults_and_allowed_values_come_from_the_schema():
    rows = {(k.section, k.key): k for k in reference.keys()}
    assert rows["swarm", "swarm.spawn_center"].default == "[-2.0, -6.0]"
    assert rows["targets", "targets.members"].default == "[{}]"  # one member with every default
    assert rows["decoys", "decoys.members"].default == "[]"
    assert rows["targets", "targets.members[].phases[].name"].default == "required"
    assert rows["network", "network.topology"].allowed == "none, line, ring, full, proximity, edges"
    assert "≥ 0" in rows["network", "network.loss_probability"].allowed
    assert rows["estimator (kind: centralized)", "estimator.kind"].default == "centralized"
    assert "K_int (0.2)" in rows["controller (kind: flocking)", "controller.gains"].allowed


def test_replace_generated_keeps_the_prose_and_refuses_a_doc_without_markers():
    doc = f"intro\n{reference.BEGIN}\nold table\n{reference.END}\noutro\n"
    new = reference.replace_generated(doc, "new table\n")
    assert new.startswith("intro\n") and new.endswith(f"{reference.END}\noutro\n") and "old" not in new
    with pytest.raises(ValueError):
        reference.replace_generated("no markers")


def test_yaml_examples_in_the_doc_are_valid_scenarios():
    blocks = re.findall(r"```yaml\n(.*?)```", DOC.read_text(), re.S)
    assert blocks
    for block in blocks:
        validate(yaml.safe_load(block), "docs/scenarios.md")
