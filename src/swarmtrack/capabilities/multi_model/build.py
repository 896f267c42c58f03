"""W20 Ch. 4's onboard builder: the multi-model distributed EKF (the gimballed camera is built in :mod:`.world`)."""

from __future__ import annotations

import numpy as np

from swarmtrack.capabilities.multi_model.settings import CameraSpec, MultiModelSpec
from swarmtrack.estimation.measurements import CameraFrameMeasurement, RangeBearingMeasurement
from swarmtrack.estimation.multimodel import MultiModelEstimator
from swarmtrack.models import make_model
from swarmtrack.onboard.context import Context

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
        RangeBearingMeasurement(s.sigma_range, s.sigma_bearing)  # type: ignore[attr-defined]  # range-bearing
    return MultiModelEstimator(
        models, measurement, label=ctx.target_label(spec.target - 1), fusion_rule=spec.fusion,
        occlusion=spec.occlusion, window=spec.window, solo_steps=spec.solo_steps, markov=spec.markov,
        P0={m: np.diag(diag(m, spec.p0, spec.p0_turn_rate)) for m in set(spec.models)},
        x0_hidden={m: np.asarray(W20_HIDDEN_START[m]) for m in set(spec.models)}, compiled=ctx.compiled,
        team=(list(spec.models), ctx.rows))
