"""A UAV that dies does not void the run's numbers: with one of five agent processes killed mid-run, a lockstep and
a real-time ``live`` run report finite RMSE, NEES and mean error over the samples that came, name the lost UAV, and
do not say the swarm lost the target (issue 35)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import uuid

import pytest

from swarmtrack.live.commands import swarm_processes
from swarmtrack.live.node import LOST_AFTER
from swarmtrack.live.transport import free_port

pytestmark = pytest.mark.xdist_group("live-2")  # beside the "live" group (tests/live/test_lockstep.py)


def _agents(swarm: str, uav: int) -> list[int]:
    return [int(line.split()[0]) for line in swarm_processes(swarm) if "agent" in line and f"--uav {uav} " in line]


@pytest.mark.slow
@pytest.mark.parametrize("clock", [[], ["--realtime"]], ids=["lockstep", "realtime"])
def test_a_uav_killed_mid_run_leaves_finite_numbers_over_the_samples_that_came(tmp_path, peer, clock):
    port, swarm = free_port(), f"test-{uuid.uuid4().hex[:8]}"
    world = subprocess.Popen([sys.executable, "-m", "swarmtrack", "live", "l24-ct", "--insecure", "--no-plots",
                              "--out", str(tmp_path / "live"), "--swarm", swarm, "--listen", f"tcp/127.0.0.1:{port}",
                              *clock, "--set", "duration=15", "--set", "swarm.n_uavs=5"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert peer.flown(port, swarm, 2, 60) >= 60  # UAV 3 has shared 3 s of steps
        (victim,) = _agents(swarm, 3)
        os.kill(victim, 9)
        _, err = world.communicate(timeout=240)
    finally:
        if world.poll() is None:
            world.kill()
        for pid in _agents(swarm, 1) + _agents(swarm, 2) + _agents(swarm, 4) + _agents(swarm, 5):
            os.kill(pid, 9)
    assert world.returncode == 0, err[-3000:]
    out = json.loads((tmp_path / "live" / "metrics.json").read_text())
    assert all(math.isfinite(v) for v in out["rmse"]["total"].values()), out["rmse"]
    assert math.isfinite(out["nees"]) and math.isfinite(out["mean_error"]["all"])
    assert out["position_rmse_per_uav"][2] is not None  # its samples before it died count
    coverage = out["coverage"]
    assert coverage["per_uav"][2] < 1 - (LOST_AFTER + 1) / 15 and min(coverage["per_uav"][:2]) > 0.5
    kinds = [w.get("kind") for w in out["warnings"]]
    assert "lost_target" not in kinds, out["warnings"]
    assert any(w.get("kind") == "absent_samples" and w.get("uav") == 3 for w in out["warnings"])
    assert "UAV 3 stopped answering" in err
    assert out["live"]["lost"][0]["uav"] == 3 and isinstance(out["live"]["rejected"], dict)
