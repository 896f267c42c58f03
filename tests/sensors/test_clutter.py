"""Misses and clutter on the range-bearing sensor (issue 40): objects in view detected with the probability asked,
a Poisson number of unlabelled false detections in each UAV's field of view, each drawn from streams of their own so
that the true objects' measurements are the same with or without them, and the seeds' runs unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from swarmtrack.scenarios.loader import ScenarioError, load_scenario
from swarmtrack.sensors.detections import UNLABELLED
from swarmtrack.sim.batch import unbatchable
from swarmtrack.sim.build import truth_side

FRAMES = 400


def _frames(overrides: list[str]):
    """Every frame's detections and sources of l24-ct's world (UAVs at rest), ``FRAMES`` of them."""
    world = truth_side(load_scenario("l24-ct", ["sensor.max_range=50", *overrides])).world
    n = world.groups["uavs"].size
    out = []
    for _ in range(FRAMES):
        out.append(world.sense())
        world.advance({"uavs": np.zeros((n, 2))}, 1)
    return out


def test_objects_in_view_are_detected_with_the_probability_asked_and_keep_their_labels():
    frames = _frames(["sensor.detection_probability=0.7"])
    detected = sum(len(det) for det, _ in frames)
    assert abs(detected / (3 * FRAMES) - 0.7) < 4 * np.sqrt(0.7 * 0.3 / (3 * FRAMES))  # 3 UAVs, one target in view
    assert all((det.label == 0).all() and (source == 0).all() for det, source in frames)


def test_clutter_is_poisson_unlabelled_from_no_object_and_inside_the_field_of_view():
    frames = _frames(["sensor.clutter_rate=2.5"])
    false = [(det, source) for det, source in frames]
    counts = np.array([(det.label == UNLABELLED).sum() for det, _ in false])
    mean = counts.mean() / 3  # per UAV per scan
    assert abs(mean - 2.5) < 4 * np.sqrt(2.5 / (3 * FRAMES))
    for det, source in false:
        clutter = det.label == UNLABELLED
        assert (source[clutter] == -1).all() and (source[~clutter] == 0).all()
        assert (det.z[clutter, 0] <= 50.0).all() and (det.z[clutter, 0] >= 0.0).all()
        assert (np.abs(det.z[clutter, 1]) <= np.pi).all()


def test_the_true_objects_measurements_are_the_same_with_or_without_misses_and_clutter():
    clean = _frames([])
    noisy = _frames(["sensor.clutter_rate=3", "sensor.detection_probability=0.8"])
    for (a, _), (b, _) in zip(clean, noisy, strict=True):
        kept = b.label == 0
        for owner, z in zip(b.owner[kept], b.z[kept], strict=True):  # each kept detection is the clean one
            np.testing.assert_array_equal(a.z[a.owner == owner][0], z)


def test_a_run_with_misses_and_clutter_is_not_batched():
    scenario = load_scenario("l24-ct", ["sensor.max_range=50", "sensor.clutter_rate=1"])
    assert unbatchable([scenario, scenario.model_copy(update={"seed": 2})]) == "misses and clutter are drawn per world"


@pytest.mark.parametrize(("override", "says"), [
    (["sensor.detection_probability=0"], "sensor.detection_probability"),
    (["sensor.detection_probability=1.5"], "sensor.detection_probability"),
    (["sensor.max_range=10", "sensor.clutter_rate=-1"], "sensor.clutter_rate"),
    (["sensor.clutter_rate=2"], "give max_range too"),
])
def test_bad_misses_and_clutter_are_refused_naming_the_field(override, says):
    with pytest.raises(ScenarioError, match=says):
        load_scenario("l24-ct", override)
