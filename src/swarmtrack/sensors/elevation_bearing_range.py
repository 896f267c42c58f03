"""Range-bearing-elevation sensor: L24's planar range-bearing sensor (:mod:`swarmtrack.sensors.range_bearing`) with
the relative elevation angle L24 Sec. 6 names as its next step, as vectorised pure functions.

The measurement from a UAV at ``q_i = (x_i, y_i, z_i)`` of the target at ``q_t`` is ``z = [ρ, β, ε] + v`` with
``d = q_t − q_i``, the range ``ρ = ‖d‖``, the bearing ``β = atan2(d_y, d_x)``, the elevation ``ε = atan2(d_z,
‖d_xy‖)`` and ``v ~ N(0, diag(σr², σβ², σε²))``. The order extends the planar ``[ρ, β]``; Stone Soup's
``CartesianToElevationBearingRange`` measures the same three as ``[ε, β, ρ]``.

**Noise (our choice, documented in docs/three-d.md).** L24's sensor has a constant range noise and a constant
angular noise, so the position it implies is uncertain across the line of sight in proportion to the distance
(L24 Sec. 4's ``R_i``). The elevation angle is read by the same sensor as the bearing, so it gets the same kind of
noise: a constant ``σε`` (the scenarios take ``σε = σβ``), and a cross-range error ``ρ σε`` in the vertical plane of
the line of sight. The converted position's covariance (first-order propagation, :func:`position_covariance`) is

    ``R = σr² u_ρ u_ρᵀ + (ρ cos ε)² σβ² u_β u_βᵀ + ρ² σε² u_ε u_εᵀ``

with the unit vectors along the line of sight ``u_ρ``, horizontal across it ``u_β`` and vertical across it ``u_ε``.
At ``ε = 0`` its horizontal block is the planar ``R_i`` and its altitude is decoupled (variance ``ρ² σε²``), so a
target level with its sensors is seen in the plane as by the planar sensor.

All functions broadcast over leading batch axes; positions are ``(..., 3)`` arrays.
"""

from __future__ import annotations

import numpy as np

from swarmtrack.sensors.detections import Detections
from swarmtrack.sensors.range_bearing import MIN_RANGE, wrap_angle

#: Index of each angle in a measurement ``[ρ, β, ε]``.
RANGE, BEARING, ELEVATION = 0, 1, 2


def _relative(target_pos: np.ndarray, sensor_pos: np.ndarray):
    d = np.asarray(target_pos, dtype=float)[..., :3] - np.asarray(sensor_pos, dtype=float)[..., :3]
    dx, dy, dz = d[..., 0], d[..., 1], d[..., 2]
    horizontal = np.hypot(dx, dy)
    return dx, dy, dz, horizontal, np.hypot(horizontal, dz)


def spherical(target_pos: np.ndarray, sensor_pos: np.ndarray) -> np.ndarray:
    """Noise-free ``[ρ, β, ε]`` (..., 3) of the target from the sensor."""
    dx, dy, dz, horizontal, rho = _relative(target_pos, sensor_pos)
    return np.stack([rho, np.arctan2(dy, dx), np.arctan2(dz, horizontal)], axis=-1)


def measure(
    target_pos: np.ndarray,
    sensor_pos: np.ndarray,
    sigma_range: float | np.ndarray,
    sigma_bearing: float | np.ndarray,
    sigma_elevation: float | np.ndarray,
    rng: np.random.Generator | None = None,
    noise: np.ndarray | None = None,
) -> np.ndarray:
    """Noisy ``[ρ, β, ε]`` (..., 3): standard normal draws from ``rng`` or the given ``noise`` (..., 3), scaled by
    each axis' standard deviation and added; the bearing wrapped to ``(−π, π]``. As in the planar sensor, nothing
    is clipped: a range comparable to ``σr`` can come out negative, an elevation near ±90° can pass it."""
    h = spherical(target_pos, sensor_pos)
    if noise is None:
        assert rng is not None, "measure needs rng or noise"
        noise = rng.standard_normal(h.shape)
    sigma = np.stack(np.broadcast_arrays(*(np.asarray(s, dtype=float) for s in (sigma_range, sigma_bearing,
                                                                                 sigma_elevation))), axis=-1)
    z = h + sigma * noise
    z[..., BEARING] = wrap_angle(z[..., BEARING])
    return z


def spherical_model(
    target_pos: np.ndarray, sensor_pos: np.ndarray, min_range: float = MIN_RANGE
) -> tuple[np.ndarray, np.ndarray]:
    """Predicted ``h = [ρ, β, ε]`` (..., 3) and ``H = ∂h/∂(x_t, y_t, z_t)`` (..., 3, 3):

    ``∂ρ = d/ρ``, ``∂β = (−d_y, d_x, 0)/‖d_xy‖²``, ``∂ε = (−d_z d_x/‖d_xy‖, −d_z d_y/‖d_xy‖, ‖d_xy‖)/ρ²``,

    with ``ρ`` and ``‖d_xy‖`` floored at ``min_range`` so ``H`` stays finite when the estimate sits on the sensor
    or straight above or below it (where the bearing is undefined)."""
    dx, dy, dz, horizontal, rho = _relative(target_pos, sensor_pos)
    h = np.stack([rho, np.arctan2(dy, dx), np.arctan2(dz, horizontal)], axis=-1)
    r = np.maximum(rho, min_range)
    s = np.maximum(horizontal, min_range)
    r2, s2 = r * r, s * s
    H = np.empty(rho.shape + (3, 3))
    H[..., RANGE, 0] = dx / r
    H[..., RANGE, 1] = dy / r
    H[..., RANGE, 2] = dz / r
    H[..., BEARING, 0] = -dy / s2
    H[..., BEARING, 1] = dx / s2
    H[..., BEARING, 2] = 0.0
    H[..., ELEVATION, 0] = -dz * dx / (r2 * s)
    H[..., ELEVATION, 1] = -dz * dy / (r2 * s)
    H[..., ELEVATION, 2] = horizontal / r2
    return h, H


def polar_covariance(sigma_range: float, sigma_bearing: float, sigma_elevation: float) -> np.ndarray:
    """Measurement noise covariance ``diag(σr², σβ², σε²)`` of the spherical update."""
    return np.diag([float(sigma_range) ** 2, float(sigma_bearing) ** 2, float(sigma_elevation) ** 2])


def to_position(z: np.ndarray, sensor_pos: np.ndarray) -> np.ndarray:
    """Target position (..., 3) implied by ``z = [ρ, β, ε]``: ``q_i + ρ (cos ε cos β, cos ε sin β, sin ε)``."""
    z = np.asarray(z, dtype=float)
    rho, beta, eps = z[..., RANGE], z[..., BEARING], z[..., ELEVATION]
    horizontal = rho * np.cos(eps)
    offset = np.stack([horizontal * np.cos(beta), horizontal * np.sin(beta), rho * np.sin(eps)], axis=-1)
    return np.asarray(sensor_pos, dtype=float)[..., :3] + offset


def position_covariance(
    rng_dist: np.ndarray | float,
    bearing: np.ndarray | float,
    elevation: np.ndarray | float,
    sigma_range: float | np.ndarray,
    sigma_bearing: float | np.ndarray,
    sigma_elevation: float | np.ndarray,
    min_range: float = MIN_RANGE,
) -> np.ndarray:
    """Covariance (..., 3, 3) of the position :func:`to_position` implies (module docstring): ``σr²`` along the
    line of sight, ``(ρ cos ε)² σβ²`` horizontally across it and ``ρ² σε²`` vertically across it.

    Both levers are floored at ``min_range`` (``ρ`` and its horizontal part ``ρ cos ε``) so ``R`` stays positive
    definite on the sensor and straight above or below it; at ``ε = 0`` the horizontal block equals
    :func:`swarmtrack.sensors.range_bearing.position_covariance`."""
    return _spectral(rng_dist, bearing, elevation, sigma_range, sigma_bearing, sigma_elevation, min_range,
                     lambda var: var)


def position_information(
    rng_dist: np.ndarray | float,
    bearing: np.ndarray | float,
    elevation: np.ndarray | float,
    sigma_range: float | np.ndarray,
    sigma_bearing: float | np.ndarray,
    sigma_elevation: float | np.ndarray,
    own_var: float = 0.0,
    min_range: float = MIN_RANGE,
) -> np.ndarray:
    """``(R + own_var·I)⁻¹`` (..., 3, 3) for ``R`` of :func:`position_covariance`, in closed form: ``R``'s
    eigenvectors are the three orthonormal directions, so the inverse is the same sum with each variance (plus
    ``own_var``, the UAV's own navigation variance per axis) inverted; nothing is factorised."""
    return _spectral(rng_dist, bearing, elevation, sigma_range, sigma_bearing, sigma_elevation, min_range,
                     lambda var: 1.0 / (var + own_var))


def _spectral(rng_dist, bearing, elevation, sigma_range, sigma_bearing, sigma_elevation, min_range,
              weight) -> np.ndarray:
    """``Σ weight(var_a) e_a e_aᵀ`` over the line of sight ``u``, the horizontal across it ``v`` and the vertical
    across it ``w``, with their variances ``σr²``, ``max(ρ cos ε, min_range)² σβ²`` and ``ρ² σε²`` (``ρ`` floored at
    ``min_range``)."""
    rho = np.maximum(np.abs(np.asarray(rng_dist, dtype=float)), min_range)
    rho, beta, eps = np.broadcast_arrays(rho, np.asarray(bearing, dtype=float), np.asarray(elevation, dtype=float))
    cb, sb, ce, se = np.cos(beta), np.sin(beta), np.cos(eps), np.sin(eps)
    u = np.stack([ce * cb, ce * sb, se], axis=-1)  # along the line of sight
    v = np.stack([-sb, cb, np.zeros_like(sb)], axis=-1)  # horizontal, across it
    w = np.stack([-se * cb, -se * sb, ce], axis=-1)  # vertical plane, across it
    var_r = np.asarray(sigma_range, dtype=float) ** 2 + np.zeros_like(rho)
    var_b = np.maximum(rho * np.abs(ce), min_range) ** 2 * np.asarray(sigma_bearing, dtype=float) ** 2
    var_e = rho**2 * np.asarray(sigma_elevation, dtype=float) ** 2
    return sum(weight(var)[..., None, None] * e[..., :, None] * e[..., None, :]
               for var, e in ((var_r, u), (var_b, v), (var_e, w)))


def sense(objects: np.ndarray, uavs: np.ndarray, stamped: np.ndarray, sigma_range: float, sigma_bearing: float,
          sigma_elevation: float, noise: np.ndarray, max_range: float | None = None, taken: float | None = None):
    """One sensing step of every UAV towards every labelled object (truth side): ``objects`` (M, 3) and ``uavs``
    (N, 3) true positions, ``stamped`` (N, 3) the navigation positions the UAVs stamp on their measurements,
    ``noise`` (N, M, 3) standard normal draws for every pair, in range or not (the draws do not depend on the
    geometry). As :func:`swarmtrack.sensors.range_bearing.sense`: UAV-major detections, each labelled with its
    object's index, and (for the world only) the index of the object each came from."""
    n, m = len(uavs), len(objects)
    z = measure(objects[None, :, :], uavs[:, None, :], sigma_range, sigma_bearing, sigma_elevation,
                noise=noise).reshape(n * m, 3)
    owner, source = np.divmod(np.arange(n * m), m) if m else (np.zeros(0, int), np.zeros(0, int))
    grid: int | None = m
    if max_range is not None:
        inside = _relative(objects[source], uavs[owner])[4] <= max_range
        owner, source, z = owner[inside], source[inside], z[inside]
        grid = None
    return Detections(owner, z, stamped[owner], source, n, grid, taken=taken), source
