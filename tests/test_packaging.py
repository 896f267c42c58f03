from pathlib import Path

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
