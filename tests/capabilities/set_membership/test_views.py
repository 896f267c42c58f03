"""What a live view draws of IB21's estimator: each UAV's unidentified and identified sets, outline by outline."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from swarmtrack.capabilities.set_membership.views import shapes
from swarmtrack.scenarios.loader import load_scenario
from swarmtrack.sim.engine import simulate


class Keep:
    """A tap that keeps what it is sent."""

    def __init__(self):
        self.frames = []

    def open(self, meta):
        pass

    def send(self, frame):
        self.frames.append(frame)

    def close(self):
        pass


def test_the_outlines_are_each_uavs_sets_and_nothing_else():
    from swarmtrack.sim.build import build

    sim = build(load_scenario("ib21-fleet-2", ["duration=1"]))
    b = sim.stack.estimator.beliefs
    b.unidentified[1] = shapely.box(0, 0, 10, 20)
    b.identified[0, 0] = shapely.MultiPolygon([shapely.box(1, 1, 2, 2), shapely.box(5, 5, 6, 6)])
    drawn = shapes(sim.stack.estimator)
    assert sorted(uav for uav, _ in drawn) == [1, 1, 2]
    for _, vertices in drawn:
        assert vertices.shape[1] == 2 and np.array_equal(vertices[0], vertices[-1])  # a closed ring in the plane
    assert shapely.Polygon(drawn[-1][1]).equals(shapely.box(0, 0, 10, 20))


@pytest.mark.parametrize("sets", ["polygons", "raster"])
def test_a_run_with_taps_hands_them_its_sets_as_they_grow(sets):
    keep = Keep()
    simulate(load_scenario("ib21-fleet-2", ["duration=40", f"estimator.sets={sets}"]), taps=[keep])
    drawn = [f.polygons for f in keep.frames]
    assert not drawn[0] and any(drawn)  # nothing is known at the start; the targets' sets come
    uavs = {uav for polygons in drawn for uav, _ in polygons}
    assert uavs <= {1, 2} and uavs
