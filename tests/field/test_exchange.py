"""Who a field UAV fuses and waits for: its neighbours in the scenario's topology that it has heard lately; beacons
from every UAV heard; and a run named by its scenario and start, so another swarm's messages are not taken."""

from __future__ import annotations

import time

import pytest

from swarmtrack.field.exchange import FieldExchange, field_run, neighbours
from swarmtrack.live.node import LOST_AFTER
from swarmtrack.scenarios.loader import load_scenario


@pytest.mark.parametrize(("topology", "expected"), [
    ("line", [[1], [0, 2], [1]]), ("full", [[1, 2], [0, 2], [0, 1]]), ("none", [[], [], []]),
    ("proximity", [[1, 2], [0, 2], [0, 1]]),  # the real radio's range decides
])
def test_a_uav_fuses_its_neighbours_in_the_scenarios_topology(topology, expected):
    scn = load_scenario("l24-ct", [f"network.topology={topology}"])
    assert [neighbours(scn, i) for i in range(3)] == expected


class _Node:
    def __init__(self, seen):
        self.seen, self.absent = seen, set()


def test_only_the_uavs_heard_lately_are_waited_for_and_beacons_come_from_every_one_heard():
    now = time.monotonic()
    node = _Node({0: now, 2: now - LOST_AFTER - 1, 3: now})  # UAV 3 (0-based 2) silent, UAV 4 heard
    exchange = FieldExchange(node, 1, 4, 0, peers=[0, 2], epoch=100.0)  # a line: neighbours 0 and 2
    exchange.step(7, 0, 0.35, 0.05, None)
    assert exchange.radio.parts == [(7, [0])] and exchange.radio.links == [0]
    assert exchange.radio.beacons == [0, 3]
    assert node.absent == {2} and exchange.due == pytest.approx(100.35)


def test_a_field_run_is_named_by_its_resolved_scenario_and_its_start():
    assert field_run("abc", 1.0) == field_run("abc", 1.0)
    assert len({field_run("abc", 1.0), field_run("abd", 1.0), field_run("abc", 1.5)}) == 3
