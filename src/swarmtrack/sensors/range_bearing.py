"""Planar range-bearing sensor (L24 Sec. 3.2, corrected; L23), as vectorised pure functions.

The measurement from UAV ``i`` at ``q_i = (x_i, y_i)`` of the target at ``q_t = (x_t, y_t)`` is
``z = [ρ, β] + v`` with ``ρ = ‖q_t − q_i‖``, ``β = atan2(y_t − y_i, x_t − x_i)`` and
``v ~ N(0, diag(σr², σβ²))`` (L24 Sec. 3.2; its printed ``h`` writes ``x_i − x_i``, see SPEC "Known typos").

Two equivalent (to first order) ways to use it in a filter:

* polar update: :func:`polar_model` gives ``h`` and ``H = ∂h/∂q_t`` with ``R = diag(σr², σβ²)``
  (:func:`polar_covariance`);
* converted-position update: :func:`to_position` turns ``z`` into a position, whose covariance is
  :func:`position_covariance`, L24 Sec. 4 / L23 ``R_i`` in its line-of-sight form.

All functions broadcast over leading batch axes; positions are ``(..., 2)`` arrays.
"""

from __future__ import annotations

import functools

import numpy as np

from swarmtrack.sensors.detections import Detections

#: L24 Sec. 4 sensor noise: (σ_range [m], σ_bearing [rad]).
L24_SIGMA: tuple[float, float] = (0.08, 0.02)
#: L23 sensor noise: (σ_range [m], σ_bearing [rad]).
L23_SIGMA: tuple[float, float] = (0.4, 0.1)

#: Default floor on the range used in Jacobians and covariances [m].
MIN_RANGE = 1e-3


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Wrap angles to ``(−π, π]`` (use it on bearing innovations)."""
    # π − [0, 2π) = (−π, π]: three operations, and no correction for the endpoint
    return np.pi - np.mod(np.pi - np.asarray(a, dtype=float), 2.0 * np.pi)


def _range_bearing(
    target_pos: np.ndarray, sensor_pos: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    d = np.asarray(target_pos, dtype=float)[..., :2] - np.asarray(sensor_pos, dtype=float)[..., :2]
    dx, dy = d[..., 0], d[..., 1]
    return dx, dy, np.hypot(dx, dy)


def measure(
    target_pos: np.ndarray,
    sensor_pos: np.ndarray,
    sigma_range: float | np.ndarray,
    sigma_bearing: float | np.ndarray,
    rng: np.random.Generator | None = None,
    noise: np.ndarray | None = None,
) -> np.ndarray:
    """Noisy ``[range, bearing]`` (..., 2) of the target from the sensor (L24 Sec. 3.2).

    Noise is additive Gaussian: standard normal draws from ``rng``, or the given ``noise`` (..., 2); the bearing
    is wrapped to ``(−π, π]``. The range is not clipped, so at ranges comparable to ``sigma_range`` it can come
    out negative (as the model says).
    """
    dx, dy, rho = _range_bearing(target_pos, sensor_pos)
    beta = np.arctan2(dy, dx)
    if noise is None:
        assert rng is not None, "measure needs rng or noise"
        noise = rng.standard_normal(rho.shape + (2,))
    z_rho = rho + np.asarray(sigma_range, dtype=float) * noise[..., 0]
    z_beta = wrap_angle(beta + np.asarray(sigma_bearing, dtype=float) * noise[..., 1])
    return np.stack(np.broadcast_arrays(z_rho, z_beta), axis=-1)


def polar_model(
    target_pos: np.ndarray, sensor_pos: np.ndarray, min_range: float = MIN_RANGE
) -> tuple[np.ndarray, np.ndarray]:
    """Predicted ``h = [ρ, β]`` (..., 2) and ``H = ∂h/∂(x_t, y_t)`` (..., 2, 2) (L24 Sec. 3.2).

    ``H = [[dx/ρ, dy/ρ], [−dy/ρ², dx/ρ²]]`` with ``ρ`` floored at ``min_range`` so ``H`` stays finite when the
    target estimate sits on the sensor.
    """
    dx, dy, rho = _range_bearing(target_pos, sensor_pos)
    h = np.stack([rho, np.arctan2(dy, dx)], axis=-1)
    r = np.maximum(rho, min_range)
    r2 = r * r
    H = np.empty(rho.shape + (2, 2))
    H[..., 0, 0] = dx / r
    H[..., 0, 1] = dy / r
    H[..., 1, 0] = -dy / r2
    H[..., 1, 1] = dx / r2
    return h, H


def polar_covariance(sigma_range: float, sigma_bearing: float) -> np.ndarray:
    """Measurement noise covariance ``diag(σr², σβ²)`` for the polar update."""
    return np.diag([float(sigma_range) ** 2, float(sigma_bearing) ** 2])


def to_position(z: np.ndarray, sensor_pos: np.ndarray) -> np.ndarray:
    """Target position (..., 2) implied by ``z = [ρ, β]``: ``q_i + ρ·(cos β, sin β)``."""
    z = np.asarray(z, dtype=float)
    rho, beta = z[..., 0], z[..., 1]
    offset = np.stack([rho * np.cos(beta), rho * np.sin(beta)], axis=-1)
    return np.asarray(sensor_pos, dtype=float)[..., :2] + offset


def position_covariance(
    rng_dist: np.ndarray | float,
    bearing: np.ndarray | float,
    sigma_range: float | np.ndarray,
    sigma_bearing: float | np.ndarray,
    min_range: float = MIN_RANGE,
) -> np.ndarray:
    """Covariance (..., 2, 2) of the position :func:`to_position` implies (L24 Sec. 4, L23 ``R_i``).

    ``R = Λ diag(σr², ρ²σβ²) Λᵀ`` with ``Λ = [[cos β, −sin β], [sin β, cos β]]``: variance ``σr²`` along the
    line of sight ``(cos β, sin β)`` and ``ρ²σβ²`` across it (first-order propagation of the polar noise).
    The papers print ``Λᵀ D Λ``, which puts the range noise across the line of sight; the line-of-sight form
    is the intended one (SPEC "Known typos"). ``ρ`` is floored at ``min_range`` so ``R`` stays positive
    definite at ``ρ = 0``.
    """
    rho = np.maximum(np.abs(np.asarray(rng_dist, dtype=float)), min_range)
    beta = np.asarray(bearing, dtype=float)
    rho, beta = np.broadcast_arrays(rho, beta)
    c, s = np.cos(beta), np.sin(beta)
    var_r = np.asarray(sigma_range, dtype=float) ** 2 + np.zeros_like(rho)
    var_t = rho**2 * np.asarray(sigma_bearing, dtype=float) ** 2
    R = np.empty(rho.shape + (2, 2))
    R[..., 0, 0] = var_r * c * c + var_t * s * s
    R[..., 1, 1] = var_r * s * s + var_t * c * c
    R[..., 0, 1] = R[..., 1, 0] = (var_r - var_t) * c * s
    return R


def sense(
    objects: np.ndarray,
    uavs: np.ndarray,
    stamped: np.ndarray,
    sigma_range: float,
    sigma_bearing: float,
    noise: np.ndarray,
    max_range: float | None = None,
    hidden: np.ndarray | None = None,
    taken: float | None = None,
):
    """One range-bearing sensing step of every UAV towards every labelled object (truth side; L24 Sec. 3.2).

    ``objects`` (M, 2) and ``uavs`` (N, 2) are true positions, ``stamped`` (N, 2) the navigation positions the
    UAVs stamp on their measurements, ``noise`` (N, M, 2) standard normal draws for every (UAV, object) pair,
    in range or not (so the draws do not depend on the geometry). The sensor is a cooperative one (a marker
    it can read), so each detection carries its object's index as its label. Returns the
    :class:`~swarmtrack.sensors.detections.Detections` (UAV-major order, stamped ``taken``) and, for the world
    only, the index of the object each came from. ``hidden`` (N, M): pairs an occluder hides (no detection).
    """
    n, m = len(uavs), len(objects)
    z = measure(objects[None, :, :], uavs[:, None, :], sigma_range, sigma_bearing, noise=noise)  # (N, M, 2)
    owner, source = _grid(n, m)
    z = z.reshape(n * m, 2)
    grid: int | None = m
    if max_range is not None or hidden is not None:
        inside = np.ones(len(owner), dtype=bool) if hidden is None else ~hidden.reshape(-1)
        if max_range is not None:
            inside &= _range_bearing(objects[source], uavs[owner])[2] <= max_range
        owner, source, z = owner[inside], source[inside], z[inside]
        grid = None
    return Detections(owner, z, stamped[owner], source, n, grid, taken=taken), source


def sense_worlds(objects: np.ndarray, uavs: np.ndarray, stamped: np.ndarray, sigma_range: float,
                 sigma_bearing: float, noise: np.ndarray, labels: np.ndarray, max_range: float | None = None,
                 taken: float | None = None):
    """:func:`sense` for a batch of B worlds of one layout, each UAV towards its own world's objects only:
    ``objects`` (B, M, 2), ``uavs`` and ``stamped`` (B, N, 2), ``noise`` (B, N, M, 2), ``labels`` (B, M) each
    object's label. The detections of world b's UAV i are those of UAV ``b·N + i``; the pairs of each world are
    computed as :func:`sense` computes them alone. Returns the detections and each one's label."""
    worlds, n, m = uavs.shape[0], uavs.shape[1], objects.shape[1]
    z = measure(objects[:, None, :, :], uavs[:, :, None, :], sigma_range, sigma_bearing, noise=noise)  # (B, N, M, 2)
    owner = np.repeat(np.arange(worlds * n), m)
    source = np.broadcast_to(labels[:, None, :], (worlds, n, m)).reshape(-1)
    z = z.reshape(-1, 2)
    if max_range is not None:
        inside = _range_bearing(objects[:, None, :, :], uavs[:, :, None, :])[2].reshape(-1) <= max_range
        owner, source, z = owner[inside], source[inside], z[inside]
    return Detections(owner, z, stamped.reshape(-1, 2)[owner], source, worlds * n, None, taken=taken), source


@functools.lru_cache(maxsize=8)
def _grid(n: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Owner and object of every (UAV, object) pair, UAV-major (read-only, shared between steps)."""
    owner, source = np.divmod(np.arange(n * m), m) if m else (np.zeros(0, int), np.zeros(0, int))
    owner.setflags(write=False)
    source.setflags(write=False)
    return owner, source


def of_relative(rel: np.ndarray, pos: np.ndarray) -> tuple[np.ndarray, None]:
    """L24 Sec. 3.2's noiseless ``z = [ρ, β]`` of targets at planar positions ``rel`` (M, 2) relative to the UAVs
    at ``pos`` (M, 2), and no frame: what a log's relative positions are replayed as
    (:class:`~swarmtrack.registry.Measurement`)."""
    return np.stack([np.hypot(rel[:, 0], rel[:, 1]), np.arctan2(rel[:, 1], rel[:, 0])], axis=1), None


def relative_of(det: Detections) -> np.ndarray:
    """The planar target positions relative to their UAVs (M, 2) that ``det``'s ``[ρ, β]`` say: the inverse of
    :func:`of_relative`."""
    return det.z[:, :1] * np.stack([np.cos(det.z[:, 1]), np.sin(det.z[:, 1])], axis=1)


def positions(det: Detections, sigma_range: float, sigma_bearing: float,
              own_sigma: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Each detection as the position it implies (:func:`to_position`, (M, 2)) and that position's covariance
    (:func:`position_covariance` at the measured range and bearing, plus ``own_sigma² I`` for the UAV's own
    navigation error; (M, 2, 2)): what a tracker of unlabelled detections reads (issue 40)."""
    R = position_covariance(det.z[:, 0], det.z[:, 1], sigma_range, sigma_bearing)
    R[:, 0, 0] += own_sigma**2
    R[:, 1, 1] += own_sigma**2
    return to_position(det.z, det.sensor_pos), R
