"""Scenario files: validated once, at the edge (pydantic). Units are in the field descriptions.

Every value a paper leaves open has a default here that says where it came from.
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, SerializeAsAny, ValidationInfo, field_validator, model_validator


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


class MemberSpec(_Strict):
    """One driven vehicle (a target or a decoy): where it starts and the velocity profile its autopilot flies."""

    profile: Literal["l24", "l23", "hover", "custom"] = Field(
        "l24", description="l24: linear, sinusoidal, circular (SPEC durations 40, 62.8, 50.3 s); l23: sinusoidal")
    phases: list[PhaseSpec] = Field(default_factory=list, description="with profile: custom")
    hover_duration: float = Field(60.0, gt=0, description="s, with profile: hover")
    start: Vec2 = Field((0.0, 0.0), description="initial position, m")

    @model_validator(mode="after")
    def _phases_for_custom(self):
        if self.profile == "custom" and not self.phases:
            raise ValueError("phases must list at least one phase when profile is 'custom'")
        return self

    def velocity_profile(self):
        """The :class:`~swarmtrack.vehicles.profile.VelocityProfile` this member flies."""
        from swarmtrack.vehicles.profile import Phase, VelocityProfile, l23_profile, l24_profile

        if self.profile == "l24":
            return l24_profile()
        if self.profile == "l23":
            return l23_profile()
        if self.profile == "hover":
            return VelocityProfile((Phase("hover", self.hover_duration),))
        return VelocityProfile(tuple(Phase(p.name, p.duration, tuple(p.c), tuple(p.amplitude), tuple(p.omega),
                                           tuple(p.phi)) for p in self.phases))


class GroupSpec(_Strict):
    """A named group of driven vehicles (``targets``, ``decoys``): one vehicle kind, any number of members, each
    flying its own velocity profile through the same autopilot (feed-forward + P velocity loop) and wind."""

    vehicle: Literal["quadrotor", "double_integrator"] = Field(
        "quadrotor", description="quadrotor: Iris-like, attitude loop and tilt limits (L24); double_integrator")
    velocity_gain: float = Field(1.5, gt=0, description="autopilot velocity-loop gain, 1/s (chosen)")
    wind_std: float = Field(0.05, ge=0, description="random acceleration disturbance std, m/s² (chosen)")
    members: list[MemberSpec] = Field(default_factory=list)


#: Keys of the one-target shorthand ``target:`` that belong to the group rather than to its member.
_GROUP_KEYS = ("vehicle", "velocity_gain", "wind_std")


def _one_target(target: dict) -> dict:
    """``target: {...}`` (one quadrotor target, capability 1's files) as the group ``targets``."""
    group = {k: target[k] for k in _GROUP_KEYS if k in target}
    group["members"] = [{k: v for k, v in target.items() if k not in _GROUP_KEYS}]
    return group


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
    """Base of every estimator's settings; ``kind`` picks the implementation (see :data:`ESTIMATOR_KINDS`)."""

    kind: str

    def followed_target(self) -> int | None:
        """The member of ``targets`` (1-based) this estimator follows, which the recording's capability-1 metrics
        and ``controller.follow: truth`` refer to; None: it follows no single target."""
        return None


class ControllerSpec(_Strict):
    """Base of every controller's settings; ``kind`` picks the implementation (see :data:`CONTROLLER_KINDS`)."""

    kind: str


class FilterSpec(EstimatorSpec):
    """An EKF over one target motion model, following the target ``target`` (1-based member of ``targets``,
    recognised onboard by the label its sensor reports)."""

    share: Literal["information", "measurements"] = Field(
        "information", description="information: neighbours send I_j, i_j (L24 eq. 6); measurements: z_j and pose")
    model: Literal["cv", "ca", "ct", "fs"] = "ct"
    q: list[float] | None = Field(None, description="diagonal of Q; default: the paper's (L24 Sec. 4)")
    initial_information: float = Field(1e-6, gt=0, description="εI, the near-zero initial information")
    fake_vz_sigma: float = Field(0.05, gt=0, description="FS model: std of the fake vz = 0 measurement, m/s")
    target: int = Field(1, ge=1, description="which member of the targets group the filter follows (1-based)")

    def followed_target(self) -> int | None:
        return self.target

    @field_validator("q")
    @classmethod
    def _q_positive(cls, v, info: ValidationInfo):
        if v is not None:
            for k, x in enumerate(v):
                if not (math.isfinite(x) and x > 0):
                    raise ValueError(f"Q must be positive definite: diagonal entry {k} is {x}")
            if "model" in info.data:
                from swarmtrack.models import make_model

                dim = make_model(info.data["model"], 0.05).dim
                if len(v) != dim:
                    raise ValueError(f"has {len(v)} entries; model {info.data['model']!r} has {dim} states")
        return v


class InformationSpec(FilterSpec):
    """Decentralized information-form EKF, one per UAV, fused over the topology's links (L24 Sec. 3)."""

    kind: Literal["information"] = "information"


class CentralizedSpec(FilterSpec):
    """One fusion centre over every UAV's measurement (the baseline; ``share`` does not apply)."""

    kind: Literal["centralized"] = "centralized"


class FlockingSpec(ControllerSpec):
    kind: Literal["flocking"] = "flocking"
    variant: Literal["standard", "integral", "tailored"] = "tailored"
    d: float = Field(4.0, gt=0, description="desired inter-agent distance, m")
    chase_after_steps: int = Field(20, ge=0, description="estimation steps before the UAVs start chasing (L24)")
    follow: Literal["estimate", "truth"] = Field(
        "estimate", description="what the target term follows; truth wires an oracle (not onboard) to the controller")
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


#: ``kind`` → settings class of every estimator and controller the scenario can pick; the simulator's builders
#: are registered beside them (:func:`swarmtrack.sim.build.register`), so a new capability adds an entry here,
#: not a branch in the engine.
ESTIMATOR_KINDS: dict[str, type[EstimatorSpec]] = {"information": InformationSpec, "centralized": CentralizedSpec}
CONTROLLER_KINDS: dict[str, type[ControllerSpec]] = {"flocking": FlockingSpec}


def _by_kind(value, kinds: dict, default: str, base: type):
    """Validate a ``kind``-tagged section with the settings class its kind names (a tagged union whose members
    come from a registry, so a registered kind needs no change to this schema)."""
    if isinstance(value, base):
        return value
    if not isinstance(value, dict):
        raise ValueError("must be a mapping of keys to values")
    kind = value.get("kind", default)
    if kind not in kinds:
        raise ValueError(f"unknown kind {kind!r}; known: {', '.join(sorted(kinds))}")
    return kinds[kind].model_validate(value)


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
    name: str = Field("custom", pattern=r"^[A-Za-z0-9_.-]+$", description=(
        "a label (letters, digits, '-', '_', '.'; not '.' or '..'), never a path"))
    description: str = ""
    seed: int = Field(0, ge=0)
    duration: float | None = Field(None, gt=0, description="s; default: the longest driven member's profile")
    rates: RatesSpec = Field(default_factory=RatesSpec)
    targets: GroupSpec = Field(default_factory=lambda: GroupSpec(members=[MemberSpec()]), description=(
        "the objects the swarm tracks; ``target: {...}`` is the shorthand for one quadrotor target"))
    decoys: GroupSpec = Field(default_factory=GroupSpec, description="objects a sensor may confuse with targets")
    swarm: SwarmSpec = Field(default_factory=SwarmSpec)
    sensor: SensorSpec = Field(default_factory=SensorSpec)
    network: NetworkSpec = Field(default_factory=NetworkSpec)
    estimator: SerializeAsAny[EstimatorSpec] = Field(default_factory=InformationSpec)
    controller: SerializeAsAny[ControllerSpec] = Field(default_factory=FlockingSpec)
    kernels: Literal["auto", "numpy", "compiled"] = Field("auto", description=(
        "compiled numba fast paths (physics, flocking, CV position-update filter) that give the same numbers "
        "as the numpy reference; auto = compiled"))

    @model_validator(mode="before")
    @classmethod
    def _shorthands(cls, data):
        """``target:`` (one target) and ``flocking:`` (the controller of capability 1's first files)."""
        if not isinstance(data, dict):
            return data
        data = dict(data)
        for old, new, convert in (("target", "targets", _one_target),
                                  ("flocking", "controller", lambda f: {"kind": "flocking", **f})):
            if old in data:
                if new in data:
                    raise ValueError(f"give either {old!r} or {new!r}, not both")
                section = data.pop(old)
                data[new] = convert(section) if isinstance(section, dict) else section
        return data

    @field_validator("name")
    @classmethod
    def _name_is_a_label(cls, v: str) -> str:
        if v in (".", ".."):
            raise ValueError(f"{v!r} is not a label (it names a folder)")
        return v

    @field_validator("estimator", mode="before")
    @classmethod
    def _estimator_kind(cls, v):
        return _by_kind(v, ESTIMATOR_KINDS, "information", EstimatorSpec)

    @field_validator("controller", mode="before")
    @classmethod
    def _controller_kind(cls, v):
        return _by_kind(v, CONTROLLER_KINDS, "flocking", ControllerSpec)

    def run_duration(self) -> float:
        """Simulated time, s: ``duration`` or the length of the longest driven member's profile."""
        if self.duration is not None:
            return self.duration
        members = self.targets.members + self.decoys.members
        return max((m.velocity_profile().total_duration for m in members), default=60.0)

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
        r = self.rates
        step = round(r.physics / r.estimation) / r.physics
        if round(self.run_duration() / step) < 1:
            raise ValueError(f"duration {self.run_duration():g} s is shorter than one estimation step ({step:g} s)")
        followed = self.estimator.followed_target()
        if followed is not None and not 1 <= followed <= len(self.targets.members):
            raise ValueError(f"estimator.target is {followed}, but targets has {len(self.targets.members)} member(s)")
        if getattr(self.controller, "follow", None) == "truth" and followed is None:
            raise ValueError("controller.follow: truth needs an estimator that follows one target")
        return self
