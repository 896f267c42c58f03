"""Capability 1's settings (L24, L23): the range-bearing sensor, the decentralized information filter and its
centralized baseline, the IMM bank over models of different sizes, and the flocking controller."""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Annotated, ClassVar, Literal

from pydantic import Field, ValidationInfo, field_validator

from swarmtrack.control.gains import FlockingGains
from swarmtrack.models import make_model
from swarmtrack.network.delays import delay_steps
from swarmtrack.scenarios.schema import (
    LIAR_NEEDS,
    Angle,
    CommaList,
    ControllerSpec,
    EstimatorSpec,
    Gain,
    Length,
    Scenario,
    SensorSpec,
    Speed,
    check_stochastic,
)


class RangeBearingSpec(SensorSpec):
    """Range and bearing from each UAV to every object (L24 Sec. 3.2)."""

    kind: Literal["range_bearing"] = "range_bearing"
    gives: ClassVar[frozenset[str]] = frozenset({"information_update", "range_bearing", "positions"})
    sigma_range: Length = Field(0.08, gt=0, description="m (L24: 0.08, L23: 0.4; at most 1e6 m)")
    sigma_bearing: Angle = Field(0.02, gt=0, description="rad (L24: 0.02, L23: 0.1; at most 1e3 rad)")
    update: Literal["position", "polar"] = Field(
        "position", description="position: converted measurement with the paper's R_i; polar: EKF on [ρ, β]")
    max_range: Length | None = Field(None, gt=0, description=(
        "m (at most 1e6 m); a UAV farther from the target measures nothing"))
    detection_probability: float = Field(1.0, gt=0, le=1, description=(
        "probability that an object in view is detected at a scan (issue 40; the papers: 1); at the UAV's position "
        "when detection_falloff is not 0"))
    detection_falloff: float = Field(0.0, ge=0, lt=1, description=(
        "the detection probability at the field of view's edge is detection_probability · (1 − detection_falloff), "
        "falling linearly with the range from the UAV's position to the edge (max_range; needed when not 0)"))
    clutter_rate: float = Field(0.0, ge=0, le=1e4, description=(
        "false detections per UAV per scan, Poisson, uniform over the disk of max_range; unlabelled (issue 40; the "
        "papers: 0)"))
    labelled: bool = Field(True, description=(
        "true: each detection carries its object's label (the papers' cooperative sensor); false: none (a sensor "
        "that cannot tell the objects apart, read by a multi-target estimator; issue 40)"))

    @field_validator("detection_falloff")
    @classmethod
    def _falloff_needs_a_field_of_view(cls, v: float, info: ValidationInfo) -> float:
        return _needs_max_range(v, info, "the detection probability falls to the field of view's edge")

    @field_validator("clutter_rate")
    @classmethod
    def _clutter_needs_a_field_of_view(cls, v: float, info: ValidationInfo) -> float:
        return _needs_max_range(v, info, "clutter is spread over the sensor's field of view")

    def update_rule(self, own_sigma: float = 0.0):
        """How its measurements enter an information filter (:class:`~swarmtrack.estimation.information
        .RangeBearingUpdate`); ``own_sigma``: the UAV's own navigation error, m."""
        from swarmtrack.estimation.information import RangeBearingUpdate

        return RangeBearingUpdate(self.sigma_range, self.sigma_bearing, self.update, own_sigma=own_sigma)

    def position_rule(self, own_sigma: float = 0.0):
        """Each detection as the position it implies with its covariance (:func:`~swarmtrack.sensors.range_bearing
        .positions`), what a tracker of unlabelled detections reads; ``own_sigma``: the UAV's navigation error."""
        from swarmtrack.sensors import range_bearing

        return functools.partial(range_bearing.positions, sigma_range=self.sigma_range,
                                 sigma_bearing=self.sigma_bearing, own_sigma=own_sigma)

    def field_of_view(self) -> float | None:
        """The area a UAV's sensor sees, m² (the disk of ``max_range``; None: unbounded)."""
        return None if self.max_range is None else math.pi * self.max_range**2

    def detection_probability_at(self, rel):
        """The probability (...,) that objects at planar positions ``rel`` (..., 2) relative to the UAV are detected in
        a scan: 0 beyond ``max_range``, ``detection_probability · (1 − detection_falloff · ρ / max_range)`` within
        it (:func:`~swarmtrack.sensors.clutter.disk_detection_probability`, the law the world senses with)."""
        from swarmtrack.sensors import clutter

        return clutter.disk_detection_probability(rel, self.detection_probability, self.detection_falloff,
                                                  self.max_range)


def _needs_max_range(v: float, info: ValidationInfo, what: str) -> float:
    """``v`` unless it is positive and the sensor has no ``max_range``: refused saying ``what`` needs one."""
    if v > 0 and info.data.get("max_range") is None:
        raise ValueError(f"{what}: give max_range too")
    return v


class RangeBearingElevationSpec(SensorSpec):
    """Range, bearing and relative elevation from each UAV to every object in a 3-D world: L24 Sec. 3.2's sensor
    with the elevation angle its Sec. 6 names (docs/three-d.md); its estimators run 3-D models (cv3d, ca3d, ct3d,
    fs3d)."""

    kind: Literal["range_bearing_elevation"] = "range_bearing_elevation"
    gives: ClassVar[frozenset[str]] = frozenset({"information_update"})
    #: It reads heights: the world flies them (swarm.altitude, the targets' altitude and climb).
    three_d: ClassVar[bool] = True
    sigma_range: Length = Field(0.08, gt=0, description="m (L24: 0.08; at most 1e6 m)")
    sigma_bearing: Angle = Field(0.02, gt=0, description="rad (L24: 0.02; at most 1e3 rad)")
    sigma_elevation: Angle = Field(0.02, gt=0, description=(
        "rad (chosen: the bearing's, L24's 0.02, read by the same sensor; at most 1e3 rad)"))
    update: Literal["position", "spherical"] = Field("position", description=(
        "position: the converted position, its covariance growing with distance across the line of sight; "
        "spherical: EKF on [ρ, β, ε]"))
    max_range: Length | None = Field(None, gt=0, description=(
        "m (at most 1e6 m); a UAV farther from the target (3-D distance) measures nothing"))
    detection_probability: float = Field(1.0, gt=0, le=1, description=(
        "probability that an object in view is detected at a scan (issue 40; L24: 1)"))
    clutter_rate: float = Field(0.0, ge=0, le=1e4, description=(
        "false detections per UAV per scan, Poisson, uniform over the ball of max_range around the UAV; unlabelled "
        "(issue 40; L24: 0)"))
    labelled: bool = Field(True, description=(
        "true: each detection carries its object's label (L24's cooperative sensor); false: none (a sensor that "
        "cannot tell the objects apart; issue 40)"))

    @field_validator("occluders")
    @classmethod
    def _no_occluders(cls, v):
        if v:
            raise ValueError("are planar regions: the range_bearing_elevation sensor takes none")
        return v

    @field_validator("clutter_rate")
    @classmethod
    def _clutter_needs_a_field_of_view(cls, v: float, info: ValidationInfo) -> float:
        return _needs_max_range(v, info, "clutter is spread over the ball of the sensor's field of view")

    def update_rule(self, own_sigma: float = 0.0):
        """:class:`~swarmtrack.estimation.elevation.RangeBearingElevationUpdate` of this sensor."""
        from swarmtrack.estimation.elevation import RangeBearingElevationUpdate

        return RangeBearingElevationUpdate(self.sigma_range, self.sigma_bearing, self.sigma_elevation, self.update,
                                           own_sigma=own_sigma)


#: The target models of a planar sensor and of a 3-D one (``three_d``: range_bearing_elevation; models/three_d.py).
PLANAR_MODELS = ("cv", "ca", "ct", "fs")
MODELS_3D = ("cv3d", "ca3d", "ct3d", "fs3d")


def check_dimensions(scenario: Scenario, models, field: str) -> None:
    """A 3-D sensor needs 3-D models and a planar one planar models: refuse the mix, naming ``field``."""
    three_d = scenario.sensor.three_d
    wrong = [m for m in models if (m in MODELS_3D) != three_d]
    if wrong:
        need = "3-D models (" + ", ".join(MODELS_3D) + ")" if three_d else "planar models (" + \
            ", ".join(PLANAR_MODELS) + ")"
        raise ValueError(f"{field} {', '.join(wrong)} does not match sensor.kind {scenario.sensor.kind}: it needs "
                         f"{need}")


class FilterSpec(EstimatorSpec):
    """An EKF over one target motion model, following the target ``target`` (1-based member of ``targets``,
    recognised onboard by the label its sensor reports)."""

    reads: ClassVar[frozenset[str]] = frozenset({"information_update"})
    share: Literal["information", "measurements"] = Field(
        "information", description="information: neighbours send I_j, i_j (L24 eq. 6); measurements: z_j and pose")
    model: Literal["cv", "ca", "ct", "fs", "cv3d", "ca3d", "ct3d", "fs3d"] = Field("ct", description=(
        "the target model (L24 Sec. 3.1); the 3-D ones with the range_bearing_elevation sensor"))
    q: list[float] | None = Field(None, description=(
        "diagonal of Q; default: the paper's (L24 Sec. 4). Not bounded above: tests/sim drive the filter to "
        "divergence with q = 1.7e308"))
    initial_information: Gain = Field(1e-6, gt=0, description="εI, the near-zero initial information (at most 1e6)")
    fake_vz_sigma: Speed = Field(0.05, gt=0, description=(
        "FS model: std of the fake vz = 0 measurement, m/s (at most 1e3 m/s)"))
    target: int = Field(1, ge=1, description="which member of the targets group the filter follows (1-based)")
    delayed_data: Literal["refilter", "as_current"] = Field("refilter", description=(
        "refilter: fuse each measurement and message at the time it was taken, re-filtering the steps since "
        "(sensor latency, network delays); as_current: fuse late data as if it were current (L24's filter)"))
    gating: Literal["none", "chi2", "ci"] = Field("none", description=(
        "neighbours' contributions: none (L24), chi2 (a χ²-test against the own prediction leaves out "
        "outliers and records whom), ci (covariance intersection, one neighbour at a time)"))
    gate_probability: float = Field(0.999, gt=0.5, lt=1, description="the χ²(2) gate's quantile")
    own_position: Literal["include", "ignore"] = Field("include", description=(
        "include: the UAV's own navigation error (swarm.nav_position_std, its navigation system's stated "
        "accuracy) enters each measurement's covariance; ignore: as the papers' filters"))

    def followed_target(self) -> int | None:
        return self.target

    def recording_meta(self) -> dict:
        return {"model": self.model}

    def check_network(self, scenario: Scenario) -> None:
        """Late data is fused at its time stamp when neighbours share information (a fusion centre hears every
        measurement); only an information filter sharing information can gate a liar's contributions."""
        if scenario.network.delay_bound() > 0 and self.share != "information" and self.kind != "centralized":
            raise ValueError("network.delay needs estimator.share information: shared raw measurements are fused "
                             "as they arrive, and late ones would be lost")
        if scenario.network.liar is not None and (self.kind != "information" or self.share != "information"):
            raise ValueError(LIAR_NEEDS)

    def check(self, scenario: Scenario) -> None:
        check_dimensions(scenario, [self.model], "estimator.model")
        if self.gating != "none" and self.model in MODELS_3D:
            raise ValueError("estimator.gating is built for planar measurements (a χ²(2) gate, 2 x 2 covariance "
                             "intersection): use none with a 3-D model")
        if self.gating != "none" and (self.kind == "centralized" or self.share != "information"):
            raise ValueError("estimator.gating applies to neighbours' information contributions: it needs "
                             "kind information with share information")
        if self.gating != "none" and scenario.network.topology == "none":
            raise ValueError("estimator.gating has no neighbours to gate: network.topology is none")
        if self.delayed_data != "refilter" or not refiltered_steps(scenario):
            return
        if self.gating == "ci":
            raise ValueError("estimator.gating ci is not built for late data (sensor.latency or network.delay): "
                             "use chi2, or delayed_data: as_current")
        if self.share != "information" and self.kind != "centralized":
            raise ValueError("estimator.delayed_data refilter needs estimator.share information (or "
                             "delayed_data: as_current)")
        period = 1.0 / scenario.rates.estimation
        ratio = scenario.sensor.latency / period
        if abs(ratio - round(ratio)) > 1e-6:
            raise ValueError(f"sensor.latency ({scenario.sensor.latency:g} s) must be a whole number of estimation "
                             f"periods ({period:g} s) for estimator.delayed_data refilter (or use as_current)")

    @field_validator("q")
    @classmethod
    def _q_positive(cls, v, info: ValidationInfo):
        if v is not None:
            for k, x in enumerate(v):
                if not (math.isfinite(x) and x > 0):
                    raise ValueError(f"Q must be positive definite: diagonal entry {k} is {x}")
            if "model" in info.data:
                dim = make_model(info.data["model"], 0.05).dim
                if len(v) != dim:
                    raise ValueError(f"has {len(v)} entries; model {info.data['model']!r} has {dim} states")
        return v


def refiltered_steps(scenario: Scenario) -> int:
    """How many estimation steps late a datum can arrive: the sensor's latency (a whole number of steps, checked)
    plus the steps the channel holds a message (:func:`swarmtrack.network.delays.delay_steps`), for a filter that
    hears neighbours (a fusion centre or a UAV without links gets no message)."""
    period = 1.0 / scenario.rates.estimation
    steps = round(scenario.sensor.latency / period)
    if scenario.estimator.kind != "centralized" and scenario.network.topology != "none":
        steps += int(delay_steps(scenario.network.delay_bound(), period))
    return steps


class InformationSpec(FilterSpec):
    """Decentralized information-form EKF, one per UAV, fused over the topology's links (L24 Sec. 3)."""

    kind: Literal["information"] = "information"


class CentralizedSpec(FilterSpec):
    """One fusion centre over every UAV's measurement (the baseline; ``share`` does not apply)."""

    kind: Literal["centralized"] = "centralized"


class IMMSpec(EstimatorSpec):
    """A bank of information filters per UAV, one per model, combined by an IMM with mixing through the common block
    [x, y, vx, vy] (L24's future work; swarmtrack.estimation.imm). Other keys as in the information estimator."""

    kind: Literal["imm"] = "imm"
    reads: ClassVar[frozenset[str]] = frozenset({"information_update"})
    share: Literal["information", "measurements"] = Field("information", description=(
        "information: one I_j, i_j per UAV, linearised at its combined prediction; measurements: z_j and pose, "
        "each model linearises at its own prediction"))
    models: Annotated[list[Literal["cv", "ct", "fs", "cv3d", "ca3d", "ct3d", "fs3d"]], CommaList] = Field(
        ["cv", "ct", "fs"], min_length=1, description=(
            "the bank every UAV runs, one information filter per model (3-D ones with range_bearing_elevation)"))
    markov: list[list[float]] | None = Field(None, description=(
        "M x M model-switching matrix over models (rows sum to 1); default 0.98 on the diagonal, the rest even"))
    q: list[list[float] | None] | None = Field(None, description=(
        "diagonal of Q per model (null: that model's default, L24 Sec. 4)"))
    initial_information: Gain = Field(1e-6, gt=0, description="εI, the near-zero initial information (at most 1e6)")
    fake_vz_sigma: Speed = Field(0.05, gt=0, description="FS member: std of the fake vz = 0 measurement, m/s")
    target: int = Field(1, ge=1, description="which member of the targets group the filters follow (1-based)")

    @field_validator("markov")
    @classmethod
    def _markov_over_models(cls, v, info: ValidationInfo):
        m = len(info.data.get("models") or [])
        if v is not None:
            check_stochastic(v)
            if m and len(v) != m:
                raise ValueError(f"is {len(v)} x {len(v)}; models lists {m} model(s)")
        return v

    @field_validator("q")
    @classmethod
    def _q_per_model(cls, v, info: ValidationInfo):
        models = info.data.get("models")
        if v is not None and models is not None:
            if len(v) != len(models):
                raise ValueError(f"has {len(v)} entries; models lists {len(models)} model(s)")
            for name, q in zip(models, v, strict=True):
                if q is not None:
                    make_model(name, 0.05, q)  # length and positivity, its ValueError names the model
        return v

    def followed_target(self) -> int | None:
        return self.target

    def check(self, scenario: Scenario) -> None:
        check_dimensions(scenario, self.models, "estimator.models")


class FlockingSpec(ControllerSpec):
    kind: Literal["flocking"] = "flocking"
    commands: ClassVar[int | None] = 2  # a planar acceleration
    variant: Literal["standard", "integral", "tailored"] = "tailored"
    d: Length = Field(4.0, gt=0, description="desired inter-agent distance, m (at most 1e6 m)")
    chase_after_steps: int = Field(20, ge=0, le=10**12, description=(
        "estimation steps before the UAVs start chasing (L24)"))
    follow: Literal["estimate", "truth"] = Field(
        "estimate", description="what the target term follows; truth wires an oracle (not onboard) to the controller")
    gains: dict[str, Gain] = Field(default_factory=dict, description=(
        "overrides of FlockingGains fields (each at most 1e6 in magnitude: gains in s⁻¹ or s⁻², D_dt in m, "
        "accel_limit in m/s²)"))

    @field_validator("gains")
    @classmethod
    def _known_gains(cls, v):
        known = {f.name for f in dataclasses.fields(FlockingGains)} - {"d", "r_comm"}
        unknown = sorted(set(v) - known)
        if unknown:
            raise ValueError(f"unknown gain(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
        FlockingGains(**v)  # its own range checks (ε, h in (0, 1), positive lengths) raise a readable ValueError
        return v

    @classmethod
    def mapping_keys(cls, field: str) -> str | None:
        """The keys of a mapping-valued field, for the scenario reference: ``gains`` takes FlockingGains fields (d
        and r_comm are controller.d and network.r_comm)."""
        if field != "gains":
            return None
        return ", ".join(f"{f.name} ({f.default})" for f in dataclasses.fields(FlockingGains)
                         if f.name not in ("d", "r_comm"))

    def follows_truth(self) -> bool:
        return self.follow == "truth"

    def chase_start_steps(self) -> int:
        return self.chase_after_steps

    def recording_meta(self) -> dict:
        return {"d": self.d}
