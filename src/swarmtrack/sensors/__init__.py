"""Sensors: the planar range-bearing sensor of L24/L23."""

from swarmtrack.sensors.range_bearing import (
    L23_SIGMA,
    L24_SIGMA,
    MIN_RANGE,
    measure,
    polar_covariance,
    polar_model,
    position_covariance,
    to_position,
    wrap_angle,
)

__all__ = [
    "L23_SIGMA",
    "L24_SIGMA",
    "MIN_RANGE",
    "measure",
    "polar_covariance",
    "polar_model",
    "position_covariance",
    "to_position",
    "wrap_angle",
]
