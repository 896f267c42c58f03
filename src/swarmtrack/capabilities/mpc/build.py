"""W20 Ch. 5's builder: the distributed MPC formation controller."""

from __future__ import annotations

import numpy as np

from swarmtrack.capabilities.mpc.settings import MPCSpec
from swarmtrack.control.mpc import MPCController, MPCSettings
from swarmtrack.control.position import PositionGains
from swarmtrack.onboard.context import Context


def mpc(spec: MPCSpec, ctx: Context) -> MPCController:
    _, A, B = spec.uav_model()
    separation = spec.separation if spec.Q_s > 0 else None  # Q_s = 0 turns collision avoidance off, all of it
    assert not isinstance(spec.bound, str), "validation resolves bound: vehicle to the number"
    settings = MPCSettings(spec.horizon, spec.period, spec.Q, spec.R, spec.Q_s, spec.r_s, float(spec.bound),
                           separation=separation,
                           margins=tuple(spec.margins(ctx.scenario)) if separation is not None else ())
    n = ctx.scenario.swarm.n_uavs  # a batch of worlds: each world's UAV i takes offset i
    offsets = np.asarray(spec.offsets or [(0.0, 0.0)] * n, dtype=float)[ctx.uavs % n]
    return MPCController(A, B, offsets, settings, target_model=None if spec.target_model == "estimate" else
                         spec.target_model, start=spec.start, gains=PositionGains(**spec.gains.model_dump()),
                         rows=ctx.rows)
