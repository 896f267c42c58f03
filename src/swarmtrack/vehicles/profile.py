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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

Pair = tuple[float, float]


def _pair(value, name: str) -> Pair:
    vals = tuple(float(v) for v in value)
    if len(vals) != 2:
        raise ValueError(f"{name} must have one value per planar axis (x, y), got {value!r}")
    return vals  # type: ignore[return-value]


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

    def __post_init__(self) -> None:
        if not self.duration > 0.0:
            raise ValueError(f"phase {self.name!r}: duration must be > 0, got {self.duration}")
        object.__setattr__(self, "duration", float(self.duration))
        for attr in ("c", "amplitude", "omega", "phi", "accel"):
            object.__setattr__(self, attr, _pair(getattr(self, attr), attr))


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
        for name, val in (("_starts", starts), ("_coef", coef), ("_disp", disp)):
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
