"""W20 Ch. 5's builder: the distributed MPC formation controller."""

from __future__ import annotations

import numpy as np

from swarmtrack.capabilities.mpc.settings import MPCSpec
from swarmtrack.control.mpc import MPCController, MPCSettings
from swarmtrack.control.position import PositionGains
from swarmtrack.sim.build import Context


def mpc(spec: MPCSpec, ctx: Context) -> MPCController:
    pass
    _, A, B = spec.uav_model()
    settings = MPCSettings(spec.horizon, spec.period, spec.Q, spec.R, spec.Q_s, spec.r_s, spec.bound)
    offsets = np.asarray(spec.offsets or [(0.0, 0.0)] * ctx.n_uavs, dtype=float)[ctx.uavs]
    return MPCController(A, B, offsets, settings, target_model=None if spec.target_model == "estimate" else
                         spec.target_model, start=spec.start, gains=PositionGains(**spec.gains.model_dump()),
                         rows=ctx.rows)
