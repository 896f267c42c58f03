"""Misses and clutter on the range-bearing-elevation sensor (issue 40 in 3-D): objects in view detected with the
probability asked, a Poisson number of unlabelled false detections uniform over the ball of max_range around each
UAV, stamped where the UAV's navigation put it, each drawn from streams of their own (the planar sensor's
``sensor/range_bearing/detection/...`` and ``sensor/range_bearing/clutter/uavs/<i>``) so that the true objects'
measurements are the same with or without them."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import stats

from swarmtrack.scenarios.loader import ScenarioError, load_scenario
from swarmtrack.sensors import elevation_bearing_range as ebr
from swarmtrack.sensors.detections import UNLABELLED
from swarmtrack.sim.batch import unbatchable
from swarmtrack.sim.build import truth_side

FRAMES = 400
MAX_RANGE = 50.0


def _world(overrides: list[str]):
    return truth_side(load_scenario("l24-3d-ct", [f"sensor.max_range={MAX_RANGE}", *overrides])).world


def _frames(overrides: list[str], world=None):
    """Every frame's detections and sources of l24-3d-ct's world (UAVs at rest, the target always in view)."""
    world = world or _world(overrides)
    n = world.groups["uavs"].size
    out = []
    for _ in range(FRAMES):
        out.append(world.sense())
        world.advance({"uavs": np.zeros((n, 2))}, 1)
    return out


def test_objects_in_view_are_detected_with_the_probability_asked_and_keep_their_labels():
    frames = _frames(["sensor.detection_probability=0.6"])
    detected = sum(len(det) for det, _ in frames)
    assert abs(detected / (3 * FRAMES) - 0.6) < 4 * np.sqrt(0.6 * 0.4 / (3 * FRAMES))  # 3 UAVs, one target in view
    assert all((det.label == 0).all() and (source == 0).all() for det, source in frames)


def test_clutter_is_poisson_with_the_rate_unlabelled_from_no_object_and_stamped_as_the_uavs_detections():
    frames = _frames(["sensor.clutter_rate=2.5"])
    counts = np.array([np.bincount(det.owner[det.label == UNLABELLED], minlength=3) for det, _ in frames]).ravel()
    assert abs(counts.mean() - 2.5) < 4 * np.sqrt(2.5 / counts.size)  # per UAV per scan
    assert counts.var() / counts.mean() == pytest.approx(1.0, abs=0.2)  # a Poisson count's dispersion
    for det, source in frames:
        false = det.label == UNLABELLED
        assert (source[false] == -1).all() and (source[~false] == 0).all()
        assert det.z.shape[1] == 3 and det.sensor_pos.shape[1] == 3
        for i in range(3):  # one navigation stamp per UAV and scan: the clutter's is its true detection's
            mine = det.sensor_pos[det.owner == i]
            np.testing.assert_array_equal(mine, np.broadcast_to(mine[0], mine.shape))


def test_clutter_is_uniform_over_the_ball_of_max_range():
    z = np.concatenate([det.z[source == -1] for det, source in _frames(["sensor.clutter_rate=3"])])
    offset = ebr.to_position(z, np.zeros(3))
    assert len(z) > 3000 and (np.linalg.norm(offset, axis=1) <= MAX_RANGE * (1 + 1e-12)).all()
    assert (np.abs(z[:, 1]) <= np.pi).all() and (np.abs(z[:, 2]) <= np.pi / 2).all()
    # uniform over the volume: (ρ/R)³, the bearing and sin ε each uniform, independent of one another
    for u in ((z[:, 0] / MAX_RANGE) ** 3, (np.pi - z[:, 1]) / (2 * np.pi), (np.sin(z[:, 2]) + 1) / 2):
        assert stats.kstest(u, "uniform").pvalue > 1e-3
    inner = np.linalg.norm(offset, axis=1) <= MAX_RANGE / 2
    assert inner.mean() == pytest.approx(1 / 8, abs=4 * np.sqrt(7 / 64 / len(z)))
    above = offset[:, 2] > 0
    assert above.mean() == pytest.approx(1 / 2, abs=4 * np.sqrt(1 / 4 / len(z)))


def test_the_true_objects_measurements_are_the_same_with_or_without_misses_and_clutter():
    clean = _frames([])
    noisy = _frames(["sensor.clutter_rate=3", "sensor.detection_probability=0.8"])
    for (a, _), (b, _) in zip(clean, noisy, strict=True):
        kept = b.label == 0
        for owner, z, pos in zip(b.owner[kept], b.z[kept], b.sensor_pos[kept], strict=True):
            np.testing.assert_array_equal(a.z[a.owner == owner][0], z)  # each kept detection is the clean one
            np.testing.assert_array_equal(a.sensor_pos[a.owner == owner][0], pos)


def test_an_unlabelled_sensor_gives_no_label_and_the_same_measurements():
    labelled = _frames(["sensor.clutter_rate=1"])
    world = _world(["sensor.clutter_rate=1"])
    world.sensor = dataclasses.replace(world.sensor, labelled=False)  # an estimator of labels refuses it (below)
    for (a, sa), (b, sb) in zip(labelled, _frames([], world), strict=True):
        assert (b.label == UNLABELLED).all()
        np.testing.assert_array_equal(a.z, b.z)
        np.testing.assert_array_equal(sa, sb)


def test_a_run_with_misses_and_clutter_is_not_batched():
    scenario = load_scenario("l24-3d-ct", [f"sensor.max_range={MAX_RANGE}", "sensor.clutter_rate=1"])
    assert unbatchable([scenario, scenario.model_copy(update={"seed": 2})]) is not None


@pytest.mark.parametrize(("override", "says"), [
    (["sensor.detection_probability=0"], "sensor.detection_probability"),
    (["sensor.detection_probability=1.5"], "sensor.detection_probability"),
    (["sensor.max_range=10", "sensor.clutter_rate=-1"], "sensor.clutter_rate"),
    (["sensor.max_range=10", "sensor.clutter_rate=1e5"], "sensor.clutter_rate"),
    (["sensor.clutter_rate=2"], "sensor.clutter_rate: .*give max_range too"),
    (["sensor.labelled=false"], "sensor.labelled"),
])
def test_bad_misses_and_clutter_are_refused_naming_the_field(override, says):
    with pytest.raises(ScenarioError, match=says):
        load_scenario("l24-3d-ct", override)
