"""Piecewise-sinusoidal velocity profiles that the target quadrotor is commanded to fly.

Each phase prescribes, per planar axis, ``v(τ) = c + a·τ + A·sin(ω·τ + φ)`` with ``τ`` measured from the
phase start (L24 Sec. 4, "linear", "sinusoidal" and "circular" phases; L23 Sec. 4 uses the sinusoidal
phase alone). The constant-acceleration term ``a·τ`` (zero by default) gives the constant-acceleration
segments of a target that switches among CV, CA and CT motion (W20 Ch. 4). The phase durations are not
given by the papers; the project defaults (SPEC.md, Capability 1) are 40 s linear, 62.8 s sinusoidal (one
period of ``sin(0.1τ)``) and 50.3 s circular (two loops of ``ω = 0.25 rad/s``).

The velocity is discontinuous at a phase boundary when the paper specifies it so (e.g. the circular phase
starts with ``vy = 2`` m/s while the sinusoidal one ends near 0): the vehicle's own controller smooths it.
Every evaluation accepts a scalar or an array of times and returns ``(..., 2)`` (x, y).

:func:`ground_robot_profile` builds the profile of a unicycle (a Turtlebot) driving constant-velocity,
constant-acceleration and constant-turn segments with a continuous velocity, and :func:`evasive_segments`
draws random such segments that keep it in a small square (W20 Ch. 4: a target switching among CV, CA and
CT motion indoors).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

Pair = tuple[float, float]


def _pair(value, name: str) -> Pair:
    vals = tuple(float(v) for v in value)
    if len(vals) != 2:
        raise ValueError(f"{name} must have one value per planar axis (x, y), got {value!r}")
    return vals


@dataclass(frozen=True)
class Phase:
    """One phase of a velocity profile: per axis ``v(τ) = c + accel·τ + amplitude·sin(omega·τ + phi)``.

    ``duration`` in s; ``c`` and ``amplitude`` in m/s; ``omega`` in rad/s; ``phi`` in rad (L24 Sec. 4);
    ``accel`` in m/s² (a constant-acceleration segment, W20 Ch. 4; 0 by default); each of the five is a
    length-2 tuple for the x and y axes. ``accel`` comes last so the positional order of the others is kept.
    """

    name: str
    duration: float
    c: Pair = (0.0, 0.0)
    amplitude: Pair = (0.0, 0.0)
    omega: Pair = (0.0, 0.0)
    phi: Pair = (0.0, 0.0)
    accel: Pair = (0.0, 0.0)
    #: The climb rate of a target in 3-D, ``vz(τ) = c + accel·τ + amplitude·sin(omega·τ + phi)`` given as
    #: ``(c, amplitude, omega, phi, accel)`` (issue 28; level flight by default).
    vertical: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not self.duration > 0.0:
            raise ValueError(f"phase {self.name!r}: duration must be > 0, got {self.duration}")
        object.__setattr__(self, "duration", float(self.duration))
        for attr in ("c", "amplitude", "omega", "phi", "accel"):
            object.__setattr__(self, attr, _pair(getattr(self, attr), attr))
        vertical = tuple(float(v) for v in self.vertical)
        if len(vertical) != 5:
            raise ValueError(f"phase {self.name!r}: vertical must be (c, amplitude, omega, phi, accel), got "
                             f"{self.vertical!r}")
        object.__setattr__(self, "vertical", vertical)


@dataclass(frozen=True)
class VelocityProfile:
    """A sequence of :class:`Phase` flown back to back from ``t = 0``.

    Times before 0 are evaluated in the first phase and times beyond the end stay in the last phase
    (its sinusoids simply continue; so does its ``accel·τ`` term, so a last phase with ``accel ≠ 0`` keeps
    speeding up, or slowing down and then reversing, beyond the end).
    """

    phases: tuple[Phase, ...]
    _starts: np.ndarray = field(init=False, repr=False, compare=False)
    _coef: np.ndarray = field(init=False, repr=False, compare=False)
    _disp: np.ndarray = field(init=False, repr=False, compare=False)
    _vcoef: np.ndarray = field(init=False, repr=False, compare=False)
    _vdisp: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        phases = tuple(self.phases)
        if not phases:
            raise ValueError("a velocity profile needs at least one phase")
        object.__setattr__(self, "phases", phases)
        durations = np.array([p.duration for p in phases])
        starts = np.concatenate(([0.0], np.cumsum(durations)[:-1]))
        # coef[k] = (5, 2): rows c, A, omega, phi, accel of phase k.
        coef = np.array([[p.c, p.amplitude, p.omega, p.phi, p.accel] for p in phases], dtype=float)
        # Displacement accumulated at the start of each phase (relative to the profile start).
        full = self._integral(coef, durations[:, None])  # (P, 2)
        disp = np.concatenate((np.zeros((1, 2)), np.cumsum(full, axis=0)[:-1]), axis=0)
        # the vertical axis alone, (P, 5, 1): the same per-axis arithmetic (the planar numbers are untouched)
        vcoef = np.array([[[v] for v in p.vertical] for p in phases], dtype=float)
        vfull = self._integral(vcoef, durations[:, None])
        vdisp = np.concatenate((np.zeros((1, 1)), np.cumsum(vfull, axis=0)[:-1]), axis=0)
        for name, val in (("_starts", starts), ("_coef", coef), ("_disp", disp), ("_vcoef", vcoef),
                          ("_vdisp", vdisp)):
            val.setflags(write=False)
            object.__setattr__(self, name, val)

    # ------------------------------------------------------------------ structure
    def __len__(self) -> int:
        return len(self.phases)

    def __iter__(self):
        return iter(self.phases)

    def __getitem__(self, k: int) -> Phase:
        return self.phases[k]

    @property
    def total_duration(self) -> float:
        """Sum of the phase durations [s]."""
        return float(sum(p.duration for p in self.phases))

    @property
    def phase_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.phases)

    @property
    def phase_starts(self) -> np.ndarray:
        """Start time of each phase [s], shape (P,)."""
        return self._starts

    def phase_index(self, t) -> np.ndarray:
        """Index of the phase active at time(s) ``t`` (int array of t's shape; clipped to [0, P-1])."""
        t = np.asarray(t, dtype=float)
        idx = np.searchsorted(self._starts, t, side="right") - 1
        return np.clip(idx, 0, len(self.phases) - 1)

    def _locate(self, t):
        t = np.asarray(t, dtype=float)
        idx = self.phase_index(t)
        tau = (t - self._starts[idx])[..., None]
        coef = self._coef[idx]  # (..., 5, 2)
        return idx, tau, coef[..., 0, :], coef[..., 1, :], coef[..., 2, :], coef[..., 3, :], coef[..., 4, :]

    # ------------------------------------------------------------------ kinematics
    def velocity(self, t) -> np.ndarray:
        """Commanded velocity ``c + accel·τ + A·sin(ωτ + φ)`` at time(s) ``t``, shape ``(..., 2)`` [m/s]."""
        _, tau, c, a, w, ph, acc = self._locate(t)
        return c + acc * tau + a * np.sin(w * tau + ph)

    def acceleration(self, t) -> np.ndarray:
        """Analytic derivative ``accel + A·ω·cos(ωτ + φ)`` of :meth:`velocity`, shape ``(..., 2)`` [m/s²].

        At a phase boundary the acceleration of the phase that starts there is returned (the velocity jump
        itself is a Dirac that is not represented).
        """
        _, tau, _, a, w, ph, acc = self._locate(t)
        return acc + a * w * np.cos(w * tau + ph)

    def position(self, t, start=(0.0, 0.0)) -> np.ndarray:
        """Exact integral of :meth:`velocity` from 0 to ``t`` plus ``start``, shape ``(..., 2)`` [m].

        Per phase ``∫₀^τ c + a·s + A sin(ωs + φ) ds = cτ + a·τ²/2 + (A/ω)(cos φ − cos(ωτ + φ))`` (the
        sinusoid's part is ``A·sin φ·τ`` when ω = 0), summed over the completed phases.
        """
        idx, tau, *_ = self._locate(t)
        coef = self._coef[idx]
        return np.asarray(start, dtype=float) + self._disp[idx] + self._integral(coef, tau)

    # ------------------------------------------------------------------ altitude (3-D targets)
    @property
    def climbs(self) -> bool:
        """Whether any phase has a vertical velocity (a 3-D target)."""
        return bool(np.any(self._vcoef))

    def _vertical(self, t):
        t = np.asarray(t, dtype=float)
        idx = self.phase_index(t)
        tau = (t - self._starts[idx])[..., None]
        return idx, tau, self._vcoef[idx]

    def vertical_velocity(self, t) -> np.ndarray:
        """Commanded climb rate at time(s) ``t`` (t's shape), m/s: :meth:`velocity`'s law on the vertical axis."""
        _, tau, coef = self._vertical(t)
        c, a, w, ph, acc = (coef[..., j, :] for j in range(5))
        return (c + acc * tau + a * np.sin(w * tau + ph))[..., 0]

    def vertical_acceleration(self, t) -> np.ndarray:
        """Analytic derivative of :meth:`vertical_velocity` (t's shape), m/s²."""
        _, tau, coef = self._vertical(t)
        _, a, w, ph, acc = (coef[..., j, :] for j in range(5))
        return (acc + a * w * np.cos(w * tau + ph))[..., 0]

    def height(self, t, start: float = 0.0) -> np.ndarray:
        """Exact integral of :meth:`vertical_velocity` from 0 to ``t`` plus ``start`` (t's shape), m."""
        idx, tau, coef = self._vertical(t)
        return (start + self._vdisp[idx] + self._integral(coef, tau))[..., 0]

    @staticmethod
    def _integral(coef: np.ndarray, tau: np.ndarray) -> np.ndarray:
        c, a, w, ph, acc = coef[..., 0, :], coef[..., 1, :], coef[..., 2, :], coef[..., 3, :], coef[..., 4, :]
        small = np.abs(w) < 1e-12
        w_safe = np.where(small, 1.0, w)
        osc = np.where(small, a * np.sin(ph) * tau, a / w_safe * (np.cos(ph) - np.cos(w_safe * tau + ph)))
        return c * tau + 0.5 * acc * tau * tau + osc


# ---------------------------------------------------------------------- paper profiles
L24_LINEAR_DURATION = 40.0
L24_SINUSOIDAL_DURATION = 62.8
L24_CIRCULAR_DURATION = 50.3


def _sinusoidal(duration: float = L24_SINUSOIDAL_DURATION) -> Phase:
    # L24 Sec. 4: vx = 0.5, vy = 2 sin(0.1 t).
    return Phase("sinusoidal", duration, c=(0.5, 0.0), amplitude=(0.0, 2.0), omega=(0.0, 0.1))


def l24_profile(
    linear: float = L24_LINEAR_DURATION,
    sinusoidal: float = L24_SINUSOIDAL_DURATION,
    circular: float = L24_CIRCULAR_DURATION,
) -> VelocityProfile:
    """The three L24 target phases (L24 Sec. 4; durations from SPEC.md Capability 1).

    linear: ``vx = 0.5, vy = 0``; sinusoidal: ``vx = 0.5, vy = 2 sin(0.1τ)``; circular:
    ``vx = 0.2 + 2 sin(0.25τ), vy = 2 cos(0.25τ) = 2 sin(0.25τ + π/2)``.
    """
    return VelocityProfile(
        (
            Phase("linear", linear, c=(0.5, 0.0)),
            _sinusoidal(sinusoidal),
            Phase(
                "circular",
                circular,
                c=(0.2, 0.0),
                amplitude=(2.0, 2.0),
                omega=(0.25, 0.25),
                phi=(0.0, math.pi / 2),
            ),
        )
    )


def l23_profile(sinusoidal: float = L24_SINUSOIDAL_DURATION) -> VelocityProfile:
    """The L23 target: the sinusoidal phase alone (``vx = 0.5, vy = 2 sin(0.1τ)``; L23 Sec. 4)."""
    return VelocityProfile((_sinusoidal(sinusoidal),))


# ---------------------------------------------------------------------- ground robot (W20 Ch. 4)
SEGMENT_KINDS = ("cv", "ca", "ct")


class Segment(NamedTuple):
    """One stretch of a ground robot's drive (W20 Ch. 4): ``kind`` ``"cv"``, ``"ca"`` or ``"ct"``; ``duration``
    in s; ``value`` the longitudinal acceleration [m/s²] for ``"ca"``, the turn rate [rad/s] for ``"ct"``,
    ignored for ``"cv"``."""

    kind: str
    duration: float
    value: float = 0.0


def _segment(index: int, segment) -> Segment:
    """``segment`` (a :class:`Segment` or a plain ``(kind, duration, value)`` tuple) checked."""
    try:
        kind, duration, value = segment
        duration, value = float(duration), float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"segment {index}: expected (kind, duration, value), got {segment!r}") from exc
    if kind not in SEGMENT_KINDS:
        raise ValueError(f"segment {index}: unknown kind {kind!r} (expected one of {SEGMENT_KINDS})")
    if not (duration > 0.0 and math.isfinite(duration)):
        raise ValueError(f"segment {index} ({kind}): duration must be finite and > 0, got {duration}")
    if not math.isfinite(value):
        raise ValueError(f"segment {index} ({kind}): value must be finite, got {value}")
    return Segment(kind, duration, value)


def _segment_phase(index: int, seg: Segment, heading: float, speed: float) -> tuple[Phase, float, float]:
    """The phase a unicycle at ``(heading, speed)`` flies for ``seg``, and the heading and speed it ends with.

    cv: ``v = V (cos ψ, sin ψ)``; ca: ``v = (V + a τ)(cos ψ, sin ψ)``; ct: ``v = V (cos(ψ + ωτ), sin(ψ + ωτ))``
    written as the sinusoids ``V sin(ωτ + ψ + π/2)``, ``V sin(ωτ + ψ)`` (unicycle kinematics, W20 Ch. 4).
    """
    kind, duration, value = seg
    direction = (speed * math.cos(heading), speed * math.sin(heading))
    if kind == "cv":
        return Phase("cv", duration, c=direction), heading, speed
    if kind == "ca":
        end_speed = speed + value * duration
        if end_speed < -1e-12 * max(1.0, abs(speed)):
            raise ValueError(f"segment {index} (ca): the speed would become negative ({speed} m/s + {value} m/s² × "
                             f"{duration} s = {end_speed} m/s)")
        accel = (value * math.cos(heading), value * math.sin(heading))
        return Phase("ca", duration, c=direction, accel=accel), heading, max(end_speed, 0.0)
    phase = Phase("ct", duration, amplitude=(speed, speed), omega=(value, value),
                  phi=(heading + math.pi / 2, heading))
    return phase, math.remainder(heading + value * duration, 2 * math.pi), speed


def ground_robot_profile(segments, heading: float = 0.0, speed: float = 0.0) -> VelocityProfile:
    """The velocity profile of a unicycle (e.g. a Turtlebot) driving ``segments`` back to back (W20 Ch. 4).

    ``segments``: :class:`Segment` or ``(kind, duration, value)`` tuples, see :class:`Segment`. The robot starts
    with ``heading`` [rad, from +x] and ``speed`` [m/s ≥ 0]; each segment starts from the heading and speed the
    previous one ended with, so the velocity is continuous at every boundary. Phase names are the kinds, so
    per-phase metrics group by motion type. A CA segment that would drive the speed below 0 is a
    ``ValueError`` (reaching exactly 0 is allowed), as are an unknown kind and a non-positive duration.
    Beyond the end the last segment continues (a CA one keeps changing the speed, see :class:`VelocityProfile`).
    """
    heading, speed = float(heading), float(speed)
    if not (speed >= 0.0 and math.isfinite(speed) and math.isfinite(heading)):
        raise ValueError(f"need a finite heading and a finite speed >= 0, got heading={heading}, speed={speed}")
    phases = []
    for index, segment in enumerate(segments):
        phase, heading, speed = _segment_phase(index, _segment(index, segment), heading, speed)
        phases.append(phase)
    if not phases:
        raise ValueError("a ground-robot profile needs at least one segment")
    return VelocityProfile(tuple(phases))


# ---------------------------------------------------------------------- evasive manoeuvres
_SAMPLE_STEP = 0.01  # s between the positions checked against the square


def _times(duration: float) -> np.ndarray:
    """``[0, duration]`` every ≤ ``_SAMPLE_STEP`` s, both ends included."""
    return np.linspace(0.0, duration, max(2, math.ceil(duration / _SAMPLE_STEP) + 1))


def _path(phase: Phase, start: np.ndarray) -> np.ndarray:
    """Exact positions along ``phase`` from ``start`` at :func:`_times`, (n, 2)."""
    return VelocityProfile((phase,)).position(_times(phase.duration), start)


def _inside(path: np.ndarray, limit: float) -> bool:
    return bool(np.all(np.abs(path) <= limit))


def _bearing_error(position: np.ndarray, heading) -> np.ndarray:
    """Angle in (−π, π] from ``heading`` to the direction of the origin (0 at the origin itself); broadcasts."""
    x, y = position[..., 0], position[..., 1]
    at_origin = (x == 0.0) & (y == 0.0)
    error = np.remainder(np.arctan2(-y, -x) - heading + np.pi, 2 * np.pi) - np.pi
    return np.where(at_origin, 0.0, error)


def _circle_inside(position: np.ndarray, heading: float, speed: float, rate: float, limit: float) -> bool:
    """Whether the circle a unicycle flies when it keeps turning at ``rate`` lies in ``|x|, |y| ≤ limit``.

    The circle has radius ``|V/ω|`` and centre ``p + (V/ω)(−sin ψ, cos ψ)`` (integral of the CT velocity).
    """
    if speed == 0.0:
        return _inside(position, limit)
    if rate == 0.0:
        return False
    radius = speed / rate
    centre = position + radius * np.array([-math.sin(heading), math.cos(heading)])
    return bool(np.all(np.abs(centre) + abs(radius) <= limit))


def _can_turn_back(position: np.ndarray, heading: float, speed: float, turn_max: float, limit: float) -> bool:
    """The safe states: one of the two full-rate turning circles lies in the square, so circling there is safe."""
    return any(_circle_inside(position, heading, speed, rate, limit) for rate in (turn_max, -turn_max))


def _aimed_rate(position: np.ndarray, heading: float, speed: float, duration: float) -> float:
    """The turn rate that, in ``duration``, points the heading at the origin from where the turn ends: the
    bearing error over ``duration``, corrected twice by the bearing error left at the end of the turn."""
    rate = float(_bearing_error(position, heading)) / duration
    for _ in range(2):
        phase, end_heading, _ = _segment_phase(0, Segment("ct", duration, rate), heading, speed)
        end = VelocityProfile((phase,)).position(duration, position)
        rate += float(_bearing_error(end, end_heading)) / duration
    return rate


def _time_to_face_centre(position: np.ndarray, heading: float, speed: float, rate: float) -> float | None:
    """First time at which a turn at ``rate`` points the heading at the origin (within one full turn), or None."""
    phase = _segment_phase(0, Segment("ct", 2 * math.pi / abs(rate), rate), heading, speed)[0]
    tau = _times(phase.duration)
    error = _bearing_error(VelocityProfile((phase,)).position(tau, position), heading + rate * tau)
    crossed = (np.sign(error[1:]) != np.sign(error[0])) & (np.abs(np.diff(error)) < np.pi)  # not the ±π wrap
    return float(tau[1:][np.argmax(crossed)]) if crossed.any() else None


def _turn_back(position: np.ndarray, heading: float, speed: float, d_range: Pair, turn_max: float,
               limit: float) -> Segment:
    """A CT segment, lasting within ``d_range``, that turns the heading toward the centre of the square.

    First choice: the rate (at most ``turn_max``) that aims the heading at the centre in ``|e|/turn_max`` s
    clipped to ``d_range`` (``e`` the bearing error), if its turning circle lies in the square. Else the full
    rate toward the centre, else away from it, whichever circle lies in the square, until the heading faces
    the centre (clipped to ``d_range``). From a safe state (:func:`_can_turn_back`) one of them always does, and
    the state the turn ends in is safe again: it is on the same circle, and the full-rate circle on the same
    side lies inside any larger one tangent to it there.
    """
    d_min, d_max = d_range
    error = float(_bearing_error(position, heading))
    duration = min(max(abs(error) / turn_max, d_min), d_max)
    rate = _aimed_rate(position, heading, speed, duration)
    if abs(rate) <= turn_max and _circle_inside(position, heading, speed, rate, limit):
        return Segment("ct", duration, rate)
    toward = math.copysign(turn_max, error) if error != 0.0 else turn_max
    for rate in (toward, -toward):
        if _circle_inside(position, heading, speed, rate, limit):
            time = _time_to_face_centre(position, heading, speed, rate)
            return Segment("ct", min(max(time if time is not None else d_min, d_min), d_max), rate)
    raise RuntimeError("turn back asked from a state that cannot turn back (a bug: evasive_segments keeps the "
                       "robot in states that can)")


def _random_segment(rng: np.random.Generator, speed: float, duration: float, speed_range: Pair,
                    turn_max: float, accel_max: float) -> Segment:
    """A segment of random kind lasting ``duration``: a random turn rate, or an acceleration keeping the speed
    inside ``speed_range``."""
    kind = SEGMENT_KINDS[int(rng.integers(len(SEGMENT_KINDS)))]
    if kind == "ct":
        return Segment(kind, duration, float(rng.uniform(-turn_max, turn_max)))
    if kind == "ca":
        low = max(-accel_max, (speed_range[0] - speed) / duration)
        high = min(accel_max, (speed_range[1] - speed) / duration)
        return Segment(kind, duration, float(rng.uniform(low, high)))
    return Segment(kind, duration, 0.0)


def evasive_segments(
    rng: np.random.Generator,
    duration: float,
    *,
    start=(0.0, 0.0),
    heading: float = 0.0,
    speed: float = 0.2,
    half_width: float = 1.0,
    segment_range: Pair = (0.5, 2.0),
    speed_range: Pair = (0.1, 0.3),
    turn_rate_max: float = 1.0,
    accel_max: float = 0.1,
) -> list[Segment]:
    """Random CV/CA/CT manoeuvres of a ground robot in the square ``|x|, |y| ≤ half_width`` (W20 Ch. 4 setting).

    Segments of random kind (uniform among cv, ca, ct) and duration (uniform in ``segment_range``) follow each
    other until ``duration`` is covered, the last one trimmed to end exactly there. A CT turns at a rate uniform
    in ``±turn_rate_max``; a CA accelerates uniformly within ``±accel_max`` intersected with what keeps the speed
    in ``speed_range``.

    Staying in the square: the robot is kept in *safe* states, from which a full-rate turn (``±turn_rate_max``)
    flies a circle that lies in the square. A random segment is kept only if its path, integrated exactly and
    checked every 0.01 s, stays in the square and it ends in a safe state; otherwise the robot turns back
    instead, a CT segment (duration in ``segment_range``) that points the heading toward the centre along a
    circle lying in the square, and ends in a safe state again (see :func:`_turn_back`). The checks keep a
    margin of ``speed_range[1] × 0.005 s`` from the edge, so the continuous path stays inside, not just the
    samples. Deterministic for a given ``rng`` state. Returns the segments; the caller builds
    ``ground_robot_profile(segments, heading, speed)`` and evaluates ``position(t, start)``.

    ``ValueError`` for inconsistent bounds, or a start outside ``speed_range``, outside the square or not safe
    (e.g. at the edge heading out, or a square too small for the turning radius ``speed/turn_rate_max``).
    """
    position = np.array(_pair(start, "start"))
    heading, speed, duration, half_width = float(heading), float(speed), float(duration), float(half_width)
    d_range, v_range = _pair(segment_range, "segment_range"), _pair(speed_range, "speed_range")
    turn_max, accel_max = float(turn_rate_max), float(accel_max)
    if not (duration > 0.0 and math.isfinite(duration)) or not half_width > 0.0:
        raise ValueError(f"need duration > 0 and half_width > 0, got {duration}, {half_width}")
    if not (0.0 < d_range[0] <= d_range[1] < math.inf) or not (0.0 <= v_range[0] <= v_range[1] < math.inf):
        raise ValueError(f"need 0 < segment_range[0] <= segment_range[1] and 0 <= speed_range[0] <= "
                         f"speed_range[1], got {d_range}, {v_range}")
    if not (0.0 < turn_max < math.inf and 0.0 <= accel_max < math.inf):
        raise ValueError(f"need turn_rate_max > 0 and accel_max >= 0, got {turn_max}, {accel_max}")
    if not v_range[0] <= speed <= v_range[1]:
        raise ValueError(f"start speed {speed} m/s is outside speed_range {v_range}")
    limit = half_width - 0.5 * v_range[1] * _SAMPLE_STEP
    if not _can_turn_back(position, heading, speed, turn_max, limit):
        raise ValueError(f"start {tuple(position.tolist())} heading {heading} rad at {speed} m/s: no full-rate turn "
                         f"stays in the square of half width {half_width} m (outside it, too close to its edge, or "
                         f"the turning radius speed/turn_rate_max is too large)")
    segments: list[Segment] = []
    elapsed = 0.0
    while True:
        remaining = duration - elapsed
        segment = _random_segment(rng, speed, min(float(rng.uniform(*d_range)), remaining), v_range, turn_max,
                                  accel_max)
        phase, end_heading, end_speed = _segment_phase(len(segments), segment, heading, speed)
        path = _path(phase, position)
        if not (_inside(path, limit) and _can_turn_back(path[-1], end_heading, end_speed, turn_max, limit)):
            turn = _turn_back(position, heading, speed, d_range, turn_max, limit)
            segment = turn._replace(duration=min(turn.duration, remaining))
            phase, end_heading, end_speed = _segment_phase(len(segments), segment, heading, speed)
            path = _path(phase, position)
        segments.append(segment)
        if segment.duration >= remaining:  # trimmed: ends exactly at ``duration``
            return segments
        position, heading, speed = path[-1], end_heading, end_speed
        elapsed += segment.duration


#: The climb of the 3-D L24 target (ours, issue 28): level for the linear phase, a vertical sinusoid of the planar
#: one's period in the sinusoidal phase (up 2 m and back), a steady climb making the circular phase a helix (2 m).
L24_3D_CLIMB = ((0.0, 0.0, 0.0, 0.0, 0.0), (0.0, 0.1, 0.1, 0.0, 0.0), (0.04, 0.0, 0.0, 0.0, 0.0))


def l24_3d_profile() -> VelocityProfile:
    """L24's three phases (:func:`l24_profile`) with the altitude L24 Sec. 6 asks for: level, a vertical sinusoid
    ``vz = 0.1 sin(0.1τ)`` m/s, then a helix climbing at 0.04 m/s (:data:`L24_3D_CLIMB`)."""
    return VelocityProfile(tuple(
        Phase(p.name, p.duration, p.c, p.amplitude, p.omega, p.phi, p.accel, vertical=climb)
        for p, climb in zip(l24_profile(), L24_3D_CLIMB, strict=True)))
