"""The onboard boundary: onboard code never sees the world.

Checked in a fresh interpreter by what actually gets imported (``sys.modules``), so an import in any form
(absolute, relative, inside a function run at import time, through a package ``__init__``) is caught.
"""

import json
import subprocess
import sys

ONBOARD = [
    "swarmtrack.sim.agent",
    "swarmtrack.estimation.base",
    "swarmtrack.estimation.information",
    "swarmtrack.estimation.kalman",
    "swarmtrack.estimation.kernels",
    "swarmtrack.estimation.multimodel",
    "swarmtrack.estimation.fusion",
    "swarmtrack.estimation.measurements",
    "swarmtrack.estimation.polygons",
    "swarmtrack.estimation.raster",
    "swarmtrack.estimation.setmembership",
    "swarmtrack.estimation.setmembership_raster",
    "swarmtrack.control.base",
    "swarmtrack.control.flocking",
    "swarmtrack.control.kernels",
    "swarmtrack.control.static",
    "swarmtrack.control.position",
    "swarmtrack.control.identification",
    "swarmtrack.control.sm_mpc",
    "swarmtrack.control.sm_mpc_raster",
    "swarmtrack.models",
    "swarmtrack.sensors.detections",
    "swarmtrack.sensors.footprint",
    "swarmtrack.network.messages",
]
TRUTH = ("swarmtrack.sim.world", "swarmtrack.sim.build", "swarmtrack.sim.engine", "swarmtrack.sim.oracle",
         "swarmtrack.vehicles", "swarmtrack.scenarios", "swarmtrack.analysis")


def _loaded_after_importing(modules: list[str]) -> set[str]:
    code = ("import importlib, json, sys\n"
            f"for m in {modules!r}: importlib.import_module(m)\n"
            "print(json.dumps(sorted(m for m in sys.modules if m.startswith('swarmtrack'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return set(json.loads(out.stdout))


def test_onboard_modules_never_load_the_world_the_vehicles_or_the_scenarios():
    loaded = _loaded_after_importing(ONBOARD)
    assert set(ONBOARD) <= loaded
    leaked = sorted(m for m in loaded if m.startswith(TRUTH))
    assert not leaked, f"onboard code loads truth-side modules: {leaked}"


def test_the_check_sees_a_truth_side_import():
    # the same check on the engine must flag the world (it is allowed there): the test can fail
    loaded = _loaded_after_importing(["swarmtrack.sim.engine"])
    assert "swarmtrack.sim.world" in loaded and "swarmtrack.vehicles" in loaded


def test_models_never_load_the_simulator():
    loaded = _loaded_after_importing(["swarmtrack.models"])
    assert not any(m.startswith("swarmtrack.sim") for m in loaded)
