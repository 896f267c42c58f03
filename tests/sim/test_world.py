"""A world of vehicle groups: several targets with their own profiles, decoys, and UAVs in one run."""

import numpy as np
import pytest

from swarmtrack.analysis.metrics import rmse_table
from swarmtrack.scenarios.loader import load_raw, validate
from swarmtrack.sim.build import build
from swarmtrack.sim.engine import simulate

TWO_TARGETS = {
    "vehicle": "quadrotor", "wind_std": 0.0,
    "members": [
        {"profile": "l23", "start": [0.0, 0.0]},
        {"profile": "custom", "start": [12.0, 4.0],
         "phases": [{"name": "west", "duration": 20.0, "c": [-0.4, 0.1]},
                    {"name": "circle", "duration": 20.0, "amplitude": [1.0, 1.0], "omega": [0.3, 0.3],
                     "phi": [0.0, 1.5708]}]},
    ],
}
DECOYS = {"vehicle": "double_integrator", "wind_std": 0.0, "members": [{"profile": "hover", "start": [5.0, -5.0]},
                                                      {"profile": "l23", "start": [-8.0, 8.0]}]}


def _scenario(follow: int, **extra):
    data = load_raw("l24-cv")
    del data["target"]
    data.update({"targets": TWO_TARGETS, "decoys": DECOYS, "duration": 40.0, **extra})
    data["sensor"]["latency"] = 0.0
    data["estimator"]["target"] = follow
    return validate(data)


def test_two_targets_and_a_decoy_group_fly_their_own_profiles_in_one_world():
    scn = _scenario(follow=2)
    world = build(scn).world
    assert {name: (sl.stop - sl.start) for name, sl in world.slices.items()} == {"targets": 2, "decoys": 2, "uavs": 3}
    rec = simulate(scn)
    truth = np.concatenate([c.truth for c in rec.chunks()])  # (K, 7, 4): every object's truth
    t = rec.t
    targets = world.slices["targets"]
    for k, member in enumerate(scn.targets.members):
        expected = member.velocity_profile().position(t, start=member.start)  # the profile flown without wind
        flown = truth[:, targets.start + k, :2]
        # the autopilot's lag only (it builds up at the custom profile's velocity jump between its phases)
        assert np.abs(flown - expected).max() < 1.0, k
    hover = truth[:, world.slices["decoys"].start, :2]
    assert np.abs(hover - [5.0, -5.0]).max() < 1e-9  # a hovering double integrator stays put
    assert not np.allclose(truth[-1, targets.start, :2], truth[-1, targets.start + 1, :2])


@pytest.mark.slow
def test_the_filter_follows_the_target_it_is_told_to_and_the_metrics_score_that_one():
    first, second = simulate(_scenario(follow=1)), simulate(_scenario(follow=2))
    assert first.tracked != second.tracked
    assert rmse_table(first)["total"]["x"] < 0.2 and rmse_table(second)["total"]["x"] < 0.2
    # the swarm chased the target its filter follows
    for rec in (first, second):
        dist = np.linalg.norm(rec.uav[-1, :, :2] - rec.target[-1, :2], axis=1)
        assert dist.max() < 6.0


def test_detections_carry_labels_but_not_their_source():
    world = build(_scenario(follow=1)).world
    det, source = world.sense()
    assert len(det) == 3 * 4  # every UAV detects both targets and both decoys
    assert set(det.label.tolist()) == {0, 1, 2, 3}
    assert not hasattr(det, "source")
    assert sorted(set(source.tolist())) == [0, 1, 2, 3]  # world objects 0..3; the UAVs are 4..6


def test_a_frames_uniforms_are_each_objects_own_draws_frame_after_frame():
    """The world draws the footprint noise ``block`` frames at a time: the same numbers as each object's stream drawing
    its (N, 2) every frame, across the blocks, and a frame handed out is never written again."""
    from swarmtrack.sim.streams import stream
    from swarmtrack.sim.world import _Uniforms

    uniforms = _Uniforms([stream(5, f"sensor/footprint/targets/{j}") for j in range(3)], 4)
    own = [stream(5, f"sensor/footprint/targets/{j}") for j in range(3)]
    frames = [uniforms.frame() for _ in range(2 * uniforms.block + 3)]
    for frame in frames:
        np.testing.assert_array_equal(frame, np.stack([rng.random((4, 2)) for rng in own], axis=1))
    assert frames[0].shape == (4, 3, 2) and not np.shares_memory(frames[0], frames[-1])
