"""Measurement models of the stacked (multi-UAV) covariance EKF of W20 Ch. 4, per detection and batched.

A UAV stacks its own and its neighbours' measurements (W20 eqs. 4.17-4.22, block-diagonal R). Every sensor of this
project observes the target's planar position, so each stacked measurement ``l`` enters through the position
block only: its Jacobian ``H_l`` is 2 x 2 on ``[x, y]``. A model here gives, for each (receiver, measurement)
pair, the innovation ``ν_l = z_l − h_l(x̂⁻)`` at the receiver's prediction, ``H_l``, ``R_l⁻¹`` and ``log det R_l``;
:mod:`swarmtrack.estimation.multimodel` sums them per receiver. A payload is what a UAV broadcasts of its own
detection: the raw measurement and the pose data needed to use it ("measurement and transform data", W20
Sec. 4.3.4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.sensors import camera
from swarmtrack.sensors.detections import Detections
from swarmtrack.sensors.range_bearing import polar_model, to_position, wrap_angle


@dataclass(frozen=True)
class CameraFrameMeasurement:
    """The camera's metric target position in its frame, ``z = A p + b + v``, ``v ~ N(0, r I₂)`` (W20 eqs.
    4.14-4.16; linear in the target's ground position, so the EKF update is exact)."""

    r: float

    def payload(self, own: Detections, label: int) -> dict[str, np.ndarray]:
        z, _, seen = own.of_label(label)
        return {"z": z, "frame": own.frame_of_label(label), "seen": seen}

    def terms(self, x_pos: np.ndarray, got: dict, rows: np.ndarray):
        """``ν, H, R⁻¹, log det R`` of the payload rows ``rows`` linearised at ``x_pos`` (E, 2)."""
        frame = got["frame"][rows]
        H = frame[:, :, :2]
        nu = got["z"][rows] - np.einsum("eab,eb->ea", H, x_pos) - frame[:, :, 2]
        e = len(rows)
        Rinv, logdet = self.noise()
        return nu, H, np.broadcast_to(Rinv, (e, 2, 2)), np.full(e, logdet)

    def noise(self) -> tuple[np.ndarray, float]:
        """``R⁻¹`` (2, 2) and ``log det R`` of every measurement."""
        return np.eye(2) / self.r, 2.0 * np.log(self.r)

    def position(self, got: dict, rows: np.ndarray) -> np.ndarray:
        """``h⁻¹(z)``: the ground position each payload row implies (W20 Table 4.1, ``x̂0``)."""
        return camera.invert(got["frame"][rows], got["z"][rows])


@dataclass(frozen=True)
class RangeBearingMeasurement:
    """Range and bearing from the measuring UAV, ``R = diag(σr², σβ²)``, bearing innovations wrapped (L24 Sec. 3.2;
    the polar EKF update, linearised at the receiver's prediction)."""

    sigma_range: float
    sigma_bearing: float
    min_range: float = 0.05

    def payload(self, own: Detections, label: int) -> dict[str, np.ndarray]:
        z, pos, seen = own.of_label(label)
        return {"z": z, "sensor_pos": pos, "seen": seen}

    def terms(self, x_pos: np.ndarray, got: dict, rows: np.ndarray):
        h, H = polar_model(x_pos, got["sensor_pos"][rows], min_range=self.min_range)
        nu = got["z"][rows] - h
        nu[:, 1] = wrap_angle(nu[:, 1])
        w = np.array([1.0 / self.sigma_range**2, 1.0 / self.sigma_bearing**2])
        e = len(rows)
        return nu, H, np.broadcast_to(np.diag(w), (e, 2, 2)), np.full(e, -np.log(w).sum())

    def position(self, got: dict, rows: np.ndarray) -> np.ndarray:
        return to_position(got["z"][rows], got["sensor_pos"][rows])
