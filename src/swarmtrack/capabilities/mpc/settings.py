"""W20 Ch. 5's settings: the distributed MPC formation controller, the UAVs' identified model and their own
position controller."""

from __future__ import annotations

from typing import ClassVar, Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from swarmtrack.control.identification import NAMED_MODELS, check_model
from swarmtrack.scenarios.schema import Acceleration, ControllerSpec, Gain, Length, Position, Scenario, Strict, Time


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
