"""Scenario files: validated once, at the edge (pydantic). Units are in the field descriptions.

Every value a paper leaves open has a default here that says where it came from.
"""

from __future__ import annotations

import math
import typing
from typing import Annotated, Literal

import numpy as np
from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    SerializeAsAny,
    ValidationInfo,
    field_validator,
    model_validator,
)


def _is_numeric(annotation) -> bool:
    """Whether a field's type holds numbers anywhere (``float``, ``tuple[float, float]``, ``dict[str, float]``)."""
    return annotation in (int, float) or any(_is_numeric(a) for a in typing.get_args(annotation))


def _holds_bool(value) -> bool:
    if isinstance(value, bool):
        return True
    if isinstance(value, (list, tuple)):
        return any(_holds_bool(v) for v in value)
    if isinstance(value, dict):
        return any(_holds_bool(v) for v in value.values())
    return False


def _is_default(model: type[BaseModel], field: str, value) -> bool:
    """Whether ``value`` is ``field``'s default: a key the chosen option ignores is let through at its default, so
    that a resolved scenario.yaml (every default spelled out) loads again."""
    return value == model.model_fields[field].get_default(call_default_factory=True)


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    @field_validator("*", mode="before")
    @classmethod
    def _no_booleans_for_numbers(cls, v, info: ValidationInfo):
        """pydantic reads ``true`` as 1 in an int or float field (``n_uavs: true`` would fly one UAV)."""
        if _is_numeric(cls.model_fields[info.field_name].annotation) and _holds_bool(v):
            raise ValueError("true/false is not a number")
        return v


# Upper bounds on physical quantities. Each is far beyond any small-UAV scenario, yet small enough that the
# squares and products the simulation forms (d², K·d, ω·t, rate x duration) stay finite in float64, so absurd
# input is refused here, naming its field, instead of overflowing mid-run ("estimator diverged", inf RMSE).
MAX_LENGTH = 1e6  #: m: 1000 km, beyond any radio or sensor range of a UAV swarm
MAX_SPEED = 1e3  #: m/s: about Mach 3
MAX_ACCELERATION = 1e3  #: m/s²: about 100 g
MAX_ANGULAR_RATE = 1e3  #: rad/s: about 160 turns a second
MAX_ANGLE = 1e3  #: rad: about 160 turns
MAX_TIME = 1e7  #: s: about four months
MAX_RATE = 1e4  #: Hz: ten times a fast attitude loop
MAX_GAIN = 1e6  #: any gain or noise intensity (s⁻¹, s⁻², m²/s³, 1/m²)


def _limit_text(limit: float) -> str:
    return f"{limit:.0e}".replace("e+0", "e").replace("e+", "e")


def _at_most(limit: float, unit: str) -> AfterValidator:
    """Refuse a value larger than ``limit`` in magnitude, naming the unit."""
    u = f" {unit}" if unit else ""

    def check(v: float) -> float:
        if abs(v) > limit:
            raise ValueError(f"{v:g}{u} is beyond the limit of {_limit_text(limit)}{u} in magnitude")
        return v

    return AfterValidator(check)


Length = Annotated[float, _at_most(MAX_LENGTH, "m")]
Speed = Annotated[float, _at_most(MAX_SPEED, "m/s")]
Acceleration = Annotated[float, _at_most(MAX_ACCELERATION, "m/s²")]
AngularRate = Annotated[float, _at_most(MAX_ANGULAR_RATE, "rad/s")]
Angle = Annotated[float, _at_most(MAX_ANGLE, "rad")]
Time = Annotated[float, _at_most(MAX_TIME, "s")]
Rate = Annotated[float, _at_most(MAX_RATE, "Hz")]
Gain = Annotated[float, _at_most(MAX_GAIN, "")]

Position = tuple[Length, Length]


def _box(v):
    if not (v[0] < v[2] and v[1] < v[3]):
        raise ValueError(f"{list(v)} must be [x0, y0, x1, y1] with x0 < x1 and y0 < y1")
    return v


def _half_widths(v):
    if min(v) <= 0:
        raise ValueError(f"{list(v)} must be two positive half-widths")
    return v


#: A box ``[x0, y0, x1, y1]`` (m) with x0 < x1 and y0 < y1.
Box = Annotated[tuple[Length, Length, Length, Length], AfterValidator(_box)]
#: Two positive half-widths (m), one per axis.
HalfWidths = Annotated[tuple[Length, Length], AfterValidator(_half_widths)]


def _split_commas(v):
    """``"cv,ca,ct"`` (handy with ``--set``) as ``["cv", "ca", "ct"]``; anything else unchanged."""
    return [m.strip() for m in v.split(",")] if isinstance(v, str) else v


_COMMA_LIST = BeforeValidator(_split_commas)
Velocity = tuple[Speed, Speed]


class PhaseSpec(_Strict):
    """One phase of the target's velocity profile; each axis flies ``c + A·sin(ω·τ + φ)``, τ from phase start."""

    name: str
    duration: Time = Field(gt=0, description="s (at most 1e7 s: about four months)")
    c: Velocity = Field((0.0, 0.0), description="constant velocity term, m/s (at most 1e3 m/s: about Mach 3)")
    amplitude: Velocity = Field((0.0, 0.0), description="sinusoid amplitude, m/s (at most 1e3 m/s)")
    omega: tuple[AngularRate, AngularRate] = Field((0.0, 0.0), description=(
        "sinusoid angular frequency, rad/s (at most 1e3 rad/s: far above any flyable manoeuvre)"))
    phi: tuple[Angle, Angle] = Field((0.0, 0.0), description="sinusoid phase, rad (at most 1e3 rad)")
    accel: tuple[Acceleration, Acceleration] = Field((0.0, 0.0), description=(
        "constant acceleration term, m/s² (v = c + accel·τ + A·sin(ωτ + φ); at most 1e3 m/s²)"))


class SegmentSpec(_Strict):
    """One segment of a ground robot's drive (unicycle): ``cv`` keeps speed and heading, ``ca`` accelerates by
    ``value`` m/s² along the heading, ``ct`` turns at ``value`` rad/s at constant speed."""

    kind: Literal["cv", "ca", "ct"]
    duration: Time = Field(gt=0, description="s")
    value: float = Field(0.0, ge=-MAX_ANGULAR_RATE, le=MAX_ANGULAR_RATE, description=(
        "ca: m/s²; ct: rad/s; cv: unused"))


class EvasiveSpec(_Strict):
    """Frequent random manoeuvres of a ground robot, drawn from the scenario's seed (stream
    ``manoeuvres/<group>/<member>``): segments of random kind and length that keep it inside a square."""

    duration: Time = Field(60.0, gt=0, description="s")
    half_width: Length = Field(1.0, gt=0, description="m, the robot stays in |x|, |y| <= half_width (W20: ~4 m²)")
    segment_range: tuple[Time, Time] = Field((0.5, 2.0), description="s, shortest and longest segment")
    speed_range: tuple[Speed, Speed] = Field((0.1, 0.3), description="m/s")
    turn_rate_max: AngularRate = Field(1.0, gt=0, description="rad/s")
    accel_max: Acceleration = Field(0.1, gt=0, description="m/s²")


class MemberSpec(_Strict):
    """One driven vehicle (a target or a decoy): where it starts and the velocity profile its autopilot flies."""

    profile: Literal["l24", "l23", "hover", "custom", "ground", "evasive"] = Field(
        "l24", description=("l24: linear, sinusoidal, circular (SPEC durations 40, 62.8, 50.3 s); l23: sinusoidal; "
                            "ground: a ground robot's cv/ca/ct segments; evasive: random ground-robot manoeuvres"))
    phases: list[PhaseSpec] = Field(default_factory=list, description="with profile: custom")
    hover_duration: Time = Field(60.0, gt=0, description="s, with profile: hover (at most 1e7 s)")
    segments: list[SegmentSpec] = Field(default_factory=list, description="with profile: ground")
    evasive: EvasiveSpec = Field(default_factory=EvasiveSpec, description="with profile: evasive")
    heading: Angle = Field(0.0, description="rad, initial heading of a ground or evasive profile")
    speed: Speed = Field(0.0, ge=0, description="m/s, initial speed of a ground or evasive profile")
    start: Position = Field((0.0, 0.0), description=(
        "initial position, m (at most 1e6 m from the origin per axis: 1000 km, beyond any radio range)"))

    @field_validator("phases", "hover_duration", "segments", "evasive", "heading", "speed")
    @classmethod
    def _used_by_profile(cls, v, info: ValidationInfo):
        """A key the chosen profile ignores is a mistake (a custom profile without ``profile: custom`` would
        silently fly l24); the default value is let through, so a resolved scenario.yaml loads again."""
        needs = {"phases": ("custom",), "hover_duration": ("hover",), "segments": ("ground",),
                 "evasive": ("evasive",), "heading": ("ground", "evasive"), "speed": ("ground", "evasive")}
        needs = needs[info.field_name]
        profile = info.data.get("profile")
        if profile is not None and profile not in needs and not _is_default(cls, info.field_name, v):
            raise ValueError(f"given, but profile is {profile!r}; {info.field_name} is used only with profile: "
                             + " or ".join(needs))
        return v

    @model_validator(mode="after")
    def _phases_for_custom(self):
        if self.profile == "custom" and not self.phases:
            raise ValueError("phases must list at least one phase when profile is 'custom'")
        if self.profile == "ground":
            if not self.segments:
                raise ValueError("segments must list at least one segment when profile is 'ground'")
            self.velocity_profile()  # a segment that would drive backwards is refused here, naming it
        return self

    def duration(self) -> float:
        """Length of the profile, s (without drawing an evasive one)."""
        return self.evasive.duration if self.profile == "evasive" else self.velocity_profile().total_duration

    def velocity_profile(self, rng=None):
        """The :class:`~swarmtrack.vehicles.profile.VelocityProfile` this member flies; an evasive one draws its
        manoeuvres from ``rng`` (a ``numpy.random.Generator``)."""
        from swarmtrack.vehicles.profile import (
            Phase,
            VelocityProfile,
            evasive_segments,
            ground_robot_profile,
            l23_profile,
            l24_profile,
        )

        if self.profile == "l24":
            return l24_profile()
        if self.profile == "l23":
            return l23_profile()
        if self.profile == "hover":
            return VelocityProfile((Phase("hover", self.hover_duration),))
        if self.profile == "ground":
            return ground_robot_profile([(s.kind, s.duration, s.value) for s in self.segments], self.heading,
                                        self.speed)
        if self.profile == "evasive":
            e = self.evasive
            if rng is None:
                raise ValueError("an evasive profile draws its manoeuvres from a random stream: pass rng")
            segments = evasive_segments(rng, e.duration, start=tuple(self.start), heading=self.heading,
                                        speed=self.speed, half_width=e.half_width, segment_range=tuple(e.segment_range),
                                        speed_range=tuple(e.speed_range), turn_rate_max=e.turn_rate_max,
                                        accel_max=e.accel_max)
            return ground_robot_profile(segments, self.heading, self.speed)
        return VelocityProfile(tuple(Phase(p.name, p.duration, tuple(p.c), tuple(p.amplitude), tuple(p.omega),
                                           tuple(p.phi), accel=tuple(p.accel)) for p in self.phases))


class GroupSpec(_Strict):
    """A named group of driven vehicles (``targets``, ``decoys``): one vehicle kind, any number of members, each
    flying its own velocity profile through the same autopilot (feed-forward + P velocity loop) and wind."""

    vehicle: Literal["quadrotor", "double_integrator", "walker"] = Field(
        "quadrotor", description=("quadrotor: Iris-like, attitude loop and tilt limits (L24); double_integrator; "
                                  "walker: constant speed, random-walk yaw rate, reflected at the area's border "
                                  "(IB21 Sec. 6)"))
    velocity_gain: Gain = Field(1.5, gt=0, description="autopilot velocity-loop gain, 1/s (chosen; at most 1e6)")
    wind_std: Acceleration = Field(0.05, ge=0, description=(
        "random acceleration disturbance std, m/s² (chosen; at most 1e3 m/s²: about 100 g)"))
    members: list[MemberSpec] = Field(default_factory=list)
    count: int = Field(0, ge=0, le=10_000, description=(
        "walker: members placed at seeded uniform positions in the area with uniform headings (IB21 Sec. 6)"))
    speed: Speed = Field(1.0, gt=0, description="walker: speed V^t, m/s (IB21: 1; Fig. 9: 1.0-1.8)")
    yaw_accel_bound: AngularRate = Field(0.39269908169872414, gt=0, description=(
        "walker: yaw acceleration drawn from U(−b, b) every physics step, rad/s² (IB21: π/8)"))
    area: Box = Field((0.0, 0.0, 400.0, 400.0), description=(
        "walker: [x0, y0, x1, y1], m, where the walkers start and stay (IB21: a 400 m square)"))

    @model_validator(mode="after")
    def _walkers(self):
        if self.vehicle != "walker":
            for name in ("count", "speed", "yaw_accel_bound", "area"):
                if not _is_default(type(self), name, getattr(self, name)):
                    raise ValueError(f"{name} is used only with vehicle: walker")
        return self

    def size(self) -> int:
        return self.count + len(self.members)


#: Keys of the one-target shorthand ``target:`` that belong to the group rather than to its member.
_GROUP_KEYS = ("vehicle", "velocity_gain", "wind_std")


def _one_target(target: dict) -> dict:
    """``target: {...}`` (one quadrotor target, capability 1's files) as the group ``targets``."""
    group = {k: target[k] for k in _GROUP_KEYS if k in target}
    group["members"] = [{k: v for k, v in target.items() if k not in _GROUP_KEYS}]
    return group


class FixedWingSpec(_Strict):
    """A fixed-wing UAV at constant speed and altitude steered by its yaw acceleration (IB21 Sec. 6)."""

    speed: Speed = Field(16.6, gt=0, description="m/s (IB21: 16.6)")
    altitude: Length = Field(100.0, gt=0, description="m (IB21: 100)")
    yaw_rate_max: AngularRate = Field(0.6, gt=0, description="rad/s (ours: ≈ 45° of bank; IB21 gives none)")


class SwarmSpec(_Strict):
    n_uavs: int = Field(3, ge=1, le=100_000, description="number of UAVs")
    vehicle: Literal["quadrotor", "double_integrator", "fixed_wing"] = "quadrotor"
    fixed_wing: FixedWingSpec = Field(default_factory=FixedWingSpec, description="with vehicle: fixed_wing")
    initial_positions: list[Position] | None = Field(None, description=(
        "m (at most 1e6 m per axis); default: seeded random in the spawn box"))
    spawn_center: Position = Field((-2.0, -6.0), description=(
        "m (chosen: the papers give no initial positions; at most 1e6 m per axis)"))
    spawn_half_width: Length = Field(3.0, gt=0, description="m (at most 1e6 m)")
    min_separation: Length = Field(1.0, ge=0, description="m, between spawned UAVs (at most 1e6 m)")
    nav_position_std: Length = Field(0.02, ge=0, description="noise on a UAV's own position estimate, m (≤ 1e6 m)")
    nav_velocity_std: Speed = Field(0.02, ge=0, description=(
        "noise on a UAV's own velocity estimate, m/s (at most 1e3 m/s)"))

    @field_validator("spawn_center", "spawn_half_width", "min_separation")
    @classmethod
    def _spawn_box_unused(cls, v, info: ValidationInfo):
        """The spawn box is not used when ``initial_positions`` is given (its default value is let through, so a
        resolved scenario.yaml loads again)."""
        if info.data.get("initial_positions") is not None and not _is_default(cls, info.field_name, v):
            raise ValueError("given, but swarm.initial_positions places the UAVs; the spawn box is not used")
        return v

    @model_validator(mode="after")
    def _positions_match(self):
        if self.initial_positions is not None and len(self.initial_positions) != self.n_uavs:
            raise ValueError(
                f"swarm.initial_positions has {len(self.initial_positions)} entries for {self.n_uavs} UAVs")
        return self


class OccluderSpec(_Strict):
    """Hides the target from some UAVs (all when ``uavs`` is empty) inside a ground region, during a time window, or
    inside the region during the window."""

    region: tuple[Length, Length, Length, Length] | None = Field(None, description="[x0, y0, x1, y1], m")
    window: tuple[Time, Time] | None = Field(None, description="[t0, t1), s")
    uavs: list[int] = Field(default_factory=list, description="1-based UAVs it hides the target from; empty: all")

    @model_validator(mode="after")
    def _something(self):
        if self.region is None and self.window is None:
            raise ValueError("an occluder needs a region, a window or both")
        if self.region is not None and not (self.region[0] < self.region[2] and self.region[1] < self.region[3]):
            raise ValueError(f"region {list(self.region)} must be [x0, y0, x1, y1] with x0 < x1 and y0 < y1")
        if self.window is not None and not 0 <= self.window[0] < self.window[1]:
            raise ValueError(f"window {list(self.window)} must be [t0, t1) with 0 <= t0 < t1")
        return self


class SensorSpec(_Strict):
    """Base of every sensor's settings; ``kind`` picks the sensor (see :data:`SENSOR_KINDS`)."""

    kind: str
    latency: float = Field(0.0, ge=0, le=5.0, description=(
        "s, age of a measurement when the filter uses it as current (sensing and middleware delay; "
        "rounded to the physics step)"))
    occluders: list[OccluderSpec] = Field(default_factory=list, description=(
        "what hides the target from some UAVs (a region, a time window or both)"))

    def check(self, scenario: Scenario) -> None:
        """Checks against the rest of the scenario (raise ValueError naming the field)."""
        n = scenario.swarm.n_uavs
        for k, occ in enumerate(self.occluders):
            for u in occ.uavs:
                if not 1 <= u <= n:
                    raise ValueError(f"sensor.occluders[{k}].uavs names UAV {u}, but the swarm has UAVs 1..{n}")


class RangeBearingSpec(SensorSpec):
    """Range and bearing from each UAV to every object (L24 Sec. 3.2)."""

    kind: Literal["range_bearing"] = "range_bearing"
    sigma_range: Length = Field(0.08, gt=0, description="m (L24: 0.08, L23: 0.4; at most 1e6 m)")
    sigma_bearing: Angle = Field(0.02, gt=0, description="rad (L24: 0.02, L23: 0.1; at most 1e3 rad)")
    update: Literal["position", "polar"] = Field(
        "position", description="position: converted measurement with the paper's R_i; polar: EKF on [ρ, β]")
    max_range: Length | None = Field(None, gt=0, description=(
        "m (at most 1e6 m); a UAV farther from the target measures nothing"))


class CameraSpec(SensorSpec):
    """Gimballed camera reporting the target's metric position in its frame (W20 eqs. 4.14-4.16), aimed at its
    UAV's latest estimate; the target is on flat ground."""

    kind: Literal["camera"] = "camera"
    sigma: Length = Field(0.0316, gt=0, description=(
        "m, camera-frame noise per axis (chosen: √(10 cm²), W20 Table 4.1's R = 10 read in cm²; at most 1e6 m)"))
    height: Length = Field(1.5, gt=0, description="m, camera height above the ground (W20 Sec. 3.2.2.2: at most 1.5)")
    footprint: tuple[Length, Length] = Field((1.2, 0.9), description=(
        "m, field of view (width, height) at footprint_range (W20 Sec. 3.2.2.2: 1.2 x 0.9 at 1.5 m)"))
    footprint_range: Length = Field(1.5, gt=0, description="m, distance at which the footprint is measured")
    home: Position = Field((0.0, 0.0), description="m, where gimbals aim before their UAV has an estimate")

    @field_validator("footprint")
    @classmethod
    def _positive(cls, v):
        if min(v) <= 0:
            raise ValueError(f"{list(v)} must be positive")
        return v


class OutageSpec(_Strict):
    """UAVs that neither send nor receive any message during a time window (W20 Sec. 5.4.4.3: "lose communication
    with the other UAVs")."""

    uavs: list[int] = Field(min_length=1, description="1-based UAVs cut off")
    window: tuple[Time, Time] = Field(description="[t0, t1), s")

    @model_validator(mode="after")
    def _ordered(self):
        if not 0 <= self.window[0] < self.window[1]:
            raise ValueError(f"window {list(self.window)} must be [t0, t1) with 0 <= t0 < t1")
        return self


class FootprintSpec(SensorSpec):
    """IB21's downward camera on fixed-wing UAVs: every walker in the footprint detected with box noise, identified
    only from inside a narrow cone (Sec. 3.2, Sec. 6, eqs. 50-54; our readings in docs/set-membership.md)."""

    kind: Literal["footprint"] = "footprint"
    opening: Angle = Field(0.7853981633974483, gt=0, description="rad, in azimuth and elevation (IB21: π/4)")
    convention: Literal["full", "half"] = Field("full", description=(
        "full: the opening is the full angle (82.8 m square at 100 m); half: the half angle (200 m)"))
    orientation: Literal["heading", "north"] = Field("heading", description="the footprint's sides")
    noise_bound: HalfWidths = Field((5.0, 5.0), description=(
        "m, the TRUE noise half-widths per axis (uniform; IB21: 5)"))
    confusion: Literal["outside_inner_cone", "inside_inner_cone"] = Field("outside_inner_cone", description=(
        "where a decoy is confused with a target: outside its inner π/60 cone (the text, Fig. 3) or inside (eq. 53)"))

    def check(self, scenario: Scenario) -> None:
        if scenario.swarm.vehicle != "fixed_wing":
            raise ValueError("sensor.kind footprint needs swarm.vehicle: fixed_wing")
        for group in ("targets", "decoys"):
            g = getattr(scenario, group)
            if g.size() and g.vehicle != "walker":
                raise ValueError(f"sensor.kind footprint needs {group}.vehicle: walker")
        if self.latency or self.occluders:
            raise ValueError("sensor.kind footprint has no latency or occluders")


class LiarSpec(_Strict):
    """One UAV whose estimation broadcasts lie, its own filter staying honest (network/faults.py)."""

    uav: int = Field(ge=1, description="1-based UAV that lies")
    mode: Literal["bias", "random"] = Field("bias", description=(
        "bias: claims the target at its measurement plus offset; random: plus a fresh N(0, sigma² I) each step"))
    offset: tuple[Length, Length] = Field((2.0, 0.0), description="m, the bias's displacement")
    sigma: Length = Field(2.0, gt=0, description="m, the random lie's standard deviation per axis")
    start: Time = Field(0.0, ge=0, description="s, when it starts lying")


class NetworkSpec(_Strict):
    topology: Literal["none", "line", "ring", "full", "proximity", "edges"] = "line"
    edges: list[tuple[int, int]] = Field(default_factory=list, description="1-based UAV pairs, with topology: edges")
    r_comm: Length = Field(4.8, gt=0, description="communication range, m (L24, L23; at most 1e6 m)")
    loss_probability: float = Field(0.0, ge=0, lt=1, description="independent loss of each message")
    outages: list[OutageSpec] = Field(default_factory=list, description="UAVs cut off from the network for a while")
    delay: Time = Field(0.0, ge=0, description=(
        "s, every estimation message's delay on every link (delivered at the first estimation step at or after "
        "it; flocking beacons are not delayed)"))
    liar: LiarSpec | None = Field(None, description="a member whose broadcasts lie (estimator.gating defends)")
    delay_max: Time | None = Field(None, ge=0, description=(
        "s, with it each message's delay is uniform in [delay, delay_max], drawn per link and step (reorders "
        "messages)"))

    @model_validator(mode="after")
    def _delay_range(self):
        if self.delay_max is not None and self.delay_max < self.delay:
            raise ValueError(f"delay_max ({self.delay_max:g} s) is smaller than delay ({self.delay:g} s)")
        return self

    def delay_bound(self) -> float:
        """The longest delay a message can take, s."""
        return self.delay if self.delay_max is None else self.delay_max

    @field_validator("edges")
    @classmethod
    def _edges_for_edges_topology(cls, v, info: ValidationInfo):
        topology = info.data.get("topology")
        if v and topology is not None and topology != "edges":
            raise ValueError(f"given, but network.topology is {topology!r}; edges are used only with topology: edges")
        for a, b in v:
            if a == b:
                raise ValueError(f"[{a}, {b}] is a self-loop (a UAV does not link to itself)")
        return v


class EstimatorSpec(_Strict):
    """Base of every estimator's settings; ``kind`` picks the implementation (see :data:`ESTIMATOR_KINDS`)."""

    kind: str

    def followed_target(self) -> int | None:
        """The member of ``targets`` (1-based) this estimator follows, which the recording's capability-1 metrics
        and ``controller.follow: truth`` refer to; None: it follows no single target."""
        return None

    def warmup_steps(self) -> int:
        """Estimation steps the estimator needs before its output is judged (metrics start after them)."""
        return 0

    def check(self, scenario: Scenario) -> None:
        """Checks against the rest of the scenario (raise ValueError naming the field)."""


class ControllerSpec(_Strict):
    """Base of every controller's settings; ``kind`` picks the implementation (see :data:`CONTROLLER_KINDS`)."""

    kind: str

    def check(self, scenario: Scenario) -> None:
        """Checks against the rest of the scenario (raise ValueError naming the field)."""


class FilterSpec(EstimatorSpec):
    """An EKF over one target motion model, following the target ``target`` (1-based member of ``targets``,
    recognised onboard by the label its sensor reports)."""

    share: Literal["information", "measurements"] = Field(
        "information", description="information: neighbours send I_j, i_j (L24 eq. 6); measurements: z_j and pose")
    model: Literal["cv", "ca", "ct", "fs"] = "ct"
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

    def check(self, scenario: Scenario) -> None:
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
                from swarmtrack.models import make_model

                dim = make_model(info.data["model"], 0.05).dim
                if len(v) != dim:
                    raise ValueError(f"has {len(v)} entries; model {info.data['model']!r} has {dim} states")
        return v


def refiltered_steps(scenario: Scenario) -> int:
    """How many estimation steps late a datum can arrive: the sensor's latency (a whole number of steps, checked)
    plus the steps the channel holds a message (:func:`swarmtrack.network.channel.delay_steps`), for a filter that
    hears neighbours (a fusion centre or a UAV without links gets no message)."""
    from swarmtrack.network.channel import delay_steps

    period = 1.0 / scenario.rates.estimation
    steps = round(getattr(scenario.sensor, "latency", 0.0) / period)
    if scenario.estimator.kind != "centralized" and scenario.network.topology != "none":
        steps += int(delay_steps(scenario.network.delay_bound(), period))
    return steps


class InformationSpec(FilterSpec):
    """Decentralized information-form EKF, one per UAV, fused over the topology's links (L24 Sec. 3)."""

    kind: Literal["information"] = "information"


class CentralizedSpec(FilterSpec):
    """One fusion centre over every UAV's measurement (the baseline; ``share`` does not apply)."""

    kind: Literal["centralized"] = "centralized"


W20_MODELS = ("cv", "ca", "ct")


class MultiModelSpec(EstimatorSpec):
    """W20's multi-model distributed EKF: one covariance EKF per UAV with its own model, stacked neighbour
    measurements, fusion of the models' estimates (W20 Ch. 4). Defaults: W20 Tables 4.1 and 4.3, with Q, R and P0
    read in centimetre units (see docs/multi-model.md)."""

    kind: Literal["multimodel"] = "multimodel"
    models: Annotated[list[Literal["cv", "ca", "ct"]], _COMMA_LIST] = Field(["cv", "ca", "ct"], description=(
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
        if v is None:
            return v
        for k, row in enumerate(v):
            if len(row) != len(v):
                raise ValueError(f"must be square: row {k + 1} has {len(row)} entries for {len(v)} rows")
            if any(not math.isfinite(x) or x < 0 for x in row):
                raise ValueError(f"row {k + 1} has a negative or non-finite entry: {row}")
            if abs(sum(row) - 1.0) > 1e-9:
                raise ValueError(f"row {k + 1} sums to {sum(row):.6g}, not 1: {row}")
        return v

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


class IMMSpec(EstimatorSpec):
    """A bank of information filters per UAV, one per model, combined by an IMM with mixing through the common block
    [x, y, vx, vy] (L24's future work; swarmtrack.estimation.imm). Other keys as in the information estimator."""

    kind: Literal["imm"] = "imm"
    share: Literal["information", "measurements"] = Field("information", description=(
        "information: one I_j, i_j per UAV, linearised at its combined prediction; measurements: z_j and pose, "
        "each model linearises at its own prediction"))
    models: Annotated[list[Literal["cv", "ct", "fs"]], _COMMA_LIST] = Field(
        ["cv", "ct", "fs"], min_length=1, description="the bank every UAV runs, one information filter per model")
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
            MultiModelSpec._stochastic(v)
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
            from swarmtrack.models import make_model

            for name, q in zip(models, v, strict=True):
                if q is not None:
                    make_model(name, 0.05, q)  # length and positivity, its ValueError names the model
        return v

    def followed_target(self) -> int | None:
        return self.target

    def check(self, scenario: Scenario) -> None:
        if scenario.sensor.kind != "range_bearing":
            raise ValueError(f"estimator.kind imm needs a range_bearing sensor, not {scenario.sensor.kind!r}")


class SetMembershipSpec(EstimatorSpec):
    """IB21's guaranteed search and track of targets among decoys (Algorithm 1): every UAV keeps the sets where each
    identified target, each unidentified object and anything unexplored can be, shares them every ``period``."""

    kind: Literal["setmembership"] = "setmembership"
    area: Box = Field((0.0, 0.0, 400.0, 400.0), description="X0 = [x0, y0, x1, y1], m")
    target_speed: Speed | None = Field(None, gt=0, description=(
        "m/s, the speed bound V^t the sets grow with; default: the targets' speed"))
    noise_bound: HalfWidths = Field((5.0, 5.0), description=(
        "m, the ASSUMED noise half-widths per axis (the guarantee needs them to contain the true ones)"))
    period: Time = Field(0.5, gt=0, description="s, between exchanges T^c (IB21: 0.5)")
    delayed_data: Literal["refused", "refilter"] = Field("refused", description=(
        "refused: network.delay is refused; refilter: a late neighbour's sets are fused at the time they describe "
        "and the updates since are replayed (IB21 Sec. 4.5), over a window of the delay bound in periods"))
    sets: Literal["polygons", "raster"] = Field("polygons", description=(
        "how the sets are held: polygons (shapely, exact up to outward margins of micrometres) or raster (grids of "
        "distance lower bounds, outer by up to a cell's half-diagonal along their edges; faster: "
        "docs/set-membership.md)"))
    cell: Length = Field(1.0, gt=0, le=50, description="m, the side of a raster cell (sets: raster)")

    def speed_bound(self, scenario: Scenario) -> float:
        return self.target_speed if self.target_speed is not None else scenario.targets.speed

    def replayed_periods(self, scenario: Scenario) -> int:
        """δ̄ of IB21 Sec. 4.5: how many sharing periods late a neighbour's sets can be fused, 0 without delays or
        neighbours. A message waits :func:`~swarmtrack.network.channel.delay_steps` estimation steps and is fused
        at the first sharing time after it arrived: the delay bound rounded up to whole periods."""
        from swarmtrack.network.channel import delay_steps

        if self.delayed_data != "refilter" or scenario.network.topology == "none":
            return 0
        dt = 1.0 / scenario.rates.estimation
        steps = int(delay_steps(scenario.network.delay_bound(), dt))
        per_period = round(self.period / dt)  # a whole number of steps (checked)
        return -(-steps // per_period)

    def check(self, scenario: Scenario) -> None:
        if scenario.sensor.kind != "footprint":
            raise ValueError("estimator.kind setmembership needs sensor.kind: footprint")
        if scenario.swarm.nav_position_std or scenario.swarm.nav_velocity_std:
            raise ValueError("swarm.nav_position_std and nav_velocity_std must be 0 with estimator.kind "
                             "setmembership: a Gaussian pose error has no bound, so no footprint is guaranteed")
        ratio = self.period * scenario.rates.estimation
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f"estimator.period {self.period:g} s must be a whole number of estimation steps")


class SMMPCSpec(ControllerSpec):
    """IB21 Sec. 5's set-membership MPC: every UAV picks, from a discrete set of yaw accelerations, the sequence over
    the horizon that leaves the smallest predicted set to search (plus α times its distance to it), given the plans of
    its lower-indexed neighbours; ``baseline``: the paper's SimpleBaselineMPC."""

    kind: Literal["sm_mpc"] = "sm_mpc"
    inputs: list[AngularRate] = Field([0.0, 0.25, -0.25, 0.5, -0.5], min_length=1, description=(
        "rad/s², the yaw accelerations tried, in tie order (ours: IB21 gives none)"))
    horizon: int = Field(2, ge=1, le=6, description="steps of the control period (IB21: 2)")
    period: Time = Field(0.5, gt=0, description="s (IB21: 0.5)")
    alpha: float = Field(1e-4, ge=0, le=1e6, description="weight of the distance to the set (IB21: 1e-4)")
    distance: Literal["nearest", "hausdorff"] = Field("nearest", description=(
        "eq. 47's distance from the UAV to the set: nearest point (ours) or farthest (the Hausdorff distance)"))
    baseline: bool = Field(False, description="SimpleBaselineMPC: no neighbours' plans, no growth of the sets")

    def check(self, scenario: Scenario) -> None:
        if scenario.estimator.kind != "setmembership" or scenario.swarm.vehicle != "fixed_wing":
            raise ValueError("controller.kind sm_mpc needs estimator.kind: setmembership and swarm.vehicle: fixed_wing")
        ratio = self.period * scenario.rates.control
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f"controller.period {self.period:g} s must be a whole number of control steps")
        if scenario.rates.physics != scenario.rates.estimation:
            raise ValueError("controller.kind sm_mpc predicts with the physics step: rates.estimation must equal "
                             "rates.physics (IB21: both T_d = 0.05 s)")


class StaticSpec(ControllerSpec):
    """UAVs hold their initial positions (W20 Sec. 4.6.1: hung from the ceiling, estimation decoupled from
    flight)."""

    kind: Literal["static"] = "static"


class FlockingSpec(ControllerSpec):
    kind: Literal["flocking"] = "flocking"
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
        import dataclasses

        from swarmtrack.control.flocking import FlockingGains

        known = {f.name for f in dataclasses.fields(FlockingGains)} - {"d", "r_comm"}
        unknown = sorted(set(v) - known)
        if unknown:
            raise ValueError(f"unknown gain(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
        FlockingGains(**v)  # its own range checks (ε, h in (0, 1), positive lengths) raise a readable ValueError
        return v


class UAVModelSpec(_Strict):
    """A UAV's identified linear model ``x(k+1) = A x(k) + B s(k)`` at period ``T``, state ``[x, y, vx, vy]``, input
    the position setpoint (W20 eq. 5.32); ``swarmtrack identify`` writes one."""

    T: Time = Field(gt=0, description="s, the sample period the model was identified at")
    A: list[list[float]] = Field(description="4 x 4")
    B: list[list[float]] = Field(description="4 x 2")

    @model_validator(mode="after")
    def _stable(self):
        from swarmtrack.control.identification import check_model

        check_model(np.asarray(self.A, dtype=float), np.asarray(self.B, dtype=float))
        return self


class PositionGainsSpec(_Strict):
    """The UAV's own position controller ``a = kp (s − p) − kd v`` (:mod:`swarmtrack.control.position`)."""

    kp: Gain = Field(1.44, gt=0, description="s⁻² (chosen: 1.2 rad/s natural frequency)")
    kd: Gain = Field(2.16, gt=0, description="s⁻¹ (chosen: damping 0.9)")
    accel_limit: Acceleration = Field(3.0, gt=0, description="m/s², norm clip on the commanded acceleration")


class MPCSpec(ControllerSpec):
    """W20 Ch. 5's distributed MPC: each UAV plans its position setpoints over a horizon to hold its formation place
    ``offsets`` relative to the target (propagated by the model its estimate follows), sidestepping neighbours
    closer than ``r_s``; its position controller flies them."""

    kind: Literal["mpc"] = "mpc"
    model: str | UAVModelSpec = Field("swarmtrack-quadrotor", description=(
        "the UAVs' identified model: a name (swarmtrack-quadrotor: the project's quadrotor, identified by swarmtrack "
        "identify --simulator; w20-simulator, w20-pelican: W20 eq. 5.32 and Sec. 5.4.1.2 as printed) or {T, A, B}"))
    horizon: int = Field(5, ge=1, le=200, description="prediction horizon h, steps (W20: 5)")
    period: Time = Field(0.2, gt=0, description="s, between plans; the model's T (W20: 0.2)")
    Q: float = Field(12.0, ge=0, le=1e6, description="position tracking weight (W20: 12)")
    R: float = Field(0.15, gt=0, le=1e6, description="input weight (W20: 0.15)")
    Q_s: float = Field(6.0, ge=0, le=1e6, description="separation weight; 0 turns collision avoidance off (W20: 6)")
    r_s: Length = Field(5.0, gt=0, description="m, separation radius: trigger and side-step offset (W20: 5)")
    bound: Length = Field(2.0, gt=0, description=(
        "m, per-axis bound on the setpoint relative to the UAV's position at the plan (W20: ±2, ±10, ±1.5)"))
    offsets: list[Position] = Field(default_factory=list, description=(
        "m, each UAV's place relative to the target, r_r (W20 eq. 5.22); default: all over the target"))
    target_model: Literal["estimate", "cv", "ca", "ct"] = Field("estimate", description=(
        "the model propagating the target: estimate = the one each UAV's estimate follows (multi-model), or fixed"))
    start: Time = Field(0.0, ge=0, description="s, before which every UAV holds its position (W20 Table 5.10: 20)")
    follow: Literal["estimate", "truth"] = Field("estimate", description=(
        "truth: W20's perfect estimate and model (an oracle, not onboard; blind UAVs keep their last estimate)"))
    gains: PositionGainsSpec = Field(default_factory=PositionGainsSpec)

    @field_validator("model")
    @classmethod
    def _known_model(cls, v):
        from swarmtrack.control.identification import NAMED_MODELS

        if isinstance(v, str) and v not in NAMED_MODELS:
            raise ValueError(f"unknown model {v!r}; known: {', '.join(sorted(NAMED_MODELS))}, or give {{T, A, B}}")
        return v

    @field_validator("offsets")
    @classmethod
    def _distinct_slots(cls, v):
        for i in range(len(v)):
            for j in range(i):
                if np.allclose(v[i], v[j]):
                    raise ValueError(f"UAVs {j + 1} and {i + 1} have the same formation slot {list(v[i])}")
        return v

    def uav_model(self):
        """``(T, A, B)`` of the named or given model."""
        from swarmtrack.control.identification import NAMED_MODELS

        if isinstance(self.model, str):
            m = NAMED_MODELS[self.model]
            return m.T, m.A, m.B
        return self.model.T, np.asarray(self.model.A, dtype=float), np.asarray(self.model.B, dtype=float)

    def check(self, scenario: Scenario) -> None:
        n = scenario.swarm.n_uavs
        if self.offsets and len(self.offsets) != n:
            raise ValueError(f"controller.offsets has {len(self.offsets)} entries for {n} UAVs")
        if not self.offsets and n > 1:
            raise ValueError(f"controller.offsets: {n} UAVs need {n} distinct formation slots (one each)")
        T = self.uav_model()[0]
        if abs(T - self.period) > 1e-9:
            raise ValueError(f"controller.period is {self.period:g} s but the model was identified at T = {T:g} s")
        ratio = self.period * scenario.rates.control
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f"controller.period {self.period:g} s must be a whole number of control steps "
                             f"(rates.control = {scenario.rates.control:g} Hz)")


#: ``kind`` → settings class of every estimator and controller the scenario can pick; the simulator's builders
#: are registered beside them (:func:`swarmtrack.sim.build.register`), so a new capability adds an entry here,
#: not a branch in the engine.
ESTIMATOR_KINDS: dict[str, type[EstimatorSpec]] = {"information": InformationSpec, "centralized": CentralizedSpec,
                                                  "multimodel": MultiModelSpec, "imm": IMMSpec,
                                                  "setmembership": SetMembershipSpec}
CONTROLLER_KINDS: dict[str, type[ControllerSpec]] = {"flocking": FlockingSpec, "static": StaticSpec,
                                                    "mpc": MPCSpec, "sm_mpc": SMMPCSpec}
SENSOR_KINDS: dict[str, type[SensorSpec]] = {"range_bearing": RangeBearingSpec, "camera": CameraSpec,
                                             "footprint": FootprintSpec}


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
    physics: Rate = Field(100.0, gt=0, description="Hz (at most 1e4 Hz: ten times a fast attitude loop)")
    estimation: Rate = Field(20.0, gt=0, description="Hz (L24, L23; at most 1e4 Hz)")
    control: Rate = Field(20.0, gt=0, description="Hz (at most 1e4 Hz)")

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
    duration: Time | None = Field(None, gt=0, description=(
        "s (at most 1e7 s: about four months); default: the longest driven member's profile"))
    rates: RatesSpec = Field(default_factory=RatesSpec)
    targets: GroupSpec = Field(default_factory=lambda: GroupSpec(members=[MemberSpec()]), description=(
        "the objects the swarm tracks; ``target: {...}`` is the shorthand for one quadrotor target"))
    decoys: GroupSpec = Field(default_factory=GroupSpec, description="objects a sensor may confuse with targets")
    swarm: SwarmSpec = Field(default_factory=SwarmSpec)
    sensor: SerializeAsAny[SensorSpec] = Field(default_factory=RangeBearingSpec)
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

    @field_validator("sensor", mode="before")
    @classmethod
    def _sensor_kind(cls, v):
        return _by_kind(v, SENSOR_KINDS, "range_bearing", SensorSpec)

    def run_duration(self) -> float:
        """Simulated time, s: ``duration`` or the length of the longest driven member's profile."""
        if self.duration is not None:
            return self.duration
        members = self.targets.members + self.decoys.members
        return max((m.duration() for m in members), default=60.0)

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
        if self.network.delay_bound() > 0:
            if self.network.delay_bound() >= self.run_duration():
                field = "delay" if self.network.delay_max is None else "delay_max"
                raise ValueError(f"network.{field} ({self.network.delay_bound():g} s) is not shorter than the run "
                                 f"({self.run_duration():g} s)")
            if self.estimator.kind == "setmembership":
                if self.estimator.delayed_data != "refilter":
                    raise ValueError("network.delay needs estimator.delayed_data: refilter with estimator.kind "
                                     "setmembership (a late neighbour's sets are fused at their time and the updates "
                                     "since replayed, IB21 Sec. 4.5)")
            elif self.estimator.kind not in ("information", "centralized"):
                raise ValueError(f"network.delay needs estimator.kind information: the {self.estimator.kind!r} "
                                 "estimator does not read time stamps")
            if getattr(self.estimator, "share", "information") != "information" and self.estimator.kind != \
                    "centralized":
                raise ValueError("network.delay needs estimator.share information: shared raw measurements are "
                                 "fused as they arrive, and late ones would be lost")
        liar = self.network.liar
        if liar is not None:
            if not 1 <= liar.uav <= n:
                raise ValueError(f"network.liar.uav names UAV {liar.uav}, but the swarm has UAVs 1..{n}")
            if self.estimator.kind != "information" or getattr(self.estimator, "share", None) != "information":
                raise ValueError("network.liar corrupts information contributions: it needs estimator.kind "
                                 "information with share information")
            if self.network.topology == "none":
                raise ValueError("network.liar has nobody to lie to: network.topology is none")
            if liar.start >= self.run_duration():
                raise ValueError(f"network.liar.start ({liar.start:g} s) is not before the end of the run "
                                 f"({self.run_duration():g} s)")
        for k, outage in enumerate(self.network.outages):
            for v in outage.uavs:
                if not 1 <= v <= n:
                    raise ValueError(f"network.outages[{k}].uavs names UAV {v}, but the swarm has UAVs 1..{n}")
        from swarmtrack.sim.clock import Clock

        r = self.rates
        clock = Clock.from_rates(r.physics, r.estimation, r.control, self.run_duration())
        if clock.steps < 1:
            raise ValueError(f"duration {self.run_duration():g} s is shorter than one estimation step "
                             f"({clock.dt_estimation:g} s)")
        followed = self.estimator.followed_target()
        if followed is not None and not 1 <= followed <= len(self.targets.members):
            raise ValueError(f"estimator.target is {followed}, but targets has {len(self.targets.members)} member(s)")
        if getattr(self.controller, "follow", None) == "truth" and followed is None:
            raise ValueError("controller.follow: truth needs an estimator that follows one target")
        self.estimator.check(self)
        self.sensor.check(self)
        self.controller.check(self)
        return self
