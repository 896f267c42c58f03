"""The range-bearing-elevation measurement in information form: L24's local information (eq. 6) with the relative
elevation angle as a third row, the update its Sec. 6 names as the next step.

A 3-D model (:mod:`swarmtrack.models.three_d`) observes its position ``[x, y, z]`` at the states
:data:`POSITION_3D`, so a measurement's information is a 3 x 3 block ``I`` and a 3-vector ``i`` added there
(L24 eq. 7, :func:`~swarmtrack.estimation.information.add_position_information`), fused by plain sums as in the
plane.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from swarmtrack.models.three_d import ALTITUDE
from swarmtrack.sensors import elevation_bearing_range as ebr
from swarmtrack.sensors.range_bearing import wrap_angle

#: The position states of every 3-D model, ``[x, y, z]``.
POSITION_3D = np.array([0, 1, ALTITUDE])
POSITION_3D.flags.writeable = False


@dataclass(frozen=True)
class RangeBearingElevationUpdate:
    """How a range-bearing-elevation measurement ``[ρ, β, ε]`` enters the filter (the 3-D
    :class:`~swarmtrack.estimation.information.RangeBearingUpdate`).

    ``position``: converted to the position it implies, its information the inverse of
    :func:`~swarmtrack.sensors.elevation_bearing_range.position_covariance` at the predicted range and angles
    (:func:`~swarmtrack.sensors.elevation_bearing_range.position_information`).
    ``spherical``: the EKF update on ``[ρ, β, ε]`` with ``R = diag(σr², σβ², σε²)`` and a wrapped bearing
    innovation. The two agree to first order.
    """

    sigma_range: float
    sigma_bearing: float
    sigma_elevation: float
    mode: str = "position"
    min_range: float = 0.05
    #: The states it observes and their number.
    index: ClassVar[np.ndarray] = POSITION_3D
    dim: ClassVar[int] = 3
    #: The std (m, per axis) of the UAV's own navigation position: added to the converted measurement's covariance
    #: (``R + σ²I``) and, to first order, to the spherical one (``diag(σr² + σ², σβ² + σ²/ρ̂_xy², σε² + σ²/ρ̂²)``:
    #: the rows of ``H`` are orthogonal with norms 1, 1/ρ̂_xy and 1/ρ̂).
    own_sigma: float = 0.0

    def contributions(self, x_pos: np.ndarray, sensor_pos: np.ndarray, z: np.ndarray):
        """Local measurement information ``(I, i)`` (L24 eq. 6 with the elevation row) on the position block:
        ``x_pos`` the predicted target position (..., 3) it is linearised at, ``sensor_pos`` the measuring UAV's
        navigation position, ``z = [ρ, β, ε]``. Returns ``I (..., 3, 3)`` and ``i (..., 3)``."""
        x_pos, sensor_pos, z = (np.asarray(a, dtype=float) for a in (x_pos, sensor_pos, z))
        h, H = ebr.spherical_model(x_pos, sensor_pos, min_range=self.min_range)
        if self.mode == "position":
            I = ebr.position_information(h[..., 0], h[..., 1], h[..., 2], self.sigma_range, self.sigma_bearing,
                                         self.sigma_elevation, own_var=self.own_sigma**2, min_range=self.min_range)
            return I, np.einsum("...ab,...b->...a", I, ebr.to_position(z, sensor_pos))
        nu = z - h
        nu[..., 1] = wrap_angle(nu[..., 1])
        own = self.own_sigma**2
        rel = x_pos - sensor_pos
        horizontal2 = np.maximum(rel[..., 0] ** 2 + rel[..., 1] ** 2, self.min_range**2)
        rho2 = np.maximum(np.sum(rel * rel, axis=-1), self.min_range**2)
        w = np.stack(np.broadcast_arrays(1.0 / (self.sigma_range**2 + own),
                                         1.0 / (self.sigma_bearing**2 + own / horizontal2),
                                         1.0 / (self.sigma_elevation**2 + own / rho2)), axis=-1)
        HtW = np.swapaxes(H, -1, -2) * w[..., None, :]
        I = HtW @ H
        i = np.einsum("...ab,...b->...a", HtW, nu + np.einsum("...ab,...b->...a", H, x_pos))
        return I, i

    @staticmethod
    def to_position(z: np.ndarray, sensor_pos: np.ndarray) -> np.ndarray:
        """The position a measurement implies (:func:`~swarmtrack.sensors.elevation_bearing_range.to_position`)."""
        return ebr.to_position(z, sensor_pos)

    @staticmethod
    def nis(q: np.ndarray, I: np.ndarray, x_pos: np.ndarray, P_pos: np.ndarray) -> np.ndarray:
        """``νᵀ S⁻¹ ν`` (...,) with ``ν = q − x_pos`` and ``S = I⁻¹ + P_pos``, by one solve without inverting ``I``:
        ``S⁻¹ = (Id + I P_pos)⁻¹ I`` (zero for ``I = 0``, a UAV that saw nothing)."""
        nu = q - x_pos
        A = np.eye(I.shape[-1]) + I @ P_pos
        return np.einsum("...a,...a->...", nu, np.linalg.solve(A, np.einsum("...ab,...b->...a", I, nu)[..., None])[
            ..., 0])


