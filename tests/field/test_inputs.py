"""A field agent's inputs on its clock: navigation interpolated at a step's time, the step's detection made the
sensor's measurement at its stamp, and every message that cannot be used skipped, counted by cause and topic."""

from __future__ import annotations

import numpy as np
import pytest

from swarmtrack.field.inputs import FieldInputs
from swarmtrack.replay.grid import Detection, Navigation, Truth
from swarmtrack.replay.steps import LogError
from swarmtrack.scenarios.loader import load_scenario
from swarmtrack.sensors import camera, range_bearing

EPOCH = 1.8e9  # the swarm's t = 0, s since the Unix epoch


@pytest.fixture(scope="module")
def l24():
    return load_scenario("l24-ct", ["duration=2"])


def _nav(stamp, x, y, vx=1.0, vy=0.0):
    return Navigation("/uav_1/pose", 0, EPOCH + stamp, (x, y), (vx, vy))


def test_the_steps_navigation_is_interpolated_and_held_for_the_window_only(l24):
    inputs = FieldInputs(l24, 0, EPOCH, window=0.5)
    inputs.put(_nav(0.0, 0.0, 0.0))
    inputs.put(_nav(0.1, 0.1, 0.0))
    assert inputs.navigation(0.05) == pytest.approx(np.array([[0.05, 0.0, 1.0, 0.0]]))
    assert inputs.navigation(0.5) == pytest.approx(np.array([[0.1, 0.0, 1.0, 0.0]]))  # held
    assert inputs.navigation(0.7) is None  # more than the window after the last sample
    assert inputs.navigation(-0.1) is None  # before the first


def test_a_detection_becomes_the_sensors_measurement_taken_where_the_uav_was_at_its_stamp(l24):
    inputs = FieldInputs(l24, 0, EPOCH)
    inputs.put(_nav(0.0, 0.0, 0.0))
    inputs.put(_nav(0.1, 0.1, 0.0))
    inputs.put(Detection("/uav_1/target", 0, EPOCH + 0.05, relative=(3.0, 4.0)))
    det = inputs.detections(0.1)
    assert det.sensor_pos == pytest.approx(np.array([[0.05, 0.0]]))
    z, _ = range_bearing.of_relative(np.array([[3.0, 4.0]]), det.sensor_pos)
    np.testing.assert_array_equal(det.z, z)
    assert det.taken == pytest.approx(0.05) and det.owner.tolist() == [0] and det.n_uavs == 1
    assert len(inputs.detections(0.15)) == 0  # taken once
    assert inputs.counts == {}


def test_a_camera_detection_carries_its_frame_and_no_detection_an_empty_one():
    w20 = load_scenario("w20-switching", ["duration=2"])
    inputs = FieldInputs(w20, 1, EPOCH)
    empty = inputs.detections(0.0)
    assert len(empty) == 0 and empty.frame.shape == (0, 2, 3)
    inputs.put(Navigation("/uav_2/pose", 1, EPOCH, (1.0, 2.0), (0.0, 0.0)))
    inputs.put(Detection("/uav_2/target", 1, EPOCH, relative=(0.5, -0.25)))
    det = inputs.detections(0.0)
    z, frame = camera.of_relative(np.array([[0.5, -0.25]]), np.array([[1.0, 2.0]]))
    np.testing.assert_array_equal(det.z, z)
    np.testing.assert_array_equal(det.frame, frame)


def test_unusable_messages_are_skipped_and_counted_by_cause_and_topic(l24):
    inputs = FieldInputs(l24, 0, EPOCH, window=0.5)
    inputs.put(_nav(1.0, 0.0, 0.0))
    inputs.put(_nav(0.9, 0.0, 0.0))  # its topic's clock went backwards
    inputs.put(_nav(1.1, float("nan"), 0.0))
    inputs.put(Detection("/uav_1/target", 0, EPOCH + 0.1, relative=(1.0, 0.0)))  # older than the window
    inputs.put(Detection("/uav_1/target", 0, EPOCH + 0.95, relative=(1.0, 0.0)))  # before its navigation
    inputs.put(Detection("/uav_1/target", 0, EPOCH + 1.0, relative=(1.0, 0.0)))
    inputs.put(Detection("/uav_1/target", 0, EPOCH + 1.02, relative=(2.0, 0.0)))  # a second one: the latest is used
    det = inputs.detections(1.05)
    assert det.z[0, 0] == pytest.approx(2.0)
    assert inputs.counts == {
        "stamped before an earlier message of its topic on /uav_1/pose": 1,
        "NaN or infinite value in a message on /uav_1/pose": 1,
        "stamped more than the window before its step on /uav_1/target": 1,
        "detection with no navigation of its UAV at its time on /uav_1/target": 1,
        "a frame that came after its step, superseded by the next on /uav_1/target": 1}


def test_what_was_stamped_before_the_uavs_first_step_is_dropped_uncounted(l24):
    inputs = FieldInputs(l24, 0, EPOCH, window=0.5)
    inputs.put(_nav(4.8, 0.0, 0.0))
    inputs.put(Detection("/uav_1/target", 0, EPOCH + 4.9, relative=(1.0, 0.0)))  # a backlog: before its start
    inputs.begin(5.0)
    inputs.put(_nav(4.2, 0.0, 0.0))  # more than the window before its first step
    inputs.put(Detection("/uav_1/target", 0, EPOCH + 4.95, relative=(1.0, 0.0)))  # a frame from before it ran
    inputs.put(_nav(5.0, 0.2, 0.0))
    assert len(inputs.detections(5.0)) == 0 and inputs.counts == {}
    assert inputs.navigation(5.0)[0, 0] == pytest.approx(0.2)


def test_truth_is_interpolated_between_close_samples_and_absent_across_a_gap(l24):
    inputs = FieldInputs(l24, None, EPOCH, truth_gap=1.0)
    for stamp, x in ((0.0, 0.0), (0.5, 0.5), (3.0, 3.0)):
        inputs.put(Truth("/target", EPOCH + stamp, (x, 0.0)))
    assert inputs.truth_at(0.25)[0] == pytest.approx(0.25)
    assert inputs.truth_at(0.5)[0] == pytest.approx(0.5)  # on a sample
    assert inputs.truth_at(1.0) is None  # between samples 2.5 s apart
    assert inputs.truth_at(-0.1) is None


def test_a_sensor_the_field_cannot_place_is_refused():
    ib21 = load_scenario("ib21-fleet-2", ["duration=2"])
    with pytest.raises(LogError, match="sensor.kind footprint: the field makes camera, position, range_bearing "
                                       "measurements"):
        FieldInputs(ib21, 0, EPOCH)
