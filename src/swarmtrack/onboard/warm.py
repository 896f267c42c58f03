"""Loading the compiled kernels a UAV's stack calls before its first real step is due, from the stack alone.

In a fresh process numba's cache takes about a second to load at a kernel's first call, which would make a UAV's
first real-time steps late. :func:`warm_up` builds a throwaway copy of the UAV's stack (another seed) and steps it
on made-up inputs: its navigation at rest at its spawn point, a detection of the followed target 5 m east made by the
sensor's declared measurement (:class:`~swarmtrack.registry.Measurement`; without one, the sensor's frame without
detections, :attr:`~swarmtrack.registry.Kind.quiet`), and an exchange in which it hears one neighbour say what it
said itself (:class:`Echo`). Nothing of the world, the run's truth or its random streams is computed: a companion
computer can do this before its swarm starts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from swarmtrack import registry
from swarmtrack.network.messages import Inbox, Outbox
from swarmtrack.onboard.build import onboard_stack
from swarmtrack.onboard.context import clock_of, context
from swarmtrack.sensors.detections import Detections

if TYPE_CHECKING:
    from swarmtrack.scenarios.schema import Scenario

#: Estimation steps a warm-up runs (each with its control steps): the first call of each kernel, and a few more.
WARM_STEPS = 3
#: Where the made-up detection puts the followed target, relative to the UAV (m, east and north).
AHEAD = (5.0, 0.0)


class Echo:
    """The warm-up's exchange (:class:`~swarmtrack.onboard.exchange.Exchange`) for UAV ``i`` of ``n``: it hears
    one neighbour say what it said itself (a swarm of one hears nobody), so the fusion of neighbours' messages runs
    too."""

    def __init__(self, i: int, n: int):
        self.i, self.n = i, n

    def _inbox(self, own: Outbox) -> Inbox:
        links = np.zeros((1, self.n), dtype=bool)
        if self.n > 1:
            links[0, (self.i + 1) % self.n] = True
        payloads = {name: np.repeat(np.asarray(v)[:1], self.n, axis=0) for name, v in own.items()}
        return Inbox(links, payloads, (), np.array([self.i]))

    def share(self, t: float, outbox: Outbox, beacon: Outbox | None) -> Inbox:
        return self._inbox(outbox)

    def publish(self, t: float, posteriors: Outbox) -> Inbox:
        return self._inbox(posteriors or {})

    def beacons(self, t: float, beacon: Outbox) -> Inbox:
        return self._inbox(beacon)

    def planned(self, t: float, plans: Outbox) -> None:
        pass


def _navigation(scenario: Scenario, i: int) -> np.ndarray:
    """UAV ``i``'s navigation (1, d) at rest at its spawn point (or the spawn box's centre), as its world would
    give it: ``[x, y, vx, vy]`` and a kinematic vehicle's state."""
    sw = scenario.swarm
    xy = np.asarray(sw.initial_positions[i] if sw.initial_positions is not None else sw.spawn_center, float)[None]
    nav = np.concatenate([xy, np.zeros((1, 2))], axis=1)
    vehicle = registry.get(registry.VEHICLE, sw.vehicle)
    if not vehicle.is_kinematic:
        return nav
    state = vehicle.module().initial_state(xy, np.zeros(1), vehicle.make_params(sw))
    return np.concatenate([nav, state], axis=1)


def _detections(scenario: Scenario, nav: np.ndarray, label: int | None) -> Detections:
    """A detection of the followed target :data:`AHEAD` of the UAV, by the sensor's declared measurement; without
    one (or without a followed target), the sensor's frame without detections (:attr:`~swarmtrack.registry.Kind.quiet`,
    else an empty one)."""
    sensor = registry.get("sensor", scenario.sensor.kind)
    if sensor.measurement is None or label is None:
        if sensor.quiet is not None:
            return registry.resolve(sensor.quiet)(scenario.sensor, nav)
        dim = 3 if scenario.sensor.three_d else 2
        return Detections(np.zeros(0, np.int64), np.zeros((0, dim)), np.zeros((0, dim)), np.zeros(0, np.int64), 1)
    z, frame = registry.resolve(sensor.measurement.of_relative)(np.asarray([AHEAD]), nav[:, :2])
    return Detections(np.zeros(1, np.int64), z, nav[:, :2].copy(), np.array([label]), 1, frame=frame)


def warm_up(scenario: Scenario, uav: int, label_of) -> None:
    """Step a throwaway copy of UAV ``uav``'s stack (built for it alone with ``label_of``, as its own is, with
    another seed) :data:`WARM_STEPS` times on made-up inputs. A stack that refuses them stops the warm-up there (a
    slower start, no more): the real run reports real errors."""
    scenario = scenario.model_copy(update={"seed": scenario.seed + 1})
    clock = clock_of(scenario)
    stack = onboard_stack(context(scenario, label_of, uavs=[uav]))
    nav, echo = _navigation(scenario, uav), Echo(uav, scenario.swarm.n_uavs)
    followed = scenario.estimator.followed_target()
    detections = _detections(scenario, nav, None if followed is None else label_of("targets", followed - 1))
    try:
        for k in range(WARM_STEPS):
            t = k * clock.dt_estimation
            beacon = stack.estimation_step(t, nav, detections, echo, t)
            stack.sample()
            stack.control_step(t, nav, stack.estimator.view(), echo, clock.dt_control, beacon)
    except Exception:  # noqa: BLE001 - a warm-up that fails is only a slower start
        return
