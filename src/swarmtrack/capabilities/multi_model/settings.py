"""W20 Ch. 4's settings: the gimballed camera and the multi-model distributed EKF."""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

from pydantic import Field, field_validator

from swarmtrack.scenarios.schema import (
    CommaList,
    EstimatorSpec,
    Gain,
    Length,
    Position,
    Scenario,
    SensorSpec,
    check_stochastic,
)


class CameraSpec(SensorSpec):
    """Gimballed camera reporting the target's metric position in its frame (W20 eqs. 4.14-4.16), aimed at its
    UAV's latest estimate; the target is on flat ground."""

    kind: Literal["camera"] = "camera"
    gives: ClassVar[frozenset[str]] = frozenset({"camera_position"})
    sigma: Length = Field(0.0316, gt=0, description=(
        "m, camera-frame noise per axis (chosen: √(10 cm²), W20 Table 4.1's R = 10 read in cm²; at most 1e6 m)"))
    height: Length = Field(1.5, gt=0, description="m, camera height above the ground (W20 Sec. 3.2.2.2: at most 1.5)")
    footprint: tuple[Length, Length] = Field((1.2, 0.9), description=(
        "m, field of view (width, height) at footprint_range (W20 Sec. 3.2.2.2: 1.2 x 0.9 at 1.5 m)"))
    footprint_range: Length = Field(1.5, gt=0, description="m, distance at which the footprint is measured")
    home: Position = Field((0.0, 0.0), description="m, where gimbals aim before their UAV has an estimate")
    # W20 Ch. 4's error budget (issue 27, docs/multi-model.md "Error budget"): 0 (None) is the ideal camera
    noise_distance_power: float = Field(0.0, ge=0, le=4, description=(
        "marker noise grows as (distance / footprint_range)^power: 1 for a fixed error of the marker's corners in "
        "pixels (pinhole camera; error budget: 1)"))
    noise_angle_power: float = Field(0.0, ge=0, le=4, description=(
        "marker noise grows as (1 / cos view angle)^power, the angle between the line of sight and the flat "
        "marker's normal (foreshortening; error budget: 1)"))
    servo_deadband: float = Field(0.0, ge=0, le=45, description=(
        "deg, dead band of each pan-tilt servo (W20 Sec. 3.3: two hobby servos; error budget 0.45: a standard "
        "servo's 5 µs dead band over its 1000 µs for about 90 degrees)"))
    servo_speed: float | None = Field(None, gt=0, le=1e5, description=(
        "deg/s, rated speed of each servo; None: instant (error budget 300: 0.2 s per 60 degrees, a standard servo "
        "at 4.8 V)"))
    servo_zero_std: float = Field(0.0, ge=0, le=45, description=(
        "deg, std of each servo's zero offset, a constant per UAV and axis drawn once (error budget 1: chosen, a "
        "horn levelled by eye; no figure in the thesis)"))
    mount_offset_std: Length = Field(0.0, ge=0, description=(
        "m, std of the error of the hand-measured gimbal-to-body translation (W20 eqs. 3.6, 3.13-3.14), a constant "
        "per UAV and axis drawn once (error budget 0.005: chosen, a ruler to frame origins one cannot touch)"))

    @field_validator("footprint")
    @classmethod
    def _positive(cls, v):
        if min(v) <= 0:
            raise ValueError(f"{list(v)} must be positive")
        return v

    def ideal(self) -> bool:
        """Whether no error source of the budget is on (the camera points and knows its pose exactly)."""
        return (self.noise_distance_power == 0 and self.noise_angle_power == 0 and self.servo_deadband == 0
                and self.servo_speed is None and self.servo_zero_std == 0 and self.mount_offset_std == 0)


W20_MODELS = ("cv", "ca", "ct")


class MultiModelSpec(EstimatorSpec):
    """W20's multi-model distributed EKF: one covariance EKF per UAV with its own model, stacked neighbour
    measurements, fusion of the models' estimates (W20 Ch. 4). Defaults: W20 Tables 4.1 and 4.3, with Q, R and P0
    read in centimetre units (see docs/multi-model.md)."""

    kind: Literal["multimodel"] = "multimodel"
    #: Planar: a camera's positions (CameraFrameMeasurement) or range and bearing (RangeBearingMeasurement).
    reads: ClassVar[frozenset[str]] = frozenset({"camera_position", "range_bearing"})
    models: Annotated[list[Literal["cv", "ca", "ct"]], CommaList] = Field(["cv", "ca", "ct"], description=(
        "one target model per UAV, in UAV order (W20 Table 4.1: cv, ca, ct); also 'cv,ca,ct'"))
    fusion: Literal["ttest", "imm-thesis", "imm", "ml", "none"] = Field("ttest", description=(
        "ttest: T-test selection (eqs. 4.23-4.28); imm-thesis: IMM weighting without mixing (4.29-4.35); imm: "
        "standard IMM with mixing; ml: max-likelihood fusion (4.36-4.37); none: each UAV its own estimate"))
    occlusion: Literal["last", "trace", "eigenvalue"] = Field("last", description=(
        "T-test output when nobody measured: last winner (4.38), least position trace (4.39), smallest largest "
        "position eigenvalue (4.40)"))
    window: int = Field(10, ge=2, le=10_000, description="T-test residual window n (Table 4.1)")
    solo_steps: int = Field(100, ge=0, le=10**9, description=(
        "steps each UAV uses its own measurements alone before sharing (W20 Fig. 4.11)"))
    q: Gain = Field(5e-6, gt=0, description=(
        "per-step process-noise variance of every position, velocity and acceleration state (Table 4.1's "
        "Q = 0.05 I read in cm units: 5e-6 m²)"))
    q_turn_rate: Gain = Field(1e-4, gt=0, description="(rad/s)² per step, CT's ω (chosen)")
    r: Gain = Field(1e-3, gt=0, description=(
        "m², camera measurement variance per axis (Table 4.1's R = 10 read in cm²); range-bearing uses its sigmas"))
    p0: Gain = Field(5e-5, gt=0, description="initial variance of the kinematic states (Table 4.1's P0 = 0.5 I in cm²)")
    p0_turn_rate: Gain = Field(0.25, gt=0, description="(rad/s)², initial variance of CT's ω (chosen)")
    markov: list[list[float]] | None = Field(None, description=(
        "IMM switching matrix, one row and column per UAV (rows sum to 1); default 0.99 on the diagonal"))
    target: int = Field(1, ge=1, description="which member of the targets group the filters follow (1-based)")

    @field_validator("markov")
    @classmethod
    def _stochastic(cls, v):
        return check_stochastic(v)

    def followed_target(self) -> int | None:
        return self.target

    def warmup_steps(self) -> int:
        """W20 Fig. 4.6: the first moments (the solo steps) are initialisation and not considered."""
        return self.solo_steps

    def check(self, scenario: Scenario) -> None:
        n = scenario.swarm.n_uavs
        if len(self.models) != n:
            raise ValueError(f"estimator.models lists {len(self.models)} model(s) for {n} UAVs; give one per UAV")
        if self.markov is not None and len(self.markov) != n:
            raise ValueError(f"estimator.markov is {len(self.markov)} x {len(self.markov)}; the swarm has {n} UAVs")
