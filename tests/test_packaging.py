from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "swarmtrack"


def test_every_source_folder_is_a_package_so_a_regular_install_ships_it():
    folders = {p.parent for p in SRC.rglob("*.py") if "__pycache__" not in p.parts}
    missing = sorted(str(f.relative_to(SRC)) for f in folders if not (f / "__init__.py").is_file())
    assert not missing, f"folders without __init__.py (left out of wheels): {missing}"
