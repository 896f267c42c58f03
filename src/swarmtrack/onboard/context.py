"""What a builder may use besides its own settings (:class:`Context`), and the clock: each built here, once.

A :class:`Context` is made by :func:`context` only, for the whole swarm (the simulator, replay), one UAV (its own
process in the live swarm) or a batch of worlds (:mod:`swarmtrack.sim.batch`); its rates are those of
:func:`clock_of`, the scenario's one multirate clock.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from swarmtrack import registry
from swarmtrack.network.rows import Rows, subset_of
from swarmtrack.sim.clock import Clock

if TYPE_CHECKING:
    from swarmtrack.scenarios.schema import Scenario


def layout(scenario: Scenario) -> dict[str, slice]:
    """The world objects' rows of ``scenario``: targets, decoys, UAVs, in this order (the world's, the recording's)."""
    sizes = {"targets": scenario.targets.size(), "decoys": scenario.decoys.size(), "uavs": scenario.swarm.n_uavs}
    out, start = {}, 0
    for name, size in sizes.items():
        out[name] = slice(start, start + size)
        start += size
    return out


def sensed_objects(slices: dict[str, slice], groups) -> np.ndarray:
    """The objects (rows of ``slices``' groups) a sensor of ``groups`` sees, in label order: a cooperative sensor
    labels each by its place here (the world's truth side and the UAVs' builders read this one rule)."""
    return np.concatenate([np.arange(slices[n].start, slices[n].stop, dtype=np.int64)
                           for n in groups if n in slices] or [np.zeros(0, np.int64)])


def sensor_labels(scenario: Scenario) -> Callable[[str, int], int | None]:
    """``label_of(group, member)`` of :class:`Context`: the label the scenario's sensor reports for a member of a
    group, from what its settings declare it sees (:attr:`SensorSpec.sensed
    <swarmtrack.scenarios.schema.SensorSpec.sensed>`); None for a member it does not see."""
    rows = layout(scenario)
    sensed = sensed_objects(rows, scenario.sensor.sensed)
    label = {int(obj): k for k, obj in enumerate(sensed)}
    return lambda group, member: label.get(rows[group].start + member)


def labels_of(scenario: Scenario) -> dict[str, list[int | None]]:
    """The sensor's label of every member of the targets and decoys (None: not sensed), what each UAV's sensor
    reports (:func:`sensor_labels` as a table: the live world tells it to its UAVs at their start)."""
    label_of = sensor_labels(scenario)
    return {g: [label_of(g, m) for m in range(getattr(scenario, g).size())] for g in ("targets", "decoys")}


def clock_of(scenario: Scenario) -> Clock:
    """The scenario's clock: its physics, estimation and control rates over its run's duration."""
    r = scenario.rates
    return Clock.from_rates(r.physics, r.estimation, r.control, scenario.run_duration())


def command_width(scenario: Scenario) -> int:
    """What the swarm's controller commands per UAV: its vehicle kind's ``command_width``."""
    return registry.get(registry.VEHICLE, scenario.swarm.vehicle).command_width


@dataclass(frozen=True)
class Context:
    """What a builder may use besides its own settings: the scenario, the rates and the labels the sensor reports
    for the world's objects. Not the world itself: what a builder hands an onboard component must not be truth.

    ``uavs``: the swarm's UAVs (0-based, sorted) the component is built for, default all of them (the simulator);
    a builder makes a component of ``len(uavs)`` rows with each UAV's own settings, which produces for those rows
    exactly what the whole swarm's component produces given the same inputs (one UAV's own process in the live
    runtime). ``n_uavs`` is the swarm's size either way."""

    scenario: Scenario
    n_uavs: int
    dt_estimation: float
    dt_control: float
    compiled: bool
    label_of: Callable[[str, int], int | None]
    """``label_of(group, member)``: the label the sensor reports for ``group`` member ``member`` (0-based); None
    for a member it does not see (every sensor sees the targets)."""
    command_width: int = 2
    """What a UAV's controller commands per UAV (the swarm's vehicle kind's ``command_width``): 2 (a planar
    acceleration) or 1 (a fixed wing's yaw acceleration)."""
    # None: every UAV (__post_init__ replaces it, so the field is always an array after construction)
    uavs: np.ndarray = dataclasses.field(default=None, compare=False)  # type: ignore[arg-type]
    resources: dict = dataclasses.field(default_factory=dict, compare=False)
    worlds: int = 1
    """A batch of worlds (:mod:`swarmtrack.sim.batch`): ``n_uavs`` is ``worlds`` worlds' UAVs, world-major."""

    def __post_init__(self) -> None:
        uavs = np.arange(self.n_uavs) if self.uavs is None else subset_of(self.uavs, self.n_uavs)
        object.__setattr__(self, "uavs", uavs)

    @property
    def rows(self) -> Rows:
        """The UAVs of the build (:class:`~swarmtrack.network.rows.Rows`)."""
        return Rows(self.uavs, self.n_uavs, self.worlds)

    def target_label(self, member: int):
        """The label the sensor reports for ``targets`` member ``member`` (0-based): it sees the targets whenever an
        estimator follows one (:func:`~swarmtrack.scenarios.contract.sensor_sees_followed_target`)."""
        label = self.label_of("targets", member)
        assert label is not None, "validation checked that the sensor sees the targets"
        return label

    def whole_swarm_only(self, kind: str, why: str) -> None:
        """Refuse a build for a subset of the swarm's UAVs (``NotImplementedError`` naming the kind and why)."""
        if len(self.uavs) != self.n_uavs:
            raise NotImplementedError(f"{kind}: cannot be built for a subset of the swarm's UAVs "
                                      f"({self.uavs.tolist()} of {self.n_uavs}): {why}")

    def shared(self, name: str, make: Callable[[], object]):
        """What several components of one build share, made once (e.g. IB21's set backend, held the same way by
        the estimator and the MPC)."""
        if name not in self.resources:
            self.resources[name] = make()
        return self.resources[name]


def context(scenario: Scenario, label_of: Callable[[str, int], int | None], uavs=None, worlds: int = 1) -> Context:
    """The builders' context of ``scenario``: for the whole swarm, UAVs ``uavs`` of it (0-based) or a batch of
    ``worlds`` worlds of it (world-major); ``label_of`` as :attr:`Context.label_of`. One decision for every compiled
    fast path: ``scenario.kernels`` is not ``numpy``."""
    clock = clock_of(scenario)
    return Context(scenario, scenario.swarm.n_uavs * worlds, clock.dt_estimation, clock.dt_control,
                   scenario.kernels != "numpy", label_of, command_width(scenario), uavs=uavs, worlds=worlds)
