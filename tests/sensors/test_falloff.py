"""A detection probability falling with the distance (sensor.detection_falloff): ``Pd · (1 − falloff · d)`` with ``d``
the range over max_range (range_bearing) or the Chebyshev distance over half_width (position), 0 outside the view;
the settings' ``detection_probability_at`` says the law the world senses with, and the true objects' measurements
are the same with or without it."""

from __future__ import annotations

import numpy as np
import pytest

from swarmtrack.capabilities.multi_target.world import position
from swarmtrack.capabilities.tracking_swarm.world import range_bearing
from swarmtrack.scenarios.loader import ScenarioError, load_scenario
from swarmtrack.sim.batch import unbatchable
from swarmtrack.sim.build import truth_side

SCANS = 4000


class _Scene:
    """A frame of one UAV at the origin and objects at fixed positions, every draw from one generator: what a
    sensor reads of a :class:`~swarmtrack.sim.sensors.Scene`, with the geometry chosen."""

    t, worlds, taken = 0.0, 1, 0.0

    def __init__(self, objects: np.ndarray, rng: np.random.Generator):
        self.objects, self.uavs, self._rng = objects, np.zeros((1, 2)), rng

    def stamped(self) -> np.ndarray:
        return self.uavs.copy()

    def normal(self) -> np.ndarray:
        return self._rng.standard_normal((1, len(self.objects), 2))

    def extra_uniform(self, purpose: str) -> np.ndarray:
        return self._rng.random((1, len(self.objects)))

    def uav_streams(self, purpose: str) -> list:
        return [self._rng]


#: (scenario, overrides, the sensor's truth side from its settings, objects relative to the UAV, the law there)
LAWS = {
    "range_bearing": ("l24-ct", ["sensor.max_range=100", "sensor.detection_probability=0.9",
                                 "sensor.detection_falloff=0.6"], range_bearing,
                      # ranges 0, 25, 50, 90, 100 (the edge) and 101 (outside)
                      [(0.0, 0.0), (0.0, 25.0), (30.0, -40.0), (-54.0, 72.0), (-100.0, 0.0), (0.0, -101.0)],
                      [0.9, 0.9 * (1 - 0.6 * 0.25), 0.9 * (1 - 0.6 * 0.5), 0.9 * (1 - 0.6 * 0.9), 0.9 * 0.4, 0.0]),
    "position": ("mtt-box-easy", ["sensor.half_width=60", "sensor.detection_probability=0.8",
                                  "sensor.detection_falloff=0.5", "sensor.clutter_rate=0"], position,
                 # Chebyshev distances 0, 30 (on the diagonal: Euclidean 42), 45, 60 (the corner) and outside
                 [(0.0, 0.0), (30.0, -30.0), (-15.0, 45.0), (60.0, -60.0), (60.5, 0.0), (-20.0, 61.0)],
                 [0.8, 0.8 * (1 - 0.5 * 0.5), 0.8 * (1 - 0.5 * 0.75), 0.8 * 0.5, 0.0, 0.0]),
}


@pytest.mark.parametrize("kind", sorted(LAWS))
def test_the_detection_rate_at_each_distance_is_the_laws_and_the_settings_say_it(kind):
    scenario_name, overrides, build, rel, law = LAWS[kind]
    scenario = load_scenario(scenario_name, overrides)
    sensor = build(scenario.sensor, scenario)
    objects = np.array(rel)
    np.testing.assert_allclose(scenario.sensor.detection_probability_at(objects), law, rtol=1e-12)
    scene, seen = _Scene(objects, np.random.default_rng(7)), np.zeros(len(objects))
    for _ in range(SCANS):
        _, source = sensor.sense(scene)
        seen += np.bincount(source, minlength=len(objects))
    p = np.asarray(law)
    assert (np.abs(seen / SCANS - p) <= 4 * np.sqrt(p * (1 - p) / SCANS) + 1e-12).all(), seen / SCANS


@pytest.mark.parametrize(("scenario_name", "overrides", "inside", "outside"), [
    ("l24-ct", ["sensor.max_range=50", "sensor.detection_probability=0.7", "sensor.detection_falloff=0.4"],
     {(0.0, 0.0): 0.7, (40.0, 30.0): 0.7 * 0.6, (-10.0, 0.0): 0.7 * 0.92}, [(50.01, 0.0), (-40.0, 30.1), (1e3, 1e3)]),
    ("mtt-box-easy", ["sensor.half_width=20", "sensor.detection_probability=0.9", "sensor.detection_falloff=0.25"],
     {(0.0, 0.0): 0.9, (20.0, 20.0): 0.9 * 0.75, (-5.0, 10.0): 0.9 * 0.875, (-20.0, 0.0): 0.9 * 0.75},
     [(20.01, 0.0), (0.0, -20.01), (-25.0, 25.0)]),
])
def test_detection_probability_at_is_zero_outside_the_view_and_the_law_inside(scenario_name, overrides, inside,
                                                                              outside):
    spec = load_scenario(scenario_name, overrides).sensor
    rel = np.array(list(inside))
    np.testing.assert_allclose(spec.detection_probability_at(rel), list(inside.values()), rtol=1e-12)
    np.testing.assert_array_equal(spec.detection_probability_at(np.array(outside)), 0.0)
    grid = np.stack(np.meshgrid(np.linspace(-80, 80, 33), np.linspace(-80, 80, 17)), axis=-1)  # (17, 33, 2)
    p = spec.detection_probability_at(grid)
    assert p.shape == (17, 33)
    view = np.abs(grid).max(axis=-1) <= spec.half_width if spec.kind == "position" else \
        np.hypot(grid[..., 0], grid[..., 1]) <= spec.max_range
    np.testing.assert_array_equal(p > 0, view)  # positive exactly over the field of view


@pytest.mark.parametrize(("scenario_name", "overrides"), [
    ("l24-ct", ["sensor.detection_probability=0.6"]),
    ("mtt-box-easy", ["sensor.half_width=null", "sensor.clutter_rate=0", "sensor.detection_probability=0.6"]),
])
def test_an_unbounded_view_detects_with_the_constant_probability_everywhere(scenario_name, overrides):
    spec = load_scenario(scenario_name, overrides).sensor
    np.testing.assert_array_equal(spec.detection_probability_at(np.array([[0.0, 0.0], [1e5, -1e5]])), 0.6)


def _frames(overrides: list[str]):
    """mtt-box-easy's world with 60 m footprints, UAVs at rest: every scan's detections, sources and truth."""
    world = truth_side(load_scenario("mtt-box-easy", ["sensor.half_width=60", "sensor.clutter_rate=0",
                                                      *overrides])).world
    out = []
    for _ in range(95):
        det, source = world.sense()
        out.append((det, source, world.truth().copy()))
        world.advance({"uavs": np.zeros((4, 2))}, 10)
    return out


def test_the_worlds_detections_follow_the_settings_law_at_every_distance():
    overrides = ["sensor.detection_probability=0.9", "sensor.detection_falloff=0.7"]
    spec = load_scenario("mtt-box-easy", ["sensor.half_width=60", "sensor.clutter_rate=0", *overrides]).sensor
    bins = np.array([0.0, 1 / 3, 2 / 3, 1.0 + 1e-9])
    expected, variance, observed, pairs = np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3)
    for det, source, truth in _frames(overrides):
        rel = truth[None, :10, :2] - truth[10:14, None, :2]  # (4 UAVs, 10 targets, 2)
        p = spec.detection_probability_at(rel)
        seen = np.zeros((4, 10), dtype=bool)
        seen[det.owner, source] = True
        assert not seen[p == 0].any()  # nothing outside the footprint
        which = np.digitize(np.abs(rel).max(axis=-1) / 60.0, bins) - 1
        for b in range(3):
            pick = (which == b) & (p > 0)
            expected[b] += p[pick].sum()
            variance[b] += (p[pick] * (1 - p[pick])).sum()
            observed[b] += seen[pick].sum()
            pairs[b] += pick.sum()
    assert (variance > 20).all()  # each distance is well sampled
    assert (np.abs(observed - expected) < 4 * np.sqrt(variance)).all(), (observed, expected)
    rate = observed / pairs
    assert rate[0] > rate[1] + 0.1 > rate[2] + 0.2  # the far ones are missed more


def test_the_true_objects_measurements_are_the_same_with_or_without_the_falloff():
    clean = _frames([])
    falling = _frames(["sensor.detection_falloff=0.8"])
    kept = 0
    for (a, sa, _), (b, sb, _) in zip(clean, falling, strict=True):
        for owner, s, z in zip(b.owner, sb, b.z, strict=True):  # each kept detection is the clean one
            np.testing.assert_array_equal(a.z[(a.owner == owner) & (sa == s)][0], z)
        kept += len(b)
        assert len(b) <= len(a)
    assert 0 < kept < sum(len(a) for a, _, _ in clean)


def test_a_run_whose_detection_probability_falls_is_not_batched():
    scenario = load_scenario("l24-ct", ["sensor.max_range=50", "sensor.detection_falloff=0.3"])
    assert unbatchable([scenario, scenario.model_copy(update={"seed": 2})]) == "misses and clutter are drawn per world"


@pytest.mark.parametrize(("scenario_name", "override", "says"), [
    ("l24-ct", ["sensor.max_range=50", "sensor.detection_falloff=1"], "sensor.detection_falloff"),
    ("l24-ct", ["sensor.max_range=50", "sensor.detection_falloff=-0.1"], "sensor.detection_falloff"),
    ("l24-ct", ["sensor.detection_falloff=0.5"], "sensor.detection_falloff: .* give max_range too"),
    ("mtt-box-easy", ["sensor.detection_falloff=1.2"], "sensor.detection_falloff"),
    ("mtt-box-easy", ["sensor.half_width=null", "sensor.clutter_rate=0", "sensor.detection_falloff=0.5"],
     "sensor.detection_falloff: .* give half_width too"),
])
def test_bad_falloffs_are_refused_naming_the_field(scenario_name, override, says):
    with pytest.raises(ScenarioError, match=says):
        load_scenario(scenario_name, override)
