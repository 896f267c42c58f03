"""The world: the only holder of truth (target and UAV vehicles), integrated at the physics rate.

It hands each UAV what that UAV's own devices would give it (a noisy navigation solution, a noisy
range-bearing measurement of the target) and nothing else. Onboard code never imports this module.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.scenarios.schema import Scenario, TargetSpec
from swarmtrack.sensors.range_bearing import measure
from swarmtrack.vehicles import double_integrator, quadrotor
from swarmtrack.vehicles.profile import Phase, VelocityProfile, l23_profile, l24_profile


def build_profile(spec: TargetSpec) -> VelocityProfile:
    if spec.profile == "l24":
        return l24_profile()
    if spec.profile == "l23":
        return l23_profile()
    if spec.profile == "hover":
        return VelocityProfile((Phase("hover", spec.hover_duration, (0.0, 0.0), (0.0, 0.0), (0.0, 0.0), (0.0, 0.0)),))
    return VelocityProfile(tuple(
        Phase(p.name, p.duration, tuple(p.c), tuple(p.amplitude), tuple(p.omega), tuple(p.phi))
        for p in spec.phases))


def spawn_positions(scenario: Scenario, rng: np.random.Generator) -> np.ndarray:
    """Initial UAV positions: the scenario's, or seeded uniform draws in the spawn box, kept apart."""
    sw = scenario.swarm
    if sw.initial_positions is not None:
        return np.asarray(sw.initial_positions, dtype=float)
    center = np.asarray(sw.spawn_center)
    pos = center + rng.uniform(-sw.spawn_half_width, sw.spawn_half_width, size=(sw.n_uavs, 2))
    for _ in range(100):  # redraw the UAVs that are too close to an earlier one
        diff = pos[:, None, :] - pos[None, :, :]
        close = np.triu(np.einsum("ijk,ijk->ij", diff, diff) < sw.min_separation**2, k=1).any(axis=0)
        if not close.any():
            break
        pos[close] = center + rng.uniform(-sw.spawn_half_width, sw.spawn_half_width, size=(close.sum(), 2))
    return pos


class World:
    """Truth. Target: an Iris-like quadrotor whose autopilot flies the velocity profile. UAVs: quadrotors
    (attitude loop, tilt and thrust limits) or ideal double integrators, commanded in acceleration."""

    def __init__(self, scenario: Scenario, rng: np.random.Generator):
        self.scenario = scenario
        self.rng = rng
        self.profile = build_profile(scenario.target)
        self.params = quadrotor.QuadrotorParams()
        self.t = 0.0
        self.target = quadrotor.hover_state(np.asarray([scenario.target.start], dtype=float))
        start = spawn_positions(scenario, rng)
        self.uav_quadrotor = scenario.swarm.vehicle == "quadrotor"
        if self.uav_quadrotor:
            self.uavs = quadrotor.hover_state(start)
        else:
            self.uavs = np.concatenate([start, np.zeros_like(start)], axis=1)
        self._sensor = scenario.sensor
        # ring buffer of past (target, UAV) positions, for measurements that arrive `latency` late
        lag = int(round(scenario.sensor.latency * scenario.rates.physics))
        self._history = np.repeat(np.concatenate([self.target[:, :2], self.uavs[:, :2]])[None], lag + 1, axis=0)
        self._tick = 0
        self._nav_std = np.array([scenario.swarm.nav_position_std] * 2 + [scenario.swarm.nav_velocity_std] * 2)

    # --- truth, for the engine's recorder and the metrics only -------------------------------------------
    @property
    def target_truth(self) -> np.ndarray:
        """[x, y, vx, vy] of the target."""
        return self.target[0, :4]

    @property
    def uav_truth(self) -> np.ndarray:
        """(N, 4) [x, y, vx, vy] of the UAVs."""
        return self.uavs[:, :4]

    def phase_index(self) -> int:
        return int(self.profile.phase_index(self.t))

    # --- what each UAV's own devices report ----------------------------------------------------------
    def navigation(self) -> np.ndarray:
        """Each UAV's own navigation solution (N, 4): truth plus white noise."""
        nav = self.uavs[:, :4].copy()
        if self._nav_std.any():
            nav += self.rng.standard_normal(nav.shape) * self._nav_std
        return nav

    def measure_target(self) -> tuple[np.ndarray, np.ndarray]:
        """Each UAV's range-bearing measurement of the target (N, 2) (L24 Sec. 3.2, corrected h) and the
        navigation position stamped on it (N, 2), both ``sensor.latency`` seconds old. An onboard filter that
        takes the packet as current sees the target where it was (the SITL pipeline delay)."""
        then = self._history[(self._tick + 1) % len(self._history)]
        z = measure(then[0], then[1:], self._sensor.sigma_range, self._sensor.sigma_bearing, self.rng)
        pose = then[1:].copy()
        if self._nav_std[0] > 0:
            pose += self.rng.standard_normal(pose.shape) * self._nav_std[0]
        return z, pose

    # --- physics -----------------------------------------------------------------------------------------
    def step(self, uav_accel_cmd: np.ndarray, dt: float) -> None:
        """Advance the truth by one physics step with the UAVs' commanded accelerations (N, 2)."""
        spec = self.scenario.target
        v_cmd = self.profile.velocity(self.t)
        a_ff = self.profile.acceleration(self.t)
        a_target = quadrotor.velocity_tracking_accel(v_cmd, self.target[:, 2:4], a_ff, spec.velocity_gain)
        wind = self.rng.standard_normal((1, 2)) * spec.wind_std if spec.wind_std > 0 else None
        if self.uav_quadrotor:
            both = quadrotor.step(np.concatenate([self.target, self.uavs]),
                                  np.concatenate([a_target.reshape(1, 2), uav_accel_cmd]), self.params, dt,
                                  None if wind is None else np.concatenate([wind, np.zeros_like(uav_accel_cmd)]))
            self.target, self.uavs = both[:1], both[1:]
        else:
            self.target = quadrotor.step(self.target, a_target.reshape(1, 2), self.params, dt, wind)
            self.uavs = double_integrator.step(self.uavs, uav_accel_cmd, dt)
        self.t += dt
        self._tick += 1
        slot = self._history[self._tick % len(self._history)]
        slot[0] = self.target[0, :2]
        slot[1:] = self.uavs[:, :2]
