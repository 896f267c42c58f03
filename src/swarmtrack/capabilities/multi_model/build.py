"""W20 Ch. 4's builders: the multi-model distributed EKF and the gimballed camera."""

from __future__ import annotations

import numpy as np

from swarmtrack.capabilities.multi_model.sensor import Budget, ImperfectCamera
from swarmtrack.capabilities.multi_model.settings import CameraSpec, MultiModelSpec
from swarmtrack.estimation.measurements import CameraFrameMeasurement, RangeBearingMeasurement
from swarmtrack.estimation.multimodel import MultiModelEstimator
from swarmtrack.models import make_model
from swarmtrack.onboard.context import Context
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.build import occluders
from swarmtrack.sim.sensors import CameraSensor

#: W20 Table 4.1: x̂0 = [h⁻¹(z0); 0], with CT's turn rate ω0 = 1e-5 rad/s.
W20_HIDDEN_START = {"cv": (0.0, 0.0), "ca": (0.0,) * 4, "ct": (0.0, 0.0, 1e-5)}


def multimodel(spec: MultiModelSpec, ctx: Context) -> MultiModelEstimator:
    """W20 Ch. 4: one model per UAV with Q = q I (ω: q_turn_rate), P0 = p0 I (ω: p0_turn_rate); the filters of the
    UAVs ``ctx.uavs``, beside the names of every UAV's model (the candidates they fuse; in a batch of worlds, one
    world's)."""
    def diag(name: str, value: float, turn: float) -> list[float]:
        dim = make_model(name, ctx.dt_estimation).dim
        return [value] * 4 + ([turn] if name == "ct" else [value] * (dim - 4))

    names = [spec.models[i % len(spec.models)] for i in ctx.uavs]  # a batch of worlds: every world's UAVs
    models = [make_model(m, ctx.dt_estimation, diag(m, spec.q, spec.q_turn_rate)) for m in names]
    s = ctx.scenario.sensor
    measurement = CameraFrameMeasurement(spec.r) if isinstance(s, CameraSpec) else \
        RangeBearingMeasurement(s.sigma_range, s.sigma_bearing)
    return MultiModelEstimator(
        models, measurement, label=ctx.label_of("targets", spec.target - 1), fusion_rule=spec.fusion,
        occlusion=spec.occlusion, window=spec.window, solo_steps=spec.solo_steps, markov=spec.markov,
        P0={m: np.diag(diag(m, spec.p0, spec.p0_turn_rate)) for m in set(spec.models)},
        x0_hidden={m: np.asarray(W20_HIDDEN_START[m]) for m in set(spec.models)}, compiled=ctx.compiled,
        team=(list(spec.models), ctx.rows))


def camera(s: CameraSpec, scenario: Scenario) -> CameraSensor:
    """The ideal camera, or with any of the error budget's sources on, :class:`ImperfectCamera` (issue 27)."""
    tan_half = (0.5 * s.footprint[0] / s.footprint_range, 0.5 * s.footprint[1] / s.footprint_range)
    if s.ideal():
        return CameraSensor(s.sigma, s.height, tan_half, tuple(s.home), occluders(s), s.latency)
    budget = Budget(s.footprint_range, s.noise_distance_power, s.noise_angle_power, np.radians(s.servo_deadband),
                    np.inf if s.servo_speed is None else np.radians(s.servo_speed), np.radians(s.servo_zero_std),
                    s.mount_offset_std)
    return ImperfectCamera(s.sigma, s.height, tan_half, tuple(s.home), occluders(s), s.latency, budget=budget)
