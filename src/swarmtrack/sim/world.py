"""The world: the only holder of truth (target and UAV vehicles), integrated at the physics rate.

It hands each UAV what that UAV's own devices would give it (a noisy navigation solution, a noisy
range-bearing measurement of the target) and nothing else. Onboard code never imports this module.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.scenarios.loader import ScenarioError
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
    else:
        raise ScenarioError(f"swarm: cannot place {sw.n_uavs} UAVs {sw.min_separation} m apart in a spawn box of "
                            f"half-width {sw.spawn_half_width} m; enlarge swarm.spawn_half_width or lower "
                            "swarm.min_separation")
    return pos


class World:
    """Truth. Target: an Iris-like quadrotor whose autopilot flies the velocity profile. UAVs: quadrotors
    (attitude loop, tilt and thrust limits) or ideal double integrators, commanded in acceleration."""

    def __init__(self, scenario: Scenario, rng: np.random.Generator, dt: float, duration: float, *,
                 compiled: bool = False):
        self.scenario = scenario
        self.compiled = compiled  # advance() through vehicles.kernels (same numbers as step())
        self.rng = rng
        self.dt = dt
        self.profile = build_profile(scenario.target)
        self.params = quadrotor.QuadrotorParams()
        start = spawn_positions(scenario, rng)
        self.uav_quadrotor = scenario.swarm.vehicle == "quadrotor"
        target = quadrotor.hover_state(np.asarray([scenario.target.start], dtype=float))
        if self.uav_quadrotor:  # one array, target in row 0, so one batched step integrates everything
            self._vehicles = np.asarray(quadrotor.hover_state(np.concatenate([target[:, :2], start])), order="F")
        else:
            self._target = target
            self._uavs = np.concatenate([start, np.zeros_like(start)], axis=1)
        self._sensor = scenario.sensor
        self._nav_std = np.array([scenario.swarm.nav_position_std] * 2 + [scenario.swarm.nav_velocity_std] * 2)
        # the target autopilot's velocity profile and the wind, sampled once for every physics tick
        ticks = int(np.ceil(duration / dt)) + 2
        grid = np.arange(ticks) * dt
        self._v_cmd = self.profile.velocity(grid)
        self._a_ff = self.profile.acceleration(grid)
        self._wind = rng.standard_normal((ticks, 2)) * scenario.target.wind_std
        self._accel = np.zeros((scenario.swarm.n_uavs + 1, 2))
        # ring buffer of past (target, UAV) positions, for measurements that arrive `latency` late
        lag = int(round(scenario.sensor.latency / dt))
        self._history = np.repeat(np.concatenate([self.target[:, :2], self.uavs[:, :2]])[None], lag + 1, axis=0)
        self._tick = 0
        if compiled:
            from swarmtrack.vehicles import kernels

            self._kernel = kernels.advance
            self._kernel_consts = kernels.params_tuple(self.params)
            self._no_points = np.empty((0, 4))

    @property
    def t(self) -> float:
        """Simulated time, s."""
        return self._tick * self.dt

    @property
    def target(self) -> np.ndarray:
        return self._vehicles[:1] if self.uav_quadrotor else self._target

    @property
    def uavs(self) -> np.ndarray:
        return self._vehicles[1:] if self.uav_quadrotor else self._uavs

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

    def measure_target(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each UAV's range-bearing measurement of the target (N, 2) (L24 Sec. 3.2, corrected h), the
        navigation position stamped on it (N, 2), both ``sensor.latency`` seconds old, and whether the UAV saw
        the target at all (N,) (within ``sensor.max_range``; rows of unseen targets are NaN). An onboard filter
        that takes the packet as current sees the target where it was (the SITL pipeline delay)."""
        then = self._history[(self._tick + 1) % len(self._history)]
        z = measure(then[0], then[1:], self._sensor.sigma_range, self._sensor.sigma_bearing, self.rng)
        pose = then[1:].copy()
        if self._nav_std[0] > 0:
            pose += self.rng.standard_normal(pose.shape) * self._nav_std[0]
        seen = np.ones(len(z), dtype=bool)
        if self._sensor.max_range is not None:
            seen = np.hypot(*(then[0] - then[1:]).T) <= self._sensor.max_range
            z[~seen] = np.nan
        return z, pose, seen

    # --- physics -----------------------------------------------------------------------------------------
    def advance(self, uav_accel_cmd: np.ndarray, ticks: int) -> None:
        """Advance the truth by ``ticks`` physics steps with the UAVs' commanded accelerations (N, 2) held.

        The same as ``ticks`` calls of :meth:`step` (the reference); with ``compiled`` one call of the numba
        kernel :func:`swarmtrack.vehicles.kernels.advance`, which gives the same numbers to a few ulps and
        updates the state arrays in place (so views such as :attr:`target_truth` follow: copy what must stay).
        """
        if not self.compiled:
            for _ in range(ticks):
                self.step(uav_accel_cmd)
            return
        if self.uav_quadrotor:
            quads, points = self._vehicles, self._no_points
        else:
            quads, points = self._target, self._uavs
        self._kernel(quads, points, uav_accel_cmd, self._v_cmd, self._a_ff, self._wind, self._tick, ticks,
                     self.scenario.target.velocity_gain, self.dt, self._kernel_consts, self._history)
        self._tick += ticks

    def step(self, uav_accel_cmd: np.ndarray) -> None:
        """Advance the truth by one physics step with the UAVs' commanded accelerations (N, 2)."""
        k = self._tick
        a_target = quadrotor.velocity_tracking_accel(self._v_cmd[k], self.target[0, 2:4], self._a_ff[k],
                                                     self.scenario.target.velocity_gain)
        if self.uav_quadrotor:
            accel = self._accel
            accel[0] = a_target + self._wind[k]  # gusts: a random acceleration the autopilot must reject
            accel[1:] = uav_accel_cmd
            self._vehicles = quadrotor.step(self._vehicles, accel, self.params, self.dt)
        else:
            self._target = quadrotor.step(self._target, (a_target + self._wind[k])[None], self.params, self.dt)
            self._uavs = double_integrator.step(self._uavs, uav_accel_cmd, self.dt)
        self._tick += 1
        slot = self._history[self._tick % len(self._history)]
        slot[0] = self.target[0, :2]
        slot[1:] = self.uavs[:, :2]
