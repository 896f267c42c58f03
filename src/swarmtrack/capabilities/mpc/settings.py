"""W20 Ch. 5's settings: the distributed MPC formation controller, the UAVs' identified model and their own
position controller."""

from __future__ import annotations

import math
from typing import Annotated, ClassVar, Literal

import numpy as np
from pydantic import Field, PrivateAttr, field_validator, model_validator

from swarmtrack.control.identification import NAMED_MODELS, check_model, error_tube, navigation_margin, vehicle_bound
from swarmtrack.scenarios.schema import (
    Acceleration,
    ControllerSpec,
    Gain,
    Length,
    Position,
    Scenario,
    Speed,
    Strict,
    Time,
)

#: The thesis' input bounds (m, relative setpoint per axis): Tables 5.9-5.10 (two and three UAVs), 5.5 (one UAV),
#: 5.7 (indoor). With the 5° vehicle they ask for more acceleration than it gives (``controller.bound: vehicle``).
THESIS_BOUNDS = {"formation": 2.0, "single": 10.0, "indoor": 1.5}


class UAVModelSpec(Strict):
    """A UAV's identified linear model ``x(k+1) = A x(k) + B s(k)`` at period ``T``, state ``[x, y, vx, vy]``, input
    the position setpoint (W20 eq. 5.32); ``swarmtrack identify`` writes one."""

    T: Time = Field(gt=0, description="s, the sample period the model was identified at")
    A: list[list[float]] = Field(description="4 x 4")
    B: list[list[float]] = Field(description="4 x 2")

    @model_validator(mode="after")
    def _stable(self):
        check_model(np.asarray(self.A, dtype=float), np.asarray(self.B, dtype=float))
        return self


class PositionGainsSpec(Strict):
    """The UAV's own position controller ``a = kp (s − p) − kd v`` (:mod:`swarmtrack.control.position`)."""

    kp: Gain = Field(1.44, gt=0, description="s⁻² (chosen: 1.2 rad/s natural frequency)")
    kd: Gain = Field(2.16, gt=0, description="s⁻¹ (chosen: damping 0.9)")
    accel_limit: Acceleration = Field(3.0, gt=0, description="m/s², norm clip on the commanded acceleration")


class MPCSpec(ControllerSpec):
    """W20 Ch. 5's distributed MPC: each UAV plans its position setpoints over a horizon to hold its formation place
    ``offsets`` relative to the target (propagated by the model its estimate follows), sidestepping neighbours
    closer than ``r_s``; its position controller flies them."""

    kind: Literal["mpc"] = "mpc"
    commands: ClassVar[int | None] = 2  # a planar acceleration (its position controller's)
    model: str | UAVModelSpec = Field("swarmtrack-quadrotor", description=(
        "the UAVs' identified model: a name (swarmtrack-quadrotor: the project's quadrotor, identified by swarmtrack "
        "identify --simulator; w20-simulator, w20-pelican: W20 eq. 5.32 and Sec. 5.4.1.2 as printed) or {T, A, B}"))
    horizon: int = Field(5, ge=1, le=200, description="prediction horizon h, steps (W20: 5)")
    period: Time = Field(0.2, gt=0, description="s, between plans; the model's T (W20: 0.2)")
    Q: float = Field(12.0, ge=0, le=1e6, description="position tracking weight (W20: 12)")
    R: float = Field(0.15, gt=0, le=1e6, description="input weight (W20: 0.15)")
    Q_s: float = Field(6.0, ge=0, le=1e6, description="separation weight; 0 turns collision avoidance off (W20: 6)")
    r_s: Length = Field(5.0, gt=0, description="m, separation radius: trigger and side-step offset (W20: 5)")
    bound: Annotated[Length, Field(gt=0)] | Literal["vehicle"] = Field(2.0, description=(
        "m (> 0), per-axis bound on the setpoint relative to the UAV's position at the plan (W20: ±2, ±10, ±1.5), or "
        "vehicle: the largest the swarm's vehicle can fly, a·T/Δv (a: its per-axis acceleration limit, the lowest of "
        "g·tan(max_roll_pitch), g·tan(max_tilt)/√2 and gains.accel_limit/√2; Δv: the model's largest velocity change "
        "in one period per m of input), resolved to the number, rounded down to the mm (docs/mpc.md); a larger "
        "number is flown with a warning"))
    separation: Annotated[Length, Field(gt=0)] | None = Field(None, description=(
        "m (> 0), hard separation every two UAVs closer than r_s keep (a buffered-Voronoi half-plane each, tightened "
        "by the model's error tube and the navigation error: docs/mpc.md); off with Q_s = 0; null: W20's cost term "
        "only"))
    model_error: tuple[Annotated[Length, Field(ge=0)], Annotated[Speed, Field(ge=0)]] = Field((0.0, 0.0), description=(
        "m, m/s (≥ 0): bound on the model's one-step error in position and velocity per axis (the largest measured "
        "in flight, or the largest residual of its identification), which tightens the separation constraint"))
    offsets: list[Position] = Field(default_factory=list, description=(
        "m, each UAV's place relative to the target, r_r (W20 eq. 5.22); default: all over the target"))
    target_model: Literal["estimate", "cv", "ca", "ct"] = Field("estimate", description=(
        "the model propagating the target: estimate = the one each UAV's estimate follows (multi-model), or fixed"))
    start: Time = Field(0.0, ge=0, description="s, before which every UAV holds its position (W20 Table 5.10: 20)")
    follow: Literal["estimate", "truth"] = Field("estimate", description=(
        "truth: W20's perfect estimate and model (an oracle, not onboard; blind UAVs keep their last estimate)"))
    gains: PositionGainsSpec = Field(default_factory=PositionGainsSpec)
    _limits: dict = PrivateAttr(default_factory=dict)  # what check() derived from the scenario (recording_meta)

    @field_validator("model")
    @classmethod
    def _known_model(cls, v):
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

    def follows_truth(self) -> bool:
        return self.follow == "truth"

    def uav_model(self):
        """``(T, A, B)`` of the named or given model."""
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
        self._resolve_limits(scenario)

    def vehicle_accel(self, scenario: Scenario) -> tuple[float, str]:
        """The per-axis acceleration the UAVs can give (m/s², both axes at once) and the setting that limits it: the
        quadrotor's attitude limits (:attr:`~swarmtrack.vehicles.quadrotor.QuadrotorParams.max_axis_accel`) or the
        position controller's norm clip ``gains.accel_limit/√2``, whichever is lower."""
        limits = [(self.gains.accel_limit / math.sqrt(2.0),
                   f"controller.gains.accel_limit = {self.gains.accel_limit:g} m/s² (in norm)")]
        if scenario.swarm.vehicle == "quadrotor":
            from swarmtrack.vehicles.quadrotor import QuadrotorParams

            q = scenario.swarm.quadrotor
            params = QuadrotorParams(max_tilt=q.max_tilt, max_roll_pitch=q.max_roll_pitch)
            limits.append((params.max_horizontal_accel / math.sqrt(2.0),
                           f"swarm.quadrotor.max_tilt = {q.max_tilt:.4g} rad (in norm)"))
            if q.max_roll_pitch is not None:
                limits.append((params.g * math.tan(q.max_roll_pitch), f"swarm.quadrotor.max_roll_pitch = "
                               f"{q.max_roll_pitch:.4g} rad ({math.degrees(q.max_roll_pitch):.3g}°)"))
        return min(limits)

    def margins(self, scenario: Scenario) -> list[float]:
        """The separation constraint's tightening at l = 1..h (m): the model's :func:`~swarmtrack.control.
        identification.error_tube` for ``model_error`` plus the :func:`~swarmtrack.control.identification.
        navigation_margin` of the swarm's navigation noise (``swarm.nav_position_std``, ``nav_velocity_std``)."""
        _, A, _ = self.uav_model()
        nav = navigation_margin(A, scenario.swarm.nav_position_std, scenario.swarm.nav_velocity_std)
        return [float(e + nav) for e in error_tube(A, self.model_error, self.horizon)]

    def _resolve_limits(self, scenario: Scenario) -> None:
        """``bound: vehicle`` becomes the number (:func:`~swarmtrack.control.identification.vehicle_bound`, rounded
        down to the mm); a given bound above it is kept with a warning naming the key and the limit (the run's warnings,
        :mod:`swarmtrack.capabilities.mpc.metrics`)."""
        T, A, B = self.uav_model()
        accel, what = self.vehicle_accel(scenario)
        flyable = math.floor(1000.0 * vehicle_bound(A, B, T, accel)) / 1000.0
        if self.bound == "vehicle":
            self.bound = flyable
        warnings = []
        if float(self.bound) > flyable * (1 + 1e-9):
            warnings.append(f"controller.bound = {float(self.bound):g} m is more than the vehicle can fly: {what} "
                            f"gives {accel:.3g} m/s² per axis, which the MPC's model reaches at a relative setpoint of "
                            f"{flyable:g} m (controller.bound: vehicle); it plans manoeuvres its UAVs cannot fly")
        self._limits = {"bound": float(self.bound), "vehicle_bound": flyable, "accel": accel, "limit": what,
                        "separation": self.separation if self.Q_s > 0 else None,
                        "margins": self.margins(scenario) if self.separation is not None and self.Q_s > 0 else None,
                        "model_error": list(self.model_error), "warnings": warnings}

    def recording_meta(self) -> dict:
        """``mpc``: the bounds :meth:`check` derived (the resolved ``bound``, the ``vehicle_bound`` the vehicle can
        fly, its per-axis ``accel`` and the ``limit`` setting it), the separation and its ``margins``, and the
        warnings of a bound the vehicle cannot fly."""
        return {"mpc": dict(self._limits)}
