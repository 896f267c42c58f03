"""Finding, overriding and validating scenarios; every failure becomes one readable :class:`ScenarioError`."""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from swarmtrack.scenarios.schema import Scenario


class ScenarioError(ValueError):
    """A scenario that cannot be run, with a message naming the offending field."""


def builtin_names() -> list[str]:
    folder = resources.files("swarmtrack.scenarios") / "builtin"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))


def _read_yaml(text: str, origin: str) -> dict:
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{origin}: not valid YAML ({exc})") from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ScenarioError(f"{origin}: a scenario file must be a mapping of keys to values")
    return data


def load_raw(ref: str) -> dict:
    """A built-in scenario by name, or a YAML file by path, as a plain dict (not yet validated)."""
    if ref in builtin_names():
        text = (resources.files("swarmtrack.scenarios") / "builtin" / f"{ref}.yaml").read_text()
        return _read_yaml(text, ref)
    path = Path(ref)
    if not path.is_file():
        raise ScenarioError(
            f"no built-in scenario or file named {ref!r}; built-in: {', '.join(builtin_names())}")
    return _read_yaml(path.read_text(), str(path))


def apply_override(data: dict, assignment: str) -> None:
    """``dotted.key=value``; the value is parsed as YAML (``3``, ``0.5``, ``full``, ``[1, 2]``)."""
    if "=" not in assignment:
        raise ScenarioError(f"override {assignment!r} must look like dotted.key=value")
    key, _, raw = assignment.partition("=")
    key = key.strip()
    if not key or any(not part for part in key.split(".")):
        raise ScenarioError(f"override {assignment!r}: empty key")
    try:
        value = yaml.safe_load(raw) if raw.strip() else None
    except yaml.YAMLError:
        raise ScenarioError(f"override {assignment!r}: the value does not parse") from None
    node: Any = data
    parts = key.split(".")
    for part in parts[:-1]:
        child = node.get(part)
        if child is None:
            child = node[part] = {}
        if not isinstance(child, dict):
            raise ScenarioError(f"override {assignment!r}: {part!r} is not a section")
        node = child
    node[parts[-1]] = value


def validate(data: dict, origin: str = "scenario") -> Scenario:
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        lines = []
        for err in exc.errors():
            where = ".".join(str(p) for p in err["loc"]) or "(top level)"
            msg = err["msg"].removeprefix("Value error, ")
            lines.append(f"{where}: {msg}")
        raise ScenarioError(f"{origin}: invalid scenario\n  " + "\n  ".join(lines)) from None


def load_scenario(ref: str, overrides: list[str] = (), seed: int | None = None) -> Scenario:
    data = load_raw(ref)
    for assignment in overrides:
        apply_override(data, assignment)
    if seed is not None:
        data["seed"] = seed
    return validate(data, ref)
