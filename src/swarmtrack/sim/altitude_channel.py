"""The world's altitude channel (truth side, issue 28): every object's ``[z, vz, az]``, stepped each physics tick beside
the planar state by :func:`swarmtrack.vehicles.altitude.step`.

A group with a :class:`~swarmtrack.vehicles.altitude.GroupAltitude` has its heights, lag and limits; a driven group
flies its velocity profiles' climb rate (feed-forward plus the planar driver's gain, ``a = gain·(vz_cmd − vz) +
az_ff``); a group commanded onboard (the UAVs) holds its heights by its autopilots' PD. A group without one stays at
``z = 0`` (on the ground plane). The channel keeps the heights of the last ``lag_steps`` ticks, for a sensor whose
reports are that old (as the world keeps the planar positions).
"""

from __future__ import annotations

import numpy as np

from swarmtrack.vehicles import altitude


class AltitudeChannel:
    """The altitude of every object of a world (module docstring). ``groups`` and ``slices`` as the world's;
    ``grid`` the physics ticks' times (the profiles are sampled on it once); ``lag_steps`` the history kept."""

    def __init__(self, groups, slices: dict[str, slice], n_objects: int, grid: np.ndarray, lag_steps: int):
        z0 = np.zeros(n_objects)
        self.lag, self.up, self.down = np.zeros(n_objects), np.full(n_objects, np.inf), np.full(n_objects, np.inf)
        driven, vz_cmd, az_ff, gains = [], [], [], []
        held, z_ref, kp, kd = [], [], [], []
        for g in groups:
            spec, rows = g.altitude, np.arange(slices[g.name].start, slices[g.name].stop)
            if spec is None:
                continue
            z0[rows] = spec.z0
            self.lag[rows], self.up[rows], self.down[rows] = spec.lag, spec.up, spec.down
            if g.driver is not None:
                driven.extend(rows)
                vz_cmd.extend(p.vertical_velocity(grid) for p in g.driver.profiles)
                az_ff.extend(p.vertical_acceleration(grid) for p in g.driver.profiles)
                gains.extend([g.driver.gain] * len(rows))
            elif spec.hold is not None:
                held.extend(rows)
                z_ref.extend(np.broadcast_to(spec.hold, len(rows)))
                kp.extend([spec.kp] * len(rows))
                kd.extend([spec.kd] * len(rows))
        self.state = altitude.initial_state(z0)
        self._driven = np.asarray(driven, dtype=np.int64)
        self._vz_cmd = np.stack(vz_cmd, axis=1) if driven else np.zeros((len(grid), 0))
        self._az_ff = np.stack(az_ff, axis=1) if driven else np.zeros((len(grid), 0))
        self._gain = np.asarray(gains, dtype=float)
        self._held = np.asarray(held, dtype=np.int64)
        self._z_ref, self._kp, self._kd = (np.asarray(v, dtype=float) for v in (z_ref, kp, kd))
        self._history = np.repeat(z0[None], lag_steps + 1, axis=0)

    def step(self, tick: int, dt: float) -> None:
        """One physics tick from tick ``tick`` (commands, then :func:`~swarmtrack.vehicles.altitude.step`)."""
        s = self.state
        a = np.zeros(len(s))
        if len(self._driven):
            k = min(tick, len(self._vz_cmd) - 1)
            a[self._driven] = self._gain * (self._vz_cmd[k] - s[self._driven, altitude.VZ]) + self._az_ff[k]
        if len(self._held):
            a[self._held] = altitude.hold(s[self._held], self._z_ref, self._kp, self._kd)
        self.state = altitude.step(s, a, dt, self.lag, self.up, self.down)
        if len(self._history) > 1:
            self._history[(tick + 1) % len(self._history)] = self.state[:, altitude.Z]

    def truth(self) -> np.ndarray:
        """(M, 2) every object's ``[z, vz]`` (a copy)."""
        return self.state[:, :altitude.AZ].copy()

    def lagged(self, tick: int) -> np.ndarray:
        """(M,) every object's height ``lag_steps`` ticks before ``tick`` (now without a lag)."""
        if len(self._history) == 1:
            return self.state[:, altitude.Z].copy()
        return self._history[(tick + 1) % len(self._history)].copy()
