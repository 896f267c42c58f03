"""The Python examples of the guides run as written (in a temporary folder, so files they write go there)."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ["docs/tracking-swarm.md", "docs/multi-model.md", "README.md", "docs/scenarios.md", "docs/identification.md",
        "docs/mpc.md", "docs/python.md"]


def python_blocks(path: Path) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", path.read_text(), re.S | re.M)


EXAMPLES = [pytest.param(code, id=f"{doc}#{k + 1}") for doc in DOCS for k, code in enumerate(python_blocks(ROOT / doc))]


def test_the_guide_has_python_examples():
    assert len(python_blocks(ROOT / "docs/tracking-swarm.md")) >= 2


@pytest.mark.parametrize("code", EXAMPLES)
def test_python_example_runs(code, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "<doc example>", "exec"), {"__name__": "__doc_example__"})
