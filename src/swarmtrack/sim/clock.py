"""Integer-tick multirate schedule: physics every tick, estimation and control every whole number of ticks."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass


@dataclass(frozen=True)
class Clock:
    """``ticks_estimation`` and ``ticks_control`` physics ticks of ``dt`` s per estimation and control step."""

    dt: float
    ticks_estimation: int
    ticks_control: int
    steps: int

    @classmethod
    def from_rates(cls, physics: float, estimation: float, control: float, duration: float) -> Clock:
        ticks_est = round(physics / estimation)
        dt = 1.0 / physics
        return cls(dt, ticks_est, round(physics / control), int(round(duration / (ticks_est * dt))))

    @property
    def dt_estimation(self) -> float:
        return self.ticks_estimation * self.dt

    @property
    def dt_control(self) -> float:
        return self.ticks_control * self.dt

    def control_segments(self, k: int) -> Iterator[tuple[bool, int]]:
        """Within estimation step ``k``: ``(control_now, ticks)`` pieces, a control step starting a piece whenever
        the global tick is a multiple of ``ticks_control``; the pieces cover ``ticks_estimation`` ticks."""
        tick = 0
        while tick < self.ticks_estimation:
            phase = (k * self.ticks_estimation + tick) % self.ticks_control
            run = min(self.ticks_estimation - tick, self.ticks_control - phase)
            yield phase == 0, run
            tick += run
