"""The Python examples of the guides run as written (in a temporary folder, so files they write go there)."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ["docs/tracking-swarm.md", "docs/multi-model.md", "README.md", "docs/scenarios.md", "docs/identification.md",
        "docs/mpc.md", "docs/python.md", "docs/stonesoup.md", "docs/replay.md"]


def python_blocks(path: Path) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", path.read_text(), re.S | re.M)


EXAMPLES = [pytest.param(code, id=f"{doc}#{k + 1}") for doc in DOCS for k, code in enumerate(python_blocks(ROOT / doc))]


def test_the_guide_has_python_examples():
    assert len(python_blocks(ROOT / "docs/tracking-swarm.md")) >= 2


@pytest.mark.slow
@pytest.mark.parametrize("code", EXAMPLES)
def test_python_example_runs(code, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "<doc example>", "exec"), {"__name__": "__doc_example__"})


def test_the_architecture_guide_names_every_registered_kind_and_only_files_that_exist():
    """docs/architecture.md describes the code as it is: its capability table lists exactly the registered kinds,
    and every source path it names exists."""
    from swarmtrack import registry

    text = (ROOT / "docs/architecture.md").read_text()
    table = text[text.index("| capability | kinds | paper |"):].split("\n\n")[0]
    listed = {(role, name) for role, names in re.findall(r"(sensors?|estimators?|controllers?) ([`\w, -]+)", table)
              for name in re.findall(r"`(\w+)`", names)}
    registered = {(role, name) for role in registry.ROLES for name in registry.kinds(role)}
    assert {(r.rstrip("s"), n) for r, n in listed} == registered
    src = ROOT / "src/swarmtrack"
    paths = set(re.findall(r"`((?:[a-z_]+/)+[a-z_]+\.py)", text))  # a path inside the package (dir/file.py)
    missing = sorted(p for p in paths if not (src / p).exists() and not (ROOT / p).exists()
                     and "<" not in p and not p.startswith("tests/"))
    assert not missing, f"docs/architecture.md names files that do not exist: {missing}"
