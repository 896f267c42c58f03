"""The onboard step (:mod:`swarmtrack.onboard.stack`): one order for every driver, broadcast before fuse."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from swarmtrack import registry
from swarmtrack.onboard.stack import OnboardStack
from swarmtrack.scenarios import builtin_names, load_scenario
from swarmtrack.sim.engine import simulate


@functools.cache
def _scenario_of_each_controller() -> dict[str, str]:
    """A built-in scenario of each registered controller kind (the first by name; loading them all takes about 1 s,
    done when a test asks, not when the tests are collected)."""
    out: dict[str, str] = {}
    for name in builtin_names():
        out.setdefault(load_scenario(name).controller.kind, name)
    return out


def test_every_registered_controller_kind_has_a_built_in_scenario():
    assert set(_scenario_of_each_controller()) == set(registry.kinds("controller"))


@pytest.mark.slow
@pytest.mark.parametrize("kind", sorted(registry.kinds("controller")))
def test_broadcast_reads_no_estimator_state(monkeypatch, kind):
    """The control step that starts with an estimation step broadcasts before the estimator fuses (so that the live
    agent's beacon travels in its share message): a run whose broadcasts come after the estimation step instead, as
    they did before, records the same numbers bit for bit, for every controller kind."""
    scenario = load_scenario(_scenario_of_each_controller()[kind], ["duration=3"], seed=2)
    first = simulate(scenario)
    estimation_step = OnboardStack.estimation_step

    def broadcast_after(self, t, nav, detections, exchange, control=None):  # control_step broadcasts then
        return estimation_step(self, t, nav, detections, exchange, None)

    monkeypatch.setattr(OnboardStack, "estimation_step", broadcast_after)
    after = simulate(scenario)
    chunks = list(zip(first.chunks(), after.chunks(), strict=True))
    for a, b in chunks:
        assert set(a.probes) == set(b.probes) and a.probes
        for name, value in a.probes.items():
            if name != "solve_time":  # measured wall time
                assert np.array_equal(value, b.probes[name], equal_nan=True), name
        assert np.array_equal(a.truth, b.truth, equal_nan=True)
