"""Many worlds per process: a batch of seeds gives each world the numbers it gets alone."""

import numpy as np
import pytest

from swarmtrack.analysis import reproduce
from swarmtrack.analysis.metrics import summary
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.batch import simulate_batch, unbatchable
from swarmtrack.sim.engine import simulate


def _numbers(summary: dict) -> dict:
    """A run's summary without the solvers' measured wall time (it differs from run to run)."""
    summary.get("formation", {}).get("solver", {}).pop("mean_solve_us", None)
    return summary


def _seeds(name: str, overrides: list[str], seeds=(1, 2, 3)):
    return [load_scenario(name, overrides, seed=s) for s in seeds]


@pytest.mark.slow
@pytest.mark.parametrize(("name", "overrides"), [
    ("l24-cv", ["duration=8"]),
    ("l24-ct", ["duration=6", "network.loss_probability=0.3"]),  # each world's losses from its own stream
    ("l23-no-fusion", ["duration=6"]),
    ("l24-fs", ["duration=4", "kernels=numpy"]),
    ("w20-switching", ["duration=5", "estimator.solo_steps=30"]),  # camera, multi-model T-test, compiled
    ("w20-switching", ["duration=4", "estimator.solo_steps=30", "estimator.fusion=imm", "kernels=numpy"]),
    ("l24-imm", ["duration=4"]),
    ("l24-imm", ["duration=4", "swarm.n_uavs=1"]),  # worlds of one UAV: its products are gemv's, as alone
    ("w20-mpc-single", ["duration=22"]),  # the truth oracle per world, one UAV's MPC from t = 20 s
    ("w20-mpc-formation-estimated", ["duration=21", "estimator.solo_steps=5"]),
])
def test_each_world_of_a_batch_equals_its_run_alone(name, overrides):
    scenarios = _seeds(name, overrides)
    for batched, s in zip(simulate_batch(scenarios), scenarios, strict=True):
        alone = simulate(s)
        np.testing.assert_array_equal(batched.estimate, alone.estimate)
        np.testing.assert_array_equal(batched.covariance, alone.covariance)
        np.testing.assert_array_equal(batched.uav, alone.uav)
        np.testing.assert_array_equal(batched.target, alone.target)
        assert batched.meta["seed"] == s.seed and batched.meta["tracked"] == alone.meta["tracked"]
        np.testing.assert_equal(_numbers(summary(batched)), _numbers(summary(alone)))


def test_a_uav_detects_only_its_own_worlds_objects():
    from swarmtrack.sim.batch import build_batch

    sim, metas = build_batch(_seeds("l24-cv", ["duration=2"]))
    det, source = sim.world.sense()
    uav_world = sim.world.world_of[sim.world.slices["uavs"]]
    assert len(source) == 3 * 3  # each of the 9 UAVs sees its own world's one target
    np.testing.assert_array_equal(sim.world.world_of[source], uav_world[det.owner])
    assert [m["groups"] for m in metas] == [{"targets": [0, 1], "decoys": [1, 1], "uavs": [1, 4]}] * 3


@pytest.mark.parametrize(("override", "why"), [
    ("estimator.kind=centralized", "estimator.kind 'centralized'"),
    ("sensor.occluders=[{window: [1, 2]}]", "occluders"),
])
def test_what_cannot_be_batched_says_why(override, why):
    assert why in unbatchable(_seeds("l24-cv", ["duration=2", override], seeds=(1, 2)))


def test_different_scenarios_are_not_one_batch():
    a, b = load_scenario("l24-cv", ["duration=2"], seed=1), load_scenario("l24-ct", ["duration=2"], seed=2)
    assert "differ in more than the seed" in unbatchable([a, b])
    with pytest.raises(ValueError, match="cannot batch"):
        simulate_batch([a, b])


def test_studies_group_seeds_into_batches_that_keep_every_worker_busy():
    runs = _seeds("l24-cv", ["duration=2"], seeds=range(1, 11)) + _seeds("w20-occlusion", ["duration=1"], (1, 2))
    got = reproduce.batches(runs, workers=2)
    assert sorted(k for b in got for k in b) == list(range(12))
    assert [len(b) for b in got if b[0] < 10] == [5, 5]  # ten seeds, two workers
    assert [b for b in got if b[0] >= 10] == [[10], [11]]  # occluders are not batched
    assert max(len(b) for b in reproduce.batches(runs[:10], workers=1)) == 10


def test_a_batch_that_diverges_is_run_again_world_by_world():
    bad = "estimator.q=[1.7e308, 1.7e308, 1.7e308, 1.7e308]"
    results = reproduce.run_batch(_seeds("l24-cv", ["duration=3", bad], seeds=(1, 2)))
    assert all("diverged" in r and "UAV" in r["diverged"] for r in results)
    good = reproduce.run_batch(_seeds("l24-cv", ["duration=3"], seeds=(1, 2)))
    assert good == [reproduce.run_one(s) for s in _seeds("l24-cv", ["duration=3"], seeds=(1, 2))]
