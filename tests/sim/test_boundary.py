"""The onboard boundary: onboard code never sees the world.

The onboard packages are walked (every module in them, found by :mod:`pkgutil`, so a new module is checked without
anyone adding it to a list) and imported in a fresh interpreter; what actually gets loaded (``sys.modules``) must hold
no truth-side module, so an import in any form (absolute, relative, inside a function run at import time, through a
package ``__init__``) is caught.
"""

import json
import subprocess
import sys

import pytest

#: Packages whose every module runs onboard (or is shared by the onboard code and the world, and so must not see it).
ONBOARD_PACKAGES = ("swarmtrack.onboard", "swarmtrack.estimation", "swarmtrack.control", "swarmtrack.models",
                    "swarmtrack.sensors", "swarmtrack.network")
#: Onboard modules in packages that also hold truth-side ones.
ONBOARD_MODULES = ("swarmtrack.sim.clock",)
TRUTH = ("swarmtrack.sim.world", "swarmtrack.sim.sensors", "swarmtrack.sim.build", "swarmtrack.sim.engine",
         "swarmtrack.sim.oracle", "swarmtrack.sim.batch", "swarmtrack.vehicles", "swarmtrack.scenarios",
         "swarmtrack.analysis", "swarmtrack.capabilities")


def _walk_and_import(packages, modules=(), extra_path: dict | None = None) -> tuple[list[str], set[str]]:
    """In a fresh interpreter: every module of ``packages`` (walked; ``extra_path`` adds a folder to a package's
    search path first) and ``modules`` imported; return the walked modules and everything loaded."""
    code = ("import importlib, json, pkgutil, sys\n"
            f"extra = {extra_path or {}!r}\n"
            "walked = []\n"
            f"for name in {list(packages)!r}:\n"
            "    pkg = importlib.import_module(name)\n"
            "    pkg.__path__.extend(extra.get(name, []))\n"
            "    walked += [m.name for m in pkgutil.walk_packages(pkg.__path__, name + '.')]\n"
            f"for m in walked + {list(modules)!r}: importlib.import_module(m)\n"
            "print(json.dumps([walked, sorted(m for m in sys.modules if m.startswith('swarmtrack'))]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    walked, loaded = json.loads(out.stdout)
    return walked, set(loaded)


def _loaded_after_importing(modules: list[str]) -> set[str]:
    return _walk_and_import((), modules)[1]


@pytest.mark.slow
def test_onboard_modules_never_load_the_world_the_vehicles_or_the_scenarios():
    walked, loaded = _walk_and_import(ONBOARD_PACKAGES, ONBOARD_MODULES)
    # modules a hand-kept list once missed are walked
    assert {"swarmtrack.onboard.stack", "swarmtrack.control.mpc", "swarmtrack.estimation.imm",
            "swarmtrack.estimation.gating", "swarmtrack.estimation.refilter",
            "swarmtrack.sensors.detections"} <= set(walked)
    leaked = sorted(m for m in loaded if m.startswith(TRUTH))
    assert not leaked, f"onboard code loads truth-side modules: {leaked}"


@pytest.mark.slow
def test_a_new_onboard_module_that_imports_the_world_is_found(tmp_path):
    # a module nobody listed, dropped into the estimation package's search path, is walked and caught
    (tmp_path / "intruder.py").write_text("from swarmtrack.sim.world import World\n")
    walked, loaded = _walk_and_import(ONBOARD_PACKAGES, extra_path={"swarmtrack.estimation": [str(tmp_path)]})
    assert "swarmtrack.estimation.intruder" in walked
    assert "swarmtrack.sim.world" in {m for m in loaded if m.startswith(TRUTH)}


@pytest.mark.slow
def test_the_check_sees_a_truth_side_import():
    # the same check on the engine must flag the world (it is allowed there): the test can fail
    loaded = _loaded_after_importing(["swarmtrack.sim.engine"])
    assert "swarmtrack.sim.world" in loaded and "swarmtrack.vehicles" in loaded


def test_models_never_load_the_simulator():
    loaded = _loaded_after_importing(["swarmtrack.models"])
    assert not any(m.startswith("swarmtrack.sim") for m in loaded)
