"""Target motion models (CV, CA, CT, FS; CV, CA and CT in 3-D) and the :func:`make_model` factory."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from swarmtrack.models.base import POSITION, VELOCITY, LinearMotionModel, MotionModel
from swarmtrack.models.ca import ConstantAcceleration
from swarmtrack.models.ct import ConstantTurn
from swarmtrack.models.cv import ConstantVelocity
from swarmtrack.models.fs import VZ_INDEX, FullStateQuadrotor
from swarmtrack.models.three_d import (
    ConstantAcceleration3D,
    ConstantTurn3D,
    ConstantVelocity3D,
    FullStateQuadrotor3D,
)

MODEL_NAMES: tuple[str, ...] = ("cv", "ca", "ct", "fs", "cv3d", "ca3d", "ct3d", "fs3d")

_CLASSES: dict[str, type[MotionModel]] = {
    "cv": ConstantVelocity,
    "ca": ConstantAcceleration,
    "ct": ConstantTurn,
    "fs": FullStateQuadrotor,
    "cv3d": ConstantVelocity3D,
    "ca3d": ConstantAcceleration3D,
    "ct3d": ConstantTurn3D,
    "fs3d": FullStateQuadrotor3D,
}

#: Default diagonals of the process-noise covariance Q.
DEFAULT_Q_DIAG: dict[str, tuple[float, ...]] = {
    # L24 Sec. 4: Q = diag(0.05² ×4)
    "cv": (0.05**2,) * 4,
    # Chosen by us (no paper value for CA with this sensor): 0.05² on position/velocity, 0.1² on acceleration.
    "ca": (0.05**2,) * 4 + (0.1**2,) * 2,
    # L24 Sec. 4: Q = diag(0.05² ×4, 0.02²)
    "ct": (0.05**2,) * 4 + (0.02**2,),
    # L24 Sec. 4: Q = diag(0.05² ×5, 0.02² ×4, 0.01² ×3)
    "fs": (0.05**2,) * 5 + (0.02**2,) * 4 + (0.01**2,) * 3,
    # 3-D (ours): the planar variances, repeated on the altitude's states ([x, y, vx, vy, z, vz] first)
    "cv3d": (0.05**2,) * 6,
    "ca3d": (0.05**2,) * 6 + (0.1**2,) * 3,
    "ct3d": (0.05**2,) * 6 + (0.02**2,),
    "fs3d": (0.05**2,) * 6 + (0.02**2,) * 4 + (0.01**2,) * 3,
}


def make_model(
    name: str, dt: float, q: Sequence[float] | np.ndarray | None = None, **params: float
) -> MotionModel:
    """Build a motion model by name with ``Q = diag(q)`` (``q=None``: :data:`DEFAULT_Q_DIAG`).

    ``params`` are extra model parameters (only ``fs`` and ``fs3d`` have any: ``mass``, ``Ixx``, ``Iyy``, ``g``).
    Raises ``ValueError`` for an unknown name, ``dt`` not finite and positive, a ``q`` of the wrong length or
    with non-finite / non-positive entries, or unknown / invalid parameters.
    """
    key = name.lower() if isinstance(name, str) else None
    if key not in _CLASSES:
        raise ValueError(f"unknown motion model {name!r}; expected one of {MODEL_NAMES}")
    try:
        dt_f = float(dt)
    except (TypeError, ValueError):
        raise ValueError(f"dt must be a finite positive number of seconds, got {dt!r}") from None
    if not math.isfinite(dt_f) or dt_f <= 0.0:
        raise ValueError(f"dt must be a finite positive number of seconds, got {dt!r}")

    cls = _CLASSES[key]
    n = len(cls.state_names)
    if q is None:
        q_arr = np.asarray(DEFAULT_Q_DIAG[key], dtype=float)
    else:
        try:
            q_arr = np.asarray(q, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"q must be a sequence of {n} numbers (the diagonal of Q), got {q!r}") from None
        if q_arr.ndim != 1 or q_arr.shape[0] != n:
            raise ValueError(
                f"q for model {key!r} must have length {n} (one variance per state {cls.state_names}), "
                f"got shape {q_arr.shape}"
            )
        if not np.all(np.isfinite(q_arr)) or np.any(q_arr <= 0.0):
            raise ValueError(f"q entries must be finite and positive (variances), got {q_arr.tolist()}")

    allowed = {"mass", "Ixx", "Iyy", "g"} if key in ("fs", "fs3d") else set()
    unknown = set(params) - allowed
    if unknown:
        raise ValueError(
            f"unknown parameter(s) {sorted(unknown)} for model {key!r}; allowed: {sorted(allowed) or 'none'}"
        )
    Q = np.diag(q_arr)
    Q.flags.writeable = False
    return cls(dt=dt_f, Q=Q, **params)


__all__ = [
    "DEFAULT_Q_DIAG",
    "MODEL_NAMES",
    "POSITION",
    "VELOCITY",
    "VZ_INDEX",
    "ConstantAcceleration",
    "ConstantAcceleration3D",
    "ConstantTurn",
    "ConstantTurn3D",
    "ConstantVelocity",
    "ConstantVelocity3D",
    "FullStateQuadrotor",
    "FullStateQuadrotor3D",
    "LinearMotionModel",
    "MotionModel",
    "make_model",
]
