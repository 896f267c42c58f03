"""Scenario files: validated once, at the edge (pydantic). Units are in the field descriptions.

Every value a paper leaves open has a default here that says where it came from.
"""

from __future__ import annotations

import math
import typing
from typing import Annotated, ClassVar, Literal

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

from swarmtrack import registry
from swarmtrack.scenarios import contract, spawn
from swarmtrack.vehicles.profile import (
    Phase,
    VelocityProfile,
    evasive_segments,
    ground_robot_profile,
    l23_profile,
    l24_3d_profile,
    l24_profile,
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


class Strict(BaseModel):
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


CommaList = BeforeValidator(_split_commas)
Velocity = tuple[Speed, Speed]


class ClimbSpec(Strict):
    """A 3-D target's climb rate in one phase, ``vz = c + accel·τ + amplitude·sin(omega·τ + phi)`` (issue 28)."""

    c: Speed = Field(0.0, description="m/s, constant climb rate (at most 1e3 m/s)")
    amplitude: Speed = Field(0.0, description="m/s, sinusoid amplitude (at most 1e3 m/s)")
    omega: AngularRate = Field(0.0, description="rad/s, sinusoid angular frequency (at most 1e3 rad/s)")
    phi: Angle = Field(0.0, description="rad, sinusoid phase (at most 1e3 rad)")
    accel: Acceleration = Field(0.0, description="m/s², constant vertical acceleration (at most 1e3 m/s²)")

    def law(self) -> tuple[float, float, float, float, float]:
        return (self.c, self.amplitude, self.omega, self.phi, self.accel)


class PhaseSpec(Strict):
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
    climb: ClimbSpec = Field(default_factory=ClimbSpec, description=(
        "its climb rate in a 3-D world (sensor.kind range_bearing_elevation); level by default"))


class SegmentSpec(Strict):
    """One segment of a ground robot's drive (unicycle): ``cv`` keeps speed and heading, ``ca`` accelerates by
    ``value`` m/s² along the heading, ``ct`` turns at ``value`` rad/s at constant speed."""

    kind: Literal["cv", "ca", "ct"]
    duration: Time = Field(gt=0, description="s")
    value: float = Field(0.0, ge=-MAX_ANGULAR_RATE, le=MAX_ANGULAR_RATE, description=(
        "ca: m/s²; ct: rad/s; cv: unused"))


class EvasiveSpec(Strict):
    """Frequent random manoeuvres of a ground robot, drawn from the scenario's seed (stream
    ``manoeuvres/<group>/<member>``): segments of random kind and length that keep it inside a square."""

    duration: Time = Field(60.0, gt=0, description="s")
    half_width: Length = Field(1.0, gt=0, description="m, the robot stays in |x|, |y| <= half_width (W20: ~4 m²)")
    segment_range: tuple[Time, Time] = Field((0.5, 2.0), description="s, shortest and longest segment")
    speed_range: tuple[Speed, Speed] = Field((0.1, 0.3), description="m/s")
    turn_rate_max: AngularRate = Field(1.0, gt=0, description="rad/s")
    accel_max: Acceleration = Field(0.1, gt=0, description="m/s²")


class MemberSpec(Strict):
    """One driven vehicle (a target or a decoy): where it starts and the velocity profile its autopilot flies."""

    profile: Literal["l24", "l24-3d", "l23", "hover", "custom", "ground", "evasive"] = Field(
        "l24", description=("l24: linear, sinusoidal, circular (SPEC durations 40, 62.8, 50.3 s); l24-3d: the same "
                            "with a vertical sinusoid and a helix (docs/three-d.md); l23: sinusoidal; "
                            "ground: a ground robot's cv/ca/ct segments; evasive: random ground-robot manoeuvres"))
    phases: list[PhaseSpec] = Field(default_factory=list, description="with profile: custom")
    hover_duration: Time = Field(60.0, gt=0, description="s, with profile: hover (at most 1e7 s)")
    segments: list[SegmentSpec] = Field(default_factory=list, description="with profile: ground")
    evasive: EvasiveSpec = Field(default_factory=EvasiveSpec, description="with profile: evasive")
    heading: Angle = Field(0.0, description="rad, initial heading of a ground or evasive profile")
    speed: Speed = Field(0.0, ge=0, description="m/s, initial speed of a ground or evasive profile")
    start: Position = Field((0.0, 0.0), description=(
        "initial position, m (at most 1e6 m from the origin per axis: 1000 km, beyond any radio range)"))
    altitude: Length = Field(0.0, ge=0, description=(
        "m above the ground at the start, in a 3-D world (sensor.kind range_bearing_elevation); its profile's climb "
        "may not take it below the ground"))

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
        if self.profile in ("l24-3d", "custom"):
            self._above_ground()
        if self.profile == "ground":
            if not self.segments:
                raise ValueError("segments must list at least one segment when profile is 'ground'")
            self.velocity_profile()  # a segment that would drive backwards is refused here, naming it
        return self

    def _above_ground(self) -> None:
        """Refuse a climbing profile that takes the member below the ground (its commanded height, every 0.05 s)."""
        profile = self.velocity_profile()
        if not profile.climbs:
            return
        t = np.arange(0.0, profile.total_duration + 0.05, 0.05)
        z = profile.height(t, self.altitude)
        if z.min() < 0.0:
            k = int(np.argmin(z))
            raise ValueError(f"altitude {self.altitude:g} m and the phases' climb take the target below the ground: "
                             f"z = {z[k]:.2f} m at t = {t[k]:.2f} s")

    def duration(self) -> float:
        """Length of the profile, s (without drawing an evasive one)."""
        return self.evasive.duration if self.profile == "evasive" else self.velocity_profile().total_duration

    def velocity_profile(self, rng=None):
        """The :class:`~swarmtrack.vehicles.profile.VelocityProfile` this member flies; an evasive one draws its
        manoeuvres from ``rng`` (a ``numpy.random.Generator``)."""
        if self.profile == "l24":
            return l24_profile()
        if self.profile == "l24-3d":
            return l24_3d_profile()
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
                                           tuple(p.phi), accel=tuple(p.accel), vertical=p.climb.law())
                                     for p in self.phases))


class VehicleChoice:
    """A field naming a registered vehicle kind (:data:`swarmtrack.registry.VEHICLE`) that ``use`` — ``"uav"``
    (the swarm) or ``"group"`` (targets, decoys) — may use: the choices come from the registry, so a registered
    vehicle needs no change to this schema. It validates the field (one line naming the choices) and the scenario
    reference lists :meth:`names` and :meth:`describe` (:mod:`swarmtrack.scenarios.reference`)."""

    def __init__(self, use: str, who: str):
        self.use, self.who = use, who

    def names(self) -> list[str]:
        return [name for name, kind in registry.kinds(registry.VEHICLE).items() if getattr(kind, self.use)]

    def describe(self) -> str:
        """Each choice with its kind's description."""
        kinds = registry.kinds(registry.VEHICLE)
        return "; ".join(f"{n}: {kinds[n].description}" if kinds[n].description else n for n in self.names())

    def __call__(self, v: str) -> str:
        if v not in self.names():
            what = f"unknown vehicle {v!r}" if v not in registry.kinds(registry.VEHICLE) else \
                f"vehicle {v!r} is not for {self.who}"
            raise ValueError(f"{what}; {self.who} can use: {', '.join(self.names())}")
        return v


def _vehicle(use: str, who: str):
    """A vehicle-kind field's type (:class:`VehicleChoice`)."""
    choice = VehicleChoice(use, who)
    return Annotated[str, AfterValidator(choice), choice]


def _vehicle_keys(section: BaseModel, use: str) -> None:
    """Refuse a key of ``section`` that only other vehicle kinds read (:attr:`Vehicle.keys`), unless at its
    default."""
    kinds = {n: k for n, k in registry.kinds(registry.VEHICLE).items() if getattr(k, use)}
    used = kinds[section.vehicle].keys
    for name in dict.fromkeys(key for k in kinds.values() for key in k.keys):
        if name in type(section).model_fields and name not in used \
                and not _is_default(type(section), name, getattr(section, name)):
            readers = " or ".join(n for n, k in kinds.items() if name in k.keys)
            raise ValueError(f"{name} is used only with vehicle: {readers}")


class GroupSpec(Strict):
    """A named group of driven vehicles (``targets``, ``decoys``): one vehicle kind, any number of members, each
    flying its own velocity profile through the same autopilot (feed-forward + P velocity loop) and wind."""

    vehicle: _vehicle("group", "a group") = Field("quadrotor", description="a registered vehicle kind")
    velocity_gain: Gain = Field(1.5, gt=0, description="autopilot velocity-loop gain, 1/s (chosen; at most 1e6)")
    wind_std: Acceleration = Field(0.05, ge=0, description=(
        "random acceleration disturbance std, m/s² (chosen; at most 1e3 m/s²: about 100 g)"))
    members: list[MemberSpec] = Field(default_factory=list)
    count: int = Field(0, ge=0, le=10_000, description=(
        "walker, nearly_cv: members placed at seeded uniform positions in the area with uniform headings (IB21 "
        "Sec. 6)"))
    speed: Speed = Field(1.0, gt=0, description=(
        "walker: speed V^t, m/s (IB21: 1; Fig. 9: 1.0-1.8); nearly_cv: initial speed, m/s"))
    accel_noise: Gain = Field(0.25, gt=0, description=(
        "nearly_cv: power spectral density of the white-noise acceleration, m²/s³ (the velocity's variance grows by "
        "it each second; issue 40's box: 0.5² per 1 s step)"))
    yaw_accel_bound: AngularRate = Field(0.39269908169872414, gt=0, description=(
        "walker: yaw acceleration drawn from U(−b, b) every physics step, rad/s² (IB21: π/8)"))
    area: Box = Field((0.0, 0.0, 400.0, 400.0), description=(
        "walker, nearly_cv: [x0, y0, x1, y1], m, where the members start and stay (IB21: a 400 m square)"))

    @model_validator(mode="after")
    def _vehicle_keys(self):
        _vehicle_keys(self, "group")
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


class FixedWingSpec(Strict):
    """A fixed-wing UAV at constant speed and altitude steered by its yaw acceleration (IB21 Sec. 6)."""

    speed: Speed = Field(16.6, gt=0, description="m/s (IB21: 16.6)")
    altitude: Length = Field(100.0, gt=0, description="m (IB21: 100)")
    yaw_rate_max: AngularRate = Field(0.6, gt=0, description="rad/s (ours: ≈ 45° of bank; IB21 gives none)")


class QuadrotorSpec(Strict):
    """The swarm's quadrotors' attitude limits (:class:`~swarmtrack.vehicles.quadrotor.QuadrotorParams`)."""

    max_tilt: float = Field(0.6, gt=0, lt=math.pi / 2, description=(
        "rad, limit of the tilt setpoint's norm (ours, like PX4's MPC_TILTMAX_AIR: 0.6 rad ≈ 34°; < π/2)"))
    max_roll_pitch: float | None = Field(None, gt=0, lt=math.pi / 2, description=(
        "rad, saturation of the roll and of the pitch setpoint, each (W20 Sec. 5.4.2: 5° = 0.0873 rad; < π/2); "
        "null: none"))


class SwarmSpec(Strict):
    n_uavs: int = Field(3, ge=1, le=100_000, description="number of UAVs")
    vehicle: _vehicle("uav", "the swarm") = Field("quadrotor", description="a registered vehicle kind")
    fixed_wing: FixedWingSpec = Field(default_factory=FixedWingSpec, description="with vehicle: fixed_wing")
    quadrotor: QuadrotorSpec = Field(default_factory=QuadrotorSpec, description="with vehicle: quadrotor")
    initial_positions: list[Position] | None = Field(None, description=(
        "m (at most 1e6 m per axis); default: seeded random in the spawn box"))
    spawn_center: Position = Field((-2.0, -6.0), description=(
        "m (chosen: the papers give no initial positions; at most 1e6 m per axis)"))
    spawn_half_width: Length = Field(3.0, gt=0, description="m (at most 1e6 m)")
    min_separation: Length = Field(1.0, ge=0, description="m, between spawned UAVs (at most 1e6 m)")
    altitude: Length = Field(0.0, ge=0, description=(
        "m, the height the UAVs start at and hold in a 3-D world (sensor.kind range_bearing_elevation)"))
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
    def _vehicle_keys(self):
        _vehicle_keys(self, "uav")
        return self

    @model_validator(mode="after")
    def _positions_match(self):
        if self.initial_positions is not None and len(self.initial_positions) != self.n_uavs:
            raise ValueError(
                f"swarm.initial_positions has {len(self.initial_positions)} entries for {self.n_uavs} UAVs")
        room = None if self.initial_positions is not None else spawn.capacity(self.spawn_half_width,
                                                                              self.min_separation)
        if room is not None and self.n_uavs > room:
            raise ValueError(f"cannot place {self.n_uavs} UAVs {self.min_separation} m apart in a spawn box "
                             f"of half-width {self.spawn_half_width} m (it holds {room}); enlarge "
                             "swarm.spawn_half_width or lower swarm.min_separation")
        return self


class OccluderSpec(Strict):
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


class SensorSpec(Strict):
    """Base of every sensor's settings; ``kind`` picks the sensor (a registered kind, :mod:`swarmtrack.registry`)."""

    kind: str
    #: What its measurements give an estimator (names of :data:`~swarmtrack.scenarios.contract.MEASUREMENTS`); a
    #: sensor that gives ``information_update`` builds it with :meth:`update_rule`.
    gives: ClassVar[frozenset[str]] = frozenset()
    #: Whether it reads heights: the world flies them (``swarm.altitude``, the targets' altitude and climb) and its
    #: estimators run 3-D models; a planar sensor's estimators run planar ones.
    three_d: ClassVar[bool] = False
    #: The groups whose members it sees, in label order: it reports member m of the k-th group, whose predecessors
    #: hold L members, as label L + m (:func:`~swarmtrack.onboard.context.sensor_labels`).
    sensed: ClassVar[tuple[str, ...]] = ("targets", "decoys")
    latency: float = Field(0.0, ge=0, le=5.0, description=(
        "s, age of a measurement when the filter uses it as current (sensing and middleware delay; "
        "rounded to the physics step)"))
    occluders: list[OccluderSpec] = Field(default_factory=list, description=(
        "what hides the target from some UAVs (a region, a time window or both)"))

    def update_rule(self, own_sigma: float = 0.0):
        """How its measurements enter an information filter, for a sensor that gives ``information_update``
        (``own_sigma``: the UAV's own navigation error, m)."""
        raise NotImplementedError(f"sensor.kind {self.kind} gives no information_update")

    def check(self, scenario: Scenario) -> None:
        """Checks against the rest of the scenario (raise ValueError naming the field)."""
        n = scenario.swarm.n_uavs
        for k, occ in enumerate(self.occluders):
            for u in occ.uavs:
                if not 1 <= u <= n:
                    raise ValueError(f"sensor.occluders[{k}].uavs names UAV {u}, but the swarm has UAVs 1..{n}")


class OutageSpec(Strict):
    """UAVs that neither send nor receive any message during a time window (W20 Sec. 5.4.4.3: "lose communication
    with the other UAVs")."""

    uavs: list[int] = Field(min_length=1, description="1-based UAVs cut off")
    window: tuple[Time, Time] = Field(description="[t0, t1), s")

    @model_validator(mode="after")
    def _ordered(self):
        if not 0 <= self.window[0] < self.window[1]:
            raise ValueError(f"window {list(self.window)} must be [t0, t1) with 0 <= t0 < t1")
        return self


class LiarSpec(Strict):
    """One UAV whose estimation broadcasts lie, its own filter staying honest (network/faults.py)."""

    uav: int = Field(ge=1, description="1-based UAV that lies")
    mode: Literal["bias", "random"] = Field("bias", description=(
        "bias: claims the target at its measurement plus offset; random: plus a fresh N(0, sigma² I) each step"))
    offset: tuple[Length, Length] = Field((2.0, 0.0), description="m, the bias's displacement")
    sigma: Length = Field(2.0, gt=0, description="m, the random lie's standard deviation per axis")
    start: Time = Field(0.0, ge=0, description="s, when it starts lying")


class NetworkSpec(Strict):
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


class EstimatorSpec(Strict):
    """Base of every estimator's settings; ``kind`` picks the implementation (a registered kind,
    :mod:`swarmtrack.registry`)."""

    kind: str
    #: The measurements it can fuse (names of :data:`~swarmtrack.scenarios.contract.MEASUREMENTS`): the scenario's
    #: sensor must give one of them. Empty: it declares none, and any sensor is let through.
    reads: ClassVar[frozenset[str]] = frozenset()

    def followed_target(self) -> int | None:
        """The member of ``targets`` (1-based) this estimator follows, which the recording's capability-1 metrics
        and ``controller.follow: truth`` refer to; None: it follows no single target."""
        return None

    def warmup_steps(self) -> int:
        """Estimation steps the estimator needs before its output is judged (metrics start after them)."""
        return 0

    def recording_meta(self) -> dict:
        """What a recording's ``meta`` says of this estimator besides its settings (read by its kind's metrics)."""
        return {}

    def check(self, scenario: Scenario) -> None:
        """Checks against the rest of the scenario (raise ValueError naming the field)."""

    def check_network(self, scenario: Scenario) -> None:
        """Checks of the network's imperfections this estimator must handle: by default it reads no time stamps
        (no ``network.delay``) and fuses no information contributions a liar could corrupt (no ``network.liar``)."""
        if scenario.network.delay_bound() > 0:
            raise ValueError(f"network.delay needs estimator.kind information: the {self.kind!r} estimator does not "
                             "read time stamps")
        if scenario.network.liar is not None:
            raise ValueError(LIAR_NEEDS)


#: Why a liar is refused by an estimator that cannot be lied to.
LIAR_NEEDS = (
    "network.liar corrupts information contributions: it needs estimator.kind information with share information")


class ControllerSpec(Strict):
    """Base of every controller's settings; ``kind`` picks the implementation (a registered kind,
    :mod:`swarmtrack.registry`)."""

    kind: str
    #: Numbers it commands per UAV, which the swarm's vehicle kind must take (its ``command_width``: 2, a planar
    #: acceleration; 1, a fixed wing's yaw acceleration); None: as many as the vehicle takes.
    commands: ClassVar[int | None] = None

    def follows_truth(self) -> bool:
        """Whether the controller follows the truth (an oracle the simulator wires, never onboard) instead of the
        estimator's view."""
        return False

    def chase_start_steps(self) -> int:
        """Estimation steps before the controller starts following the target (metrics start after them)."""
        return 0

    def recording_meta(self) -> dict:
        """What a recording's ``meta`` says of this controller besides its settings (read by its kind's metrics)."""
        return {}

    def check(self, scenario: Scenario) -> None:
        """Checks against the rest of the scenario (raise ValueError naming the field)."""


#: Each role's base settings class (a registered kind's settings subclass it).
ROLE_BASES: dict[str, type[Strict]] = {"sensor": SensorSpec, "estimator": EstimatorSpec, "controller": ControllerSpec}
for _role, _base in ROLE_BASES.items():
    registry.declare_role(_role, _base)

#: The kind a scenario gets when it names none, per role.
DEFAULT_KINDS = {"sensor": "range_bearing", "estimator": "information", "controller": "flocking"}


def _by_kind(value, role: str):
    """Validate a ``kind``-tagged section with the settings class its registered kind names (a tagged union whose
    members come from the registry, so a registered kind needs no change to this schema)."""
    base = ROLE_BASES[role]
    if isinstance(value, base):
        return value
    if not isinstance(value, dict):
        raise ValueError("must be a mapping of keys to values")
    try:
        kind = registry.get(role, value.get("kind", DEFAULT_KINDS[role]))
    except registry.UnknownKind:
        known = ", ".join(sorted(registry.kinds(role)))
        raise ValueError(f"unknown kind {value.get('kind')!r}; known: {known}") from None
    return kind.settings.model_validate(value)


def _default(role: str):
    """The default section of ``role`` (its default kind's settings)."""
    return lambda: registry.get(role, DEFAULT_KINDS[role]).settings()


def check_stochastic(v: list[list[float]] | None) -> list[list[float]] | None:
    """A row-stochastic square matrix (a Markov switching matrix), or None; the error names the bad row."""
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


class RatesSpec(Strict):
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


class Scenario(Strict):
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
    sensor: SerializeAsAny[SensorSpec] = Field(default_factory=_default("sensor"))
    network: NetworkSpec = Field(default_factory=NetworkSpec)
    estimator: SerializeAsAny[EstimatorSpec] = Field(default_factory=_default("estimator"))
    controller: SerializeAsAny[ControllerSpec] = Field(default_factory=_default("controller"))
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
        return _by_kind(v, "estimator")

    @field_validator("controller", mode="before")
    @classmethod
    def _controller_kind(cls, v):
        return _by_kind(v, "controller")

    @field_validator("sensor", mode="before")
    @classmethod
    def _sensor_kind(cls, v):
        return _by_kind(v, "sensor")

    def _heights_need_3d(self) -> None:
        """Heights and climbs are flown in a 3-D world only (a sensor that reads them, ``three_d``): in a planar one
        they would be silently ignored."""
        if self.sensor.three_d:
            return
        with_heights = ", ".join(n for n, k in registry.kinds("sensor").items() if k.settings.three_d)
        if self.swarm.altitude:
            raise ValueError(f"swarm.altitude is {self.swarm.altitude:g} m, but sensor.kind {self.sensor.kind} is "
                             f"planar: heights are flown with {with_heights}")
        for group in ("targets", "decoys"):
            for k, m in enumerate(getattr(self, group).members):
                climbs = m.profile == "l24-3d" or any(any(p.climb.law()) for p in m.phases)
                if m.altitude or climbs:
                    what = "altitude" if m.altitude else "profile" if m.profile == "l24-3d" else "phases' climb"
                    raise ValueError(f"{group}.members[{k}].{what} is given, but sensor.kind {self.sensor.kind} is "
                                     f"planar: heights are flown with {with_heights}")

    def estimation_steps(self) -> int:
        """Estimation steps of the run: a whole number of physics ticks each, as the simulator's clock counts."""
        dt = round(self.rates.physics / self.rates.estimation) / self.rates.physics
        return int(round(self.run_duration() / dt))

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
        if 0 < self.network.delay_bound() >= self.run_duration():
            field = "delay" if self.network.delay_max is None else "delay_max"
            raise ValueError(f"network.{field} ({self.network.delay_bound():g} s) is not shorter than the run "
                             f"({self.run_duration():g} s)")
        liar = self.network.liar
        if liar is not None:
            if not 1 <= liar.uav <= n:
                raise ValueError(f"network.liar.uav names UAV {liar.uav}, but the swarm has UAVs 1..{n}")
        self.estimator.check_network(self)
        if liar is not None:
            if self.network.topology == "none":
                raise ValueError("network.liar has nobody to lie to: network.topology is none")
            if liar.start >= self.run_duration():
                raise ValueError(f"network.liar.start ({liar.start:g} s) is not before the end of the run "
                                 f"({self.run_duration():g} s)")
        for k, outage in enumerate(self.network.outages):
            for v in outage.uavs:
                if not 1 <= v <= n:
                    raise ValueError(f"network.outages[{k}].uavs names UAV {v}, but the swarm has UAVs 1..{n}")
        if self.estimation_steps() < 1:
            raise ValueError(f"duration {self.run_duration():g} s is shorter than one estimation step "
                             f"({round(self.rates.physics / self.rates.estimation) / self.rates.physics:g} s)")
        followed = self.estimator.followed_target()
        if followed is not None and not 1 <= followed <= len(self.targets.members):
            raise ValueError(f"estimator.target is {followed}, but targets has {len(self.targets.members)} member(s)")
        if self.controller.follows_truth() and followed is None:
            raise ValueError("controller.follow: truth needs an estimator that follows one target")
        contract.truth_has_a_profile(self)
        self._heights_need_3d()
        contract.sensor_feeds_estimator(self)
        contract.sensor_sees_followed_target(self)
        self.estimator.check(self)
        self.sensor.check(self)
        self.controller.check(self)
        contract.controller_drives_vehicle(self)
        return self
