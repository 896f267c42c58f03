"""What each command loads, at run time, in a fresh interpreter (issue 38): a UAV's own process (``swarmtrack agent``)
and ``swarmtrack replay`` load their stack and nothing of the world; validating a scenario loads none of the
simulator's code, numba or scipy.

The AST import checks (tests/test_architecture.py, tests/sim/test_boundary.py) cannot see the registry's
``"module:attribute"`` strings or imports inside functions: here the code is run and ``sys.modules`` read after.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

#: The truth side, which a UAV's process and a replay must never load.
WORLD = ("swarmtrack.sim.world", "swarmtrack.sim.sensors", "swarmtrack.sim.oracle", "swarmtrack.sim.engine",
         "swarmtrack.sim.batch", "swarmtrack.sim.build", "swarmtrack.analysis")
#: A capability's truth side and analysis (its ``world``, ``metrics`` and ``figures`` modules).
CAPABILITY_WORLD = (".world", ".metrics", ".figures")
#: What validating a scenario loads of the packages that run: the plain data its settings check against, and the
#: log readers' registration record (LogFormat).
SETTINGS_DATA = {"swarmtrack.control", "swarmtrack.control.gains", "swarmtrack.control.identification",
                 "swarmtrack.network", "swarmtrack.network.delays", "swarmtrack.replay", "swarmtrack.replay.formats"}
#: A scenario of every estimator and controller kind the agent builds (the IMM, the multi-model team, the MPC, the
#: set-membership pair, the static controller) and the 3-D sensor.
AGENT_SCENARIOS = ("l24-ct", "l24-imm", "l24-3d-ct", "w20-switching", "w20-mpc-formation", "ib21-fleet-6")


def _loaded(code: str) -> list[str]:
    """Run ``code`` in a fresh interpreter; the modules loaded after it (swarmtrack's, numba, scipy)."""
    code += ("\nimport json, sys\nprint(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in "
             "('swarmtrack', 'numba', 'scipy'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.splitlines()[-1])


def _world_side(loaded) -> list[str]:
    return [m for m in loaded if m.startswith(WORLD)
            or (m.startswith("swarmtrack.capabilities.") and m.endswith(CAPABILITY_WORLD))]


@pytest.mark.slow
def test_a_uav_process_loads_its_stack_and_nothing_of_the_world():
    # what `swarmtrack agent` imports, then its stack built and stepped (the warm-up) for every kind of stack
    loaded = _loaded(f"""
import swarmtrack.live.commands, swarmtrack.live.agent, swarmtrack.autopilot.link
from swarmtrack.live.agent import build_onboard
from swarmtrack.onboard.context import sensor_labels
from swarmtrack.onboard.warm import warm_up
from swarmtrack.scenarios.loader import load_scenario
for name in {AGENT_SCENARIOS!r}:
    s = load_scenario(name)
    label_of = sensor_labels(s)
    warm_up(s, 0, label_of)
    labels = {{g: [label_of(g, m) for m in range(getattr(s, g).size())] for g in ("targets", "decoys")}}
    build_onboard(s, s.swarm.n_uavs - 1, labels)
""")
    assert {"swarmtrack.control.sm_mpc", "swarmtrack.estimation.multimodel", "swarmtrack.control.mpc"} <= set(loaded)
    assert not _world_side(loaded)


@pytest.mark.slow
def test_a_field_agent_loads_its_stack_its_sources_and_nothing_of_the_world():
    # what `swarmtrack agent --field` imports, its inputs placed and its stack built and stepped (the warm-up)
    loaded = _loaded("""
import swarmtrack.field.commands, swarmtrack.field.agent, swarmtrack.field.sources, swarmtrack.autopilot.link
from swarmtrack.field.inputs import FieldInputs
from swarmtrack.field.sources import parse, typestore
from swarmtrack.live.agent import build_onboard
from swarmtrack.onboard.context import labels_of, sensor_labels
from swarmtrack.onboard.warm import warm_up
from swarmtrack.replay.rosbag import Topics
from swarmtrack.scenarios.loader import load_scenario
parse("zenoh://a/b?type=geometry_msgs/msg/PointStamped")
for name in ("l24-ct", "w20-switching"):
    s = load_scenario(name)
    FieldInputs(s, 0, 0.0).detections(0.0)
    warm_up(s, 0, sensor_labels(s))
    build_onboard(s, 0, labels_of(s))
""")
    assert {"swarmtrack.field.agent", "swarmtrack.field.inputs", "swarmtrack.estimation.multimodel"} <= set(loaded)
    assert not _world_side(loaded)


@pytest.mark.slow
def test_a_replay_loads_its_stack_its_readers_and_nothing_of_the_world(tmp_path):
    folder = tmp_path / "run"
    subprocess.run([sys.executable, "-m", "swarmtrack", "run", "l24-cv", "--set", "duration=2", "--no-plots",
                    "--out", str(folder)], check=True, capture_output=True, timeout=300)
    csv = tmp_path / "flight.csv"  # 2 s of a flight: three UAVs at rest, UAV 1 sees the target 3 m north-east
    rows = [f"{t / 10},{u},navigation,{u},0" for t in range(21) for u in (1, 2, 3)]
    rows += [f"{t / 10},1,detection,2,3" for t in range(21)] + [f"{t / 10},,truth,3,3" for t in range(21)]
    csv.write_text("t,uav,kind,x,y\n" + "\n".join(rows) + "\n")
    loaded = _loaded(f"""
import swarmtrack.replay.commands
from swarmtrack.replay.engine import replay_logs
from swarmtrack.scenarios.loader import load_scenario
rec = replay_logs({str(folder)!r}, load_scenario({str(folder / "scenario.yaml")!r}))
assert rec.meta['n_steps'] > 0
rec = replay_logs({str(csv)!r}, load_scenario("l24-cv"))
assert rec.meta['n_steps'] > 0
""")
    assert {"swarmtrack.replay.run_folder", "swarmtrack.replay.csv_log", "swarmtrack.estimation.information"} \
        <= set(loaded)
    assert not _world_side(loaded)


@pytest.mark.slow
def test_validating_a_scenario_loads_no_simulator_code_numba_or_scipy():
    loaded = _loaded("""
from swarmtrack.cli import main
for name in ("l24-ct", "w20-mpc-formation", "ib21-fleet-6", "w20-switching"):
    main(["validate", name], standalone_mode=False)
""")
    onboard = [m for m in loaded if m.startswith(("swarmtrack.sim", "swarmtrack.estimation", "swarmtrack.control",
                                                  "swarmtrack.network", "swarmtrack.live", "swarmtrack.replay",
                                                  "swarmtrack.analysis", "numba", "scipy"))]
    assert set(onboard) <= SETTINGS_DATA, sorted(set(onboard) - SETTINGS_DATA)
    assert "swarmtrack.capabilities.mpc.settings" in loaded  # the check ran over the registered kinds


@pytest.mark.slow
def test_the_check_sees_the_world_where_it_is_loaded():
    # the same reading on `swarmtrack run`'s builder flags the world: the tests above can fail
    loaded = _loaded("from swarmtrack.sim.build import build\n"
                     "from swarmtrack.scenarios.loader import load_scenario\nbuild(load_scenario('l24-ct'))")
    assert "swarmtrack.sim.world" in _world_side(loaded)
    assert "swarmtrack.capabilities.tracking_swarm.world" in _world_side(loaded)
