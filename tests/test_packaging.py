import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "swarmtrack"


def test_every_source_folder_is_a_package_so_a_regular_install_ships_it():
    folders = {p.parent for p in SRC.rglob("*.py") if "__pycache__" not in p.parts}
    missing = sorted(str(f.relative_to(SRC)) for f in folders if not (f / "__init__.py").is_file())
    assert not missing, f"folders without __init__.py (left out of wheels): {missing}"


def test_the_source_version_is_the_packaged_one():
    """Cache keys read ``swarmtrack.__version__``: it must be the version pyproject.toml builds."""
    import tomllib

    import swarmtrack

    project = tomllib.loads((SRC.parents[1] / "pyproject.toml").read_text())["project"]
    assert swarmtrack.__version__ == project["version"]


BENCHMARKS = sorted((SRC.parents[1] / "benchmarks").glob("*.py"))


@pytest.mark.slow
@pytest.mark.parametrize("script", BENCHMARKS, ids=[p.stem for p in BENCHMARKS])
def test_every_benchmark_still_imports_what_it_measures(script):
    """A benchmark imports the package's names at its top: one that a refactor moved fails here, not months later in
    ``make bench``."""
    res = subprocess.run([sys.executable, str(script), "--help"], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr[-2000:]
