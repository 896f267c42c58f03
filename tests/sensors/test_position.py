"""The planar position sensor (issue 40): unlabelled relative positions of the objects in the UAV's footprint, with
the noise asked, misses and clutter over the footprint; its detections are linear measurements of the positions."""

import numpy as np
import pytest

from swarmtrack.scenarios.loader import ScenarioError, load_scenario
from swarmtrack.sensors import position
from swarmtrack.sensors.detections import UNLABELLED
from swarmtrack.sim.build import truth_side

FRAMES = 95  # the run is 100 s long: the world is sampled that far


def _frames(overrides: list[str]):
    world = truth_side(load_scenario("mtt-box-easy", overrides)).world
    out = []
    for _ in range(FRAMES):
        det, source = world.sense()
        out.append((det, source, world.truth().copy()))
        world.advance({"uavs": np.zeros((4, 2))}, 10)
    return out


def test_detections_are_unlabelled_relative_positions_with_the_noise_asked():
    frames = _frames(["sensor.detection_probability=1", "sensor.clutter_rate=0", "sensor.sigma=0.5"])
    errors = []
    for det, source, truth in frames:
        assert (det.label == UNLABELLED).all() and (source >= 0).all()
        assert len(det) == 4 * 10  # every UAV sees every target in the box
        p, R = position.positions(det, 0.5)
        errors.append(p - truth[source, :2])
        np.testing.assert_array_equal(R[:, 0, 0], 0.25)
    e = np.concatenate(errors)
    assert np.std(e, axis=0) == pytest.approx([0.5, 0.5], rel=0.05)
    assert np.abs(e.mean(axis=0)).max() < 0.05


def test_misses_and_clutter_inside_the_footprint():
    frames = _frames(["sensor.half_width=60", "sensor.clutter_rate=3", "sensor.detection_probability=0.8"])
    true_seen = in_view = false = 0
    for det, source, truth in frames:
        clutter = source == -1
        false += clutter.sum()
        assert (np.abs(det.z[clutter]) <= 60.0).all()
        rel = truth[None, :10, :2] - truth[10:14, None, :2]
        in_view += (np.abs(rel) <= 60.0).all(axis=-1).sum()
        true_seen += (~clutter).sum()
    assert abs(true_seen / in_view - 0.8) < 4 * np.sqrt(0.16 / in_view)
    assert abs(false / (4 * FRAMES) - 3.0) < 4 * np.sqrt(3.0 / (4 * FRAMES))


@pytest.mark.parametrize(("override", "says"), [
    (["sensor.detection_probability=0"], "sensor.detection_probability"),
    (["sensor.detection_probability=1.01"], "sensor.detection_probability"),
    (["sensor.clutter_rate=-0.5"], "sensor.clutter_rate"),
    (["sensor.half_width=null"], "give half_width too"),
])
def test_bad_values_are_refused_naming_the_field(override, says):
    with pytest.raises(ScenarioError, match=says):
        load_scenario("mtt-box-easy", override)


def test_a_frames_true_and_false_detections_carry_one_stamp_per_uav():
    """The navigation error is drawn once per frame: a UAV's clutter is stamped where its true detections are."""
    frames = _frames(["swarm.nav_position_std=0.5", "sensor.half_width=60", "sensor.clutter_rate=3"])
    for det, _source, _ in frames:
        for i in range(4):
            stamps = det.sensor_pos[det.owner == i]
            assert len(stamps) == 0 or (stamps == stamps[0]).all()
