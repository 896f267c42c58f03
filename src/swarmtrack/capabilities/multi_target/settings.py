"""Issue 40's settings: the planar position sensor (unlabelled detections with misses and clutter) and the labelled
multi-Bernoulli (LMB) estimator, one multi-target tracker per UAV fed its own detections and those its neighbours
share."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, ClassVar, Literal, Protocol, cast

from pydantic import Field, ValidationInfo, field_validator

from swarmtrack.capabilities.tracking_swarm.settings import FlockingSpec
from swarmtrack.scenarios.schema import (
    LIAR_NEEDS,
    Acceleration,
    Box,
    EstimatorSpec,
    Length,
    Scenario,
    SensorSpec,
    Speed,
)


class GivesPositions(Protocol):
    """What a sensor's settings that give ``positions`` provide (the position sensor's, the range-bearing
    sensor's): what the LMB estimator reads of them."""

    kind: str
    latency: float
    detection_probability: float
    clutter_rate: float

    def position_rule(self, own_sigma: float = 0.0) -> Callable: ...

    def field_of_view(self) -> float | None: ...

    def detection_probability_at(self, rel) -> Any: ...


def positions_sensor(scenario: Scenario) -> GivesPositions:
    """The scenario's sensor, which gives ``positions`` (the contract checked it before the estimator's checks)."""
    return cast(GivesPositions, scenario.sensor)


class PositionSpec(SensorSpec):
    """The planar position of every object in a square footprint centred on the UAV, relative to it, with Gaussian
    noise; unlabelled: the sensor cannot tell the objects apart (:mod:`swarmtrack.sensors.position`)."""

    kind: Literal["position"] = "position"
    gives: ClassVar[frozenset[str]] = frozenset({"positions"})
    #: Its detections carry no label.
    labelled: ClassVar[bool] = False
    sigma: Length = Field(1.0, gt=0, description="m, noise std per axis (issue 40's box: 1; at most 1e6 m)")
    half_width: Length | None = Field(None, gt=0, description=(
        "m, half-width of the square footprint centred on the UAV, along the world's axes; null: it sees "
        "everything (at most 1e6 m)"))
    detection_probability: float = Field(1.0, gt=0, le=1, description=(
        "probability that an object in view is detected at a scan; at the UAV's position when detection_falloff is "
        "not 0"))
    detection_falloff: float = Field(0.0, ge=0, lt=1, description=(
        "the detection probability at the field of view's edge is detection_probability · (1 − detection_falloff), "
        "falling linearly with the Chebyshev distance max(|x|, |y|) from the UAV's position to the footprint's edge "
        "(half_width; needed when not 0)"))
    clutter_rate: float = Field(0.0, ge=0, le=1e4, description=(
        "false detections per UAV per scan, Poisson, uniform over the footprint"))

    @field_validator("detection_falloff", "clutter_rate")
    @classmethod
    def _needs_a_footprint(cls, v: float, info: ValidationInfo) -> float:
        if v > 0 and info.data.get("half_width") is None:
            what = "clutter is spread over the sensor's footprint" if info.field_name == "clutter_rate" else \
                "the detection probability falls to the footprint's edge"
            raise ValueError(f"{what}: give half_width too")
        return v

    def position_rule(self, own_sigma: float = 0.0):
        """Each detection as a world position with its covariance (:func:`~swarmtrack.sensors.position.positions`);
        ``own_sigma``: the UAV's own navigation error, m."""
        from swarmtrack.sensors import position

        return functools.partial(position.positions, sigma=self.sigma, own_sigma=own_sigma)

    def field_of_view(self) -> float | None:
        """The area a UAV's sensor sees, m² (None: unbounded)."""
        return None if self.half_width is None else (2.0 * self.half_width) ** 2

    def detection_probability_at(self, rel):
        """The probability (...,) that objects at planar positions ``rel`` (..., 2) relative to the UAV are detected in
        a scan: 0 outside the footprint, ``detection_probability · (1 − detection_falloff · max(|x|, |y|) /
        half_width)`` inside it (:func:`~swarmtrack.sensors.clutter.square_detection_probability`, the law the world
        senses with)."""
        from swarmtrack.sensors import clutter

        return clutter.square_detection_probability(rel, self.detection_probability, self.detection_falloff,
                                                    self.half_width)


class MultiTargetSpec(EstimatorSpec):
    """What every multi-target tracker per UAV shares (:mod:`swarmtrack.estimation.multitarget`): its motion model,
    the detections it reads and how, what the UAVs tell each other, the region it watches."""

    kind: str
    reads: ClassVar[frozenset[str]] = frozenset({"positions"})
    #: Its view carries every UAV's confirmed tracks (what a controller of many targets reads).
    reports_tracks: ClassVar[bool] = True
    accel_std: Acceleration = Field(0.5, gt=0, description=(
        "m/s², std of the white acceleration of the constant-velocity model, constant over a step (Bar-Shalom's "
        "discretised white-noise acceleration; issue 40's box: 0.5)"))
    detection_probability: float | None = Field(None, gt=0, le=1, description=(
        "P_D the filter assumes inside the sensor's field of view; null: the sensor's law (with its falloff)"))
    clutter_rate: float | None = Field(None, ge=0, le=1e4, description=(
        "false detections per scan the filter assumes, over the sensor's field of view; null: the sensor's"))
    region: Box | None = Field(None, description=(
        "[x0, y0, x1, y1], m: the surveillance region; a track predicted outside it ends (its survival is 0 there); "
        "null: everywhere (issue 40's box: the box)"))
    birth_velocity_std: Speed = Field(5.0, gt=0, description="m/s, a new track's velocity std per axis")
    max_tracks: int = Field(64, ge=1, le=10_000, description=(
        "the most tracks a UAV keeps (the likeliest), and reports"))
    gate_probability: float = Field(0.9999, gt=0.5, lt=1, description=(
        "the χ²(2) gate's quantile: a detection outside a track's gate is not associated with it"))
    share: Literal["measurements", "none", "centre"] = Field("measurements", description=(
        "measurements: each UAV broadcasts its detections, and every UAV corrects its tracks with its own and "
        "each neighbour's in turn (iterated corrector, in the order of the UAVs); none: its own only; centre: the "
        "centralised baseline, one filter fed every UAV's detections without the network"))
    max_shared: int = Field(64, ge=1, le=10_000, description=(
        "the most detections a UAV broadcasts per step (the closest to it): bounds a message's size"))
    fuse_tracks: bool = Field(True, description=(
        "each UAV also broadcasts its tracks after its correction and fuses its neighbours' (matched by label, then "
        "by assignment; a pair by geometric average; a confirmed track outside its own view adopted): tracks travel "
        "over several hops. Not with share centre"))
    max_shared_tracks: int = Field(32, ge=1, le=10_000, description=(
        "the most tracks a UAV broadcasts per step (the likeliest): bounds the second message's size"))
    own_position: Literal["include", "ignore"] = Field("include", description=(
        "include: the UAV's own navigation error (swarm.nav_position_std) enters each detection's covariance"))
    settle_steps: int = Field(0, ge=0, le=10**9, description=(
        "estimation steps before the tracks are judged (the metrics' window; issue 40's benchmark: 20, the "
        "targets' acquisition)"))

    def warmup_steps(self) -> int:
        return self.settle_steps

    def check_network(self, scenario: Scenario) -> None:
        """Delays are let through: a batch of detections that arrives after its step is dropped and counted (a
        correction is at its step's time), the tracks of the step still fused. A liar is refused (no gate)."""
        if scenario.network.liar is not None:
            raise ValueError(LIAR_NEEDS)

    def check(self, scenario: Scenario) -> None:
        sensor = positions_sensor(scenario)
        if getattr(sensor, "labelled", False):
            raise ValueError(f"sensor.labelled is true: estimator.kind {self.kind} tracks detections that carry no "
                             f"label (set sensor.labelled: false, or use a sensor that gives none; sensor.kind "
                             f"{sensor.kind} labels each object)")
        if sensor.latency > 0:
            raise ValueError(f"sensor.latency: estimator.kind {self.kind} fuses detections as current; use latency 0")
        rate = sensor.clutter_rate if self.clutter_rate is None else self.clutter_rate
        if rate > 0 and sensor.field_of_view() is None:
            raise ValueError("estimator.clutter_rate is spread over the sensor's field of view, which is unbounded: "
                             "give the sensor's max_range or half_width")


class LMBSpec(MultiTargetSpec):
    """A labelled multi-Bernoulli filter per UAV (Reuter et al. 2014) over the unlabelled detections of its own
    sensor and of the neighbours that share theirs, associated by loopy belief propagation (Williams and Lau 2014),
    tracks born where detections are left unexplained (adaptive birth), a nearly-constant-velocity motion model
    (docs/multi-target.md)."""

    kind: Literal["lmb"] = "lmb"
    survival_probability: float = Field(0.99, gt=0, le=1, description="P_S, a track's survival per step")
    birth_rate: float = Field(0.1, gt=0, le=100, description=(
        "λ_B, the expected births per scan, spread over the detections no track explains (adaptive birth)"))
    birth_existence: float = Field(0.5, gt=0, lt=1, description="r_B,max, the largest existence of a new track")
    existence_threshold: float = Field(0.5, gt=0, lt=1, description=(
        "a track whose existence is above it is reported (an estimate)"))
    prune_threshold: float = Field(1e-3, gt=0, lt=0.5, description="a track whose existence falls below it is dropped")


class ClassicSpec(MultiTargetSpec):
    """A classic tracker per UAV, a baseline beside the LMB filter (:mod:`swarmtrack.estimation.classic`): a
    detection no track takes starts a tentative track, confirmed at its ``confirm``-th hit and deleted at its first
    miss, a confirmed one deleted after ``delete`` misses in a row. The swarm's messages and fusion are the LMB's."""

    kind: str
    #: The filter class, ``"module:attribute"``.
    tracker: ClassVar[str] = ""
    confirm: int = Field(3, ge=1, le=1000, description="hits (detections, over the batches) that confirm a track")
    delete: int = Field(3, ge=1, le=1000, description="misses in a row that delete a confirmed track")


class GNNSpec(ClassicSpec):
    """Global nearest neighbour: the assignment of detections to tracks of least total ``d² + ln |S|``, each
    assigned track Kalman-updated (:class:`~swarmtrack.estimation.classic.GNNFilter`)."""

    kind: Literal["gnn"] = "gnn"
    tracker: ClassVar[str] = "swarmtrack.estimation.classic:GNNFilter"


class JPDASpec(ClassicSpec):
    """Joint probabilistic data association, its marginals by loopy belief propagation
    (:class:`~swarmtrack.estimation.classic.JPDAFilter`)."""

    kind: Literal["jpda"] = "jpda"
    tracker: ClassVar[str] = "swarmtrack.estimation.classic:JPDAFilter"


class TrackAssignmentSpec(FlockingSpec):
    """Each UAV assigns the swarm to its confirmed tracks (the least total distance, at most ``per_track`` UAVs each,
    shared evenly), keeps the others (at least ``searchers``) flying a lawnmower over ``region``, and flocks around
    its own track with
    L24's flocking (:mod:`swarmtrack.control.assignment`). Other keys as in the flocking controller."""

    kind: Literal["track_assignment"] = "track_assignment"  # type: ignore[assignment]
    searchers: int = Field(1, ge=0, le=100_000, description=(
        "UAVs kept searching for new targets while there are more UAVs than tracks"))
    per_track: int = Field(2, ge=1, le=100_000, description=(
        "the most UAVs that follow one track (every track gets one first); the others search"))
    region: Box = Field((-100.0, -100.0, 100.0, 100.0), description=(
        "[x0, y0, x1, y1], m: the area the searchers sweep"))
    lane: Length = Field(40.0, gt=0, description="m, between the search pattern's lanes (about the footprint's width)")
    search_speed: Speed = Field(3.0, gt=0, description="m/s, the searchers' speed")

    def check(self, scenario: Scenario) -> None:
        if not getattr(scenario.estimator, "reports_tracks", False):
            raise ValueError(f"controller.kind track_assignment follows the confirmed tracks of a multi-target "
                             f"estimator, which estimator.kind {scenario.estimator.kind} does not report (use lmb)")
        if self.follow != "estimate":
            raise ValueError("controller.follow: track_assignment follows the tracks, not the truth")
