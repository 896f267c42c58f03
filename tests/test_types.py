"""The type check (issue 38): mypy over ``src/swarmtrack`` with pyproject.toml's ``[tool.mypy]`` settings, which
include :mod:`swarmtrack.conformance` (every implementation assigned to its protocol); and its burn-down list (the
modules whose errors are still ignored) names only modules that exist."""

from __future__ import annotations

import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"


def _mypy_config() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]


def burn_down() -> list[str]:
    """The modules of the ``ignore_errors`` overrides: the burn-down list."""
    out: list[str] = []
    for override in _mypy_config().get("overrides", []):
        if override.get("ignore_errors"):
            modules = override["module"]
            out += [modules] if isinstance(modules, str) else modules
    return out


def _source(module: str) -> Path | None:
    """The file of a ``swarmtrack`` module (a module file or a package's ``__init__.py``), or None."""
    base = SRC.joinpath(*module.split("."))
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def test_the_burn_down_list_names_only_modules_that_exist_once_each():
    modules = burn_down()
    assert all(m.startswith("swarmtrack.") and "*" not in m for m in modules), \
        "the burn-down list names single swarmtrack modules, no patterns"
    missing = [m for m in modules if _source(m) is None]
    assert not missing, f"pyproject.toml's mypy burn-down list names modules that do not exist: {missing}"
    assert len(modules) == len(set(modules)), "a module is named twice in the burn-down list"


def test_the_type_check_covers_the_package_and_its_conformance_module():
    config = _mypy_config()
    assert config["files"] == ["src/swarmtrack"]
    assert _source("swarmtrack.conformance") is not None
    assert "swarmtrack.conformance" not in burn_down()


@pytest.mark.slow
def test_mypy_finds_no_error_in_the_package():
    """mypy from cold, as on a fresh clone: its cache is not written (``--cache-dir /dev/null``), which a run that
    starts from none cannot use anyway."""
    start = time.perf_counter()
    try:
        done = subprocess.run([sys.executable, "-m", "mypy", "--config-file", str(ROOT / "pyproject.toml"),
                               "--cache-dir", "/dev/null"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"mypy took over 300 s: {exc.stdout}{exc.stderr}")
    report = done.stdout + done.stderr
    if done.returncode != 0 and "No module named mypy" in report:
        pytest.fail("mypy is not installed: pip install -e '.[dev]'")
    assert done.returncode == 0, f"mypy found errors (in {time.perf_counter() - start:.0f} s):\n{report}"
