"""Scenario files: validated once, at the edge (pydantic). Units are in the field descriptions.

Every value a paper leaves open has a default here that says where it came from.
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


Vec2 = tuple[float, float]


class PhaseSpec(_Strict):
    """One phase of the target's velocity profile; each axis flies ``c + A·sin(ω·τ + φ)``, τ from phase start."""

    name: str
    duration: float = Field(gt=0, description="s")
    c: Vec2 = Field((0.0, 0.0), description="constant velocity term, m/s")
    amplitude: Vec2 = Field((0.0, 0.0), description="sinusoid amplitude, m/s")
    omega: Vec2 = Field((0.0, 0.0), description="sinusoid angular frequency, rad/s")
    phi: Vec2 = Field((0.0, 0.0), description="sinusoid phase, rad")


class TargetSpec(_Strict):
    profile: Literal["l24", "l23", "hover", "custom"] = Field(
        "l24", description="l24: linear, sinusoidal, circular (SPEC durations 40, 62.8, 50.3 s); l23: sinusoidal")
    phases: list[PhaseSpec] = Field(default_factory=list, description="with profile: custom")
    hover_duration: float = Field(60.0, gt=0, description="s, with profile: hover")
    start: Vec2 = Field((0.0, 0.0), description="initial position, m")
    velocity_gain: float = Field(1.5, gt=0, description="target autopilot velocity-loop gain, 1/s (chosen)")
    wind_std: float = Field(0.05, ge=0, description="random acceleration disturbance std, m/s² (chosen)")

    @model_validator(mode="after")
    def _phases_for_custom(self):
        if self.profile == "custom" and not self.phases:
            raise ValueError("target.phases must list at least one phase when target.profile is 'custom'")
        return self


class SwarmSpec(_Strict):
    n_uavs: int = Field(3, ge=1, le=100_000, description="number of UAVs")
    vehicle: Literal["quadrotor", "double_integrator"] = "quadrotor"
    initial_positions: list[Vec2] | None = Field(None, description="m; default: seeded random in the spawn box")
    spawn_center: Vec2 = Field((-2.0, -6.0), description="m (chosen: the papers give no initial positions)")
    spawn_half_width: float = Field(3.0, gt=0, description="m")
    min_separation: float = Field(1.0, ge=0, description="m, between spawned UAVs")
    nav_position_std: float = Field(0.02, ge=0, description="noise on a UAV's own position estimate, m")
    nav_velocity_std: float = Field(0.02, ge=0, description="noise on a UAV's own velocity estimate, m/s")

    @model_validator(mode="after")
    def _positions_match(self):
        if self.initial_positions is not None and len(self.initial_positions) != self.n_uavs:
            raise ValueError(
                f"swarm.initial_positions has {len(self.initial_positions)} entries for {self.n_uavs} UAVs")
        return self


class SensorSpec(_Strict):
    kind: Literal["range_bearing"] = "range_bearing"
    sigma_range: float = Field(0.08, gt=0, description="m (L24: 0.08, L23: 0.4)")
    sigma_bearing: float = Field(0.02, gt=0, description="rad (L24: 0.02, L23: 0.1)")
    update: Literal["position", "polar"] = Field(
        "position", description="position: converted measurement with the paper's R_i; polar: EKF on [ρ, β]")
    max_range: float | None = Field(None, gt=0, description="m; a UAV farther from the target measures nothing")
    latency: float = Field(0.0, ge=0, le=5.0, description=(
        "s, age of a measurement when the filter uses it as current (sensing and middleware delay; "
        "rounded to the physics step)"))


class NetworkSpec(_Strict):
    topology: Literal["none", "line", "ring", "full", "proximity", "edges"] = "line"
    edges: list[tuple[int, int]] = Field(default_factory=list, description="1-based UAV pairs, with topology: edges")
    r_comm: float = Field(4.8, gt=0, description="communication range, m (L24, L23)")
    loss_probability: float = Field(0.0, ge=0, lt=1, description="independent loss of each message")


class EstimatorSpec(_Strict):
    kind: Literal["information", "centralized"] = "information"
    share: Literal["information", "measurements"] = Field(
        "information", description="information: neighbours send I_j, i_j (L24 eq. 6); measurements: z_j and pose")
    model: Literal["cv", "ca", "ct", "fs"] = "ct"
    q: list[float] | None = Field(None, description="diagonal of Q; default: the paper's (L24 Sec. 4)")
    initial_information: float = Field(1e-6, gt=0, description="εI, the near-zero initial information")
    fake_vz_sigma: float = Field(0.05, gt=0, description="FS model: std of the fake vz = 0 measurement, m/s")

    @field_validator("q")
    @classmethod
    def _q_positive(cls, v):
        if v is not None:
            for k, x in enumerate(v):
                if not (math.isfinite(x) and x > 0):
                    raise ValueError(f"Q must be positive definite: diagonal entry {k} is {x}")
        return v


class FlockingSpec(_Strict):
    variant: Literal["standard", "integral", "tailored"] = "tailored"
    d: float = Field(4.0, gt=0, description="desired inter-agent distance, m")
    chase_after_steps: int = Field(20, ge=0, description="estimation steps before the UAVs start chasing (L24)")
    follow: Literal["estimate", "truth"] = Field("estimate", description="what the target term follows")
    gains: dict[str, float] = Field(default_factory=dict, description="overrides of FlockingGains fields")

    @field_validator("gains")
    @classmethod
    def _known_gains(cls, v):
        import dataclasses

        from swarmtrack.control.flocking import FlockingGains

        known = {f.name for f in dataclasses.fields(FlockingGains)} - {"d", "r_comm"}
        unknown = sorted(set(v) - known)
        if unknown:
            raise ValueError(f"unknown gain(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
        FlockingGains(**v)  # its own range checks (ε, h in (0, 1), positive lengths) raise a readable ValueError
        return v


class RatesSpec(_Strict):
    physics: float = Field(100.0, gt=0, description="Hz")
    estimation: float = Field(20.0, gt=0, description="Hz (L24, L23)")
    control: float = Field(20.0, gt=0, description="Hz")

    @model_validator(mode="after")
    def _divides(self):
        for name in ("estimation", "control"):
            ratio = self.physics / getattr(self, name)
            if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
                raise ValueError(f"rates.{name} must divide rates.physics ({self.physics} Hz)")
        return self


class Scenario(_Strict):
    name: str = "custom"
    description: str = ""
    seed: int = Field(0, ge=0)
    duration: float | None = Field(None, gt=0, description="s; default: the target profile's length")
    rates: RatesSpec = Field(default_factory=RatesSpec)
    target: TargetSpec = Field(default_factory=TargetSpec)
    swarm: SwarmSpec = Field(default_factory=SwarmSpec)
    sensor: SensorSpec = Field(default_factory=SensorSpec)
    network: NetworkSpec = Field(default_factory=NetworkSpec)
    estimator: EstimatorSpec = Field(default_factory=EstimatorSpec)
    flocking: FlockingSpec = Field(default_factory=FlockingSpec)
    kernels: Literal["auto", "numpy", "compiled"] = Field("auto", description=(
        "compiled numba fast paths (physics, flocking, CV position-update filter) that give the same numbers "
        "as the numpy reference; auto = compiled"))

    def run_duration(self) -> float:
        """Simulated time, s: ``duration`` or the length of the target's profile."""
        if self.duration is not None:
            return self.duration
        from swarmtrack.vehicles.profile import l23_profile, l24_profile

        t = self.target
        if t.profile == "l24":
            return l24_profile().total_duration
        if t.profile == "l23":
            return l23_profile().total_duration
        return t.hover_duration if t.profile == "hover" else sum(p.duration for p in t.phases)

    @model_validator(mode="after")
    def _cross_checks(self):
        n = self.swarm.n_uavs
        steps = self.run_duration() * self.rates.estimation
        record_gb = steps * n * 24 * 8 / 1e9  # estimate, UAV truth and the 4 x 4 covariance per UAV per step
        if record_gb > 8.0:
            raise ValueError(f"duration x swarm.n_uavs is too large to record: {steps:.0f} estimation steps x {n} "
                             f"UAVs needs {record_gb:.0f} GB (limit 8 GB)")
        for e in self.network.edges:
            for v in e:
                if not 1 <= v <= n:
                    raise ValueError(f"network.edges names UAV {v}, but the swarm has UAVs 1..{n}")
        if self.estimator.q is not None:
            from swarmtrack.models import make_model

            dim = make_model(self.estimator.model, 0.05).dim
            if len(self.estimator.q) != dim:
                raise ValueError(f"estimator.q has {len(self.estimator.q)} entries; model "
                                 f"{self.estimator.model!r} has {dim} states")
        return self
