"""Finding, overriding and validating scenarios; every failure becomes one readable :class:`ScenarioError`."""

from __future__ import annotations

from collections.abc import Sequence
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


#: Deeper YAML than this is refused before it is built (PyYAML's composer recurses once per level).
MAX_DEPTH = 50
#: Larger files are refused unread (100,000 initial positions take about 3 MB).
MAX_BYTES = 64 * 2**20


class _Loader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses duplicate keys (PyYAML keeps the last one silently) and documents
    nested more than :data:`MAX_DEPTH` levels deep (a RecursionError otherwise)."""

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent, index):
        if self._depth >= MAX_DEPTH:
            raise yaml.composer.ComposerError(None, None, f"nested more than {MAX_DEPTH} levels deep",
                                              self.peek_event().start_mark)
        self._depth += 1
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            first_line: dict = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":  # ``<<: *anchor`` keys may be overridden
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    line = first_line.get(key)
                except TypeError:  # an unhashable key: the base class reports it
                    continue
                if line is not None:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"duplicate key {key!r} (first given on line {line})", key_node.start_mark)
                first_line[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep)


class _YamlProblem(Exception):
    """What is wrong with a YAML text, in one line."""


def _yaml_problem(exc: yaml.YAMLError) -> str:
    """One line: the problem and where (PyYAML's own text spans several lines)."""
    if isinstance(exc, yaml.MarkedYAMLError) and exc.problem:
        mark = exc.problem_mark
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""
        context = f"{exc.context}: " if exc.context else ""
        return f"{context}{exc.problem}{where}"
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__


def _parse(text: str):
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506 (a SafeLoader)
    except yaml.YAMLError as exc:
        raise _YamlProblem(_yaml_problem(exc)) from None
    except RecursionError:
        raise _YamlProblem(f"nested too deeply (more than {MAX_DEPTH} levels)") from None


def _read_yaml(text: str, origin: str) -> dict:
    try:
        data = _parse(text)
    except _YamlProblem as exc:
        raise ScenarioError(f"{origin}: not valid YAML: {exc}") from None
    if data is None:
        raise ScenarioError(f"{origin}: empty scenario file (it holds no keys; {{}} runs the defaults)")
    if not isinstance(data, dict):
        raise ScenarioError(f"{origin}: a scenario file must be a mapping of keys to values")
    return data


def load_raw(ref: str) -> dict:
    """A built-in scenario by name, or a YAML file by path, as a plain dict (not yet validated)."""
    if ref in builtin_names():
        text = (resources.files("swarmtrack.scenarios") / "builtin" / f"{ref}.yaml").read_text()
        return _read_yaml(text, ref)
    path = Path(ref)
    if path.is_dir():
        raise ScenarioError(f"{path}: is a folder, not a scenario file")
    if not path.is_file():
        raise ScenarioError(
            f"no built-in scenario or file named {ref!r}; built-in: {', '.join(builtin_names())}")
    return _read_yaml(_read_text(path), str(path))


def _read_text(path: Path) -> str:
    """The file's UTF-8 text (a byte-order mark is allowed)."""
    try:
        if path.stat().st_size > MAX_BYTES:
            raise ScenarioError(f"{path}: {path.stat().st_size} bytes is too large for a scenario file "
                                f"(limit {MAX_BYTES // 2**20} MB)")
        raw = path.read_bytes()
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: not a UTF-8 text file (byte 0x{raw[exc.start]:02x} at offset {exc.start}); "
                            "a scenario is a YAML text file") from None


def apply_override(data: dict, assignment: str) -> None:
    """``dotted.key=value``; the value is parsed as YAML (``3``, ``0.5``, ``full``, ``[1, 2]``)."""
    if "=" not in assignment:
        raise ScenarioError(f"override {assignment!r} must look like dotted.key=value")
    key, _, raw = assignment.partition("=")
    key = key.strip()
    if not key or any(not part for part in key.split(".")):
        raise ScenarioError(f"override {assignment!r}: empty key")
    try:
        value = _parse(raw) if raw.strip() else None
    except _YamlProblem as exc:
        raise ScenarioError(f"override {assignment!r}: the value does not parse ({exc})") from None
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


#: The shorthand sections (see :meth:`Scenario._shorthands`), the section they stand for and the part of its
#: field path they replace, so an error names the field as the user wrote it.
_SHORTHANDS = (("target", ("targets", "members", 0)), ("target", ("targets",)), ("flocking", ("controller",)))


def _as_written(loc: tuple, data: dict) -> tuple:
    for short, long in _SHORTHANDS:
        if short in data and loc[:len(long)] == long:
            return (short, *loc[len(long):])
    return loc


def _field_path(loc: tuple) -> str:
    """``("targets", "members", 0, "phases")`` as ``targets.members[0].phases``."""
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else f".{part}"
    return text.lstrip(".")


def validate(data: dict, origin: str = "scenario") -> Scenario:
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        lines = []
        for err in exc.errors():
            where = _field_path(_as_written(tuple(err["loc"]), data))
            msg = err["msg"].removeprefix("Value error, ")
            lines.append(f"{where}: {msg}" if where else msg)
        raise ScenarioError(f"{origin}: invalid scenario\n  " + "\n  ".join(lines)) from None


def load_scenario(ref: str, overrides: Sequence[str] = (), seed: int | None = None) -> Scenario:
    data = load_raw(ref)
    for assignment in overrides:
        apply_override(data, assignment)
    if seed is not None:
        data["seed"] = seed
    return validate(data, ref)
