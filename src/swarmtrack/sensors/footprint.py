"""Downward camera footprint and identification cones (IB21 Sec. 3.2 and Sec. 6, eqs. 3-8 and 50-54).

**Footprint** F_i (IB21 Sec. 6: "opening angles equal to π/4 in both azimuth and elevation"). A nadir camera on a UAV
at altitude ``h`` (γ = 0, no roll or pitch modelled) sees a ground square of half-side ``h·tan_half``, centred below
the UAV. Two readings of the opening (:func:`tan_half`): ``"full"`` (ours, the default), π/4 is the full angle, so
``tan_half = tan(π/8)`` and the side is 82.84 m at 100 m; ``"half"``, π/4 is the half angle, 200 m at 100 m. The full
angle is the paper's own convention for its cones ("aperture 2λ = π/60"), and only the small square agrees with
Fig. 8 (a 200 m square would let two UAVs clear the 400 × 400 m area in ≈ 24 s; the paper needs ≥ 5 UAVs).
The paper does not say how the square is oriented; ours (``orientation="heading"``, default): body-fixed, sides
along and across the heading (the camera is strapped to the airframe); ``"north"``: sides along the axes.
Every object in the *closed* square is detected (no missed detections, no false alarms), and its measurement is
its ground position plus a noise uniform in ``±w̄`` per axis (IB21 Sec. 6, ``h_i(x^u, x) = (x1, x2)``, eqs. 5-8).
:func:`footprint_corners` is the one geometry of F: the truth side tests detection with :func:`inside`, the onboard
estimator removes :func:`footprint_polygons` of the same corners (eroded as it needs).

**Identification cones** (eqs. 50-54). ``g = Δᵀa − ‖Δ‖‖a‖cos λ`` with ``Δ = p_uav − p_obj`` in 3-D, the object on
the ground (z = 0): ``g ≥ 0`` iff the UAV is inside the one-nappe circular cone of half-aperture λ with its vertex at
the object and its axis ``a = (sin γ cos(x3 + β), sin γ sin(x3 + β), cos γ)`` (eqs. 51, 54), which turns with the
object's heading x3; ``β ~ U(−π/4, π/4)``, ``γ ~ U(2π/60, 3π/60)`` per object (:func:`draw_cones`). The paper gives
full apertures 2λ: π/60 for a true target (eq. 50), π/30 for a decoy's identification cone g^f (eq. 52) and π/60
for its confusion test q^f (eq. 53). At 100 m the patch of UAV positions inside a π/60 cone is a near-circle of
radius ≈ 2.6 m whose centre is 100·tan γ = 10.5-15.8 m from the object.

**The confusion sign** (eq. 4: a decoy ℓ with ``g^f ≥ 0 ∧ q^f ≥ 0`` is reported as the true target J(ℓ);
``q^f < 0``: it is recognised as false). Eq. 53 is printed with the form of eq. 52, so literally ``q^f ≥ 0`` *inside*
the inner π/60 cone. The Sec. 3.2 text ("q^f ≥ 0 is satisfied if UAV i does *not* belong to some cone whose apex is
x^f_ℓ") and Fig. 3 (q^f < 0 on the dark cone, where decoys are identified as false) say the opposite. Default
(``confusion="outside_inner_cone"``), the text's reading, ``q^f = ‖Δ‖‖a‖cos λ^{f,q} − Δᵀa`` (eq. 53 negated):

* outside the π/30 cone: unidentified (``UNLABELLED``);
* inside π/30, outside π/60: confused, label J(ℓ);
* inside π/60: identified as false (``IDENTIFIED_FALSE``).

``confusion="inside_inner_cone"`` is eq. 53 as printed (the last two outcomes swap). A true target j is labelled j
inside its π/60 cone and ``UNLABELLED`` outside (eq. 3; true targets are never misidentified). J(ℓ) is not given;
ours: ``ℓ mod N_t`` (:func:`confusion_map`).

Pure functions over arrays with a leading axis over UAVs (n) and/or objects (m). Randomness comes in as a
generator (:func:`draw_cones`) or as pre-drawn uniforms (:func:`sense`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property

import numba
import numpy as np

from swarmtrack.sensors.detections import IDENTIFIED_FALSE, UNLABELLED, Detections

#: IB21 Sec. 6: the sensor opening in azimuth and elevation [rad].
OPENING = math.pi / 4
#: IB21 Sec. 6 full apertures 2λ [rad]: true target (eq. 50), decoy identification g^f (eq. 52), decoy q^f (eq. 53).
APERTURE_TRUE = math.pi / 60
APERTURE_DECOY_IDENTIFY = math.pi / 30
APERTURE_DECOY_REVEAL = math.pi / 60
#: IB21 Sec. 6 laws of the cone axis angles (eqs. 51, 54): azimuth β and angle from the vertical γ [rad].
BETA_RANGE = (-math.pi / 4, math.pi / 4)
GAMMA_RANGE = (2 * math.pi / 60, 3 * math.pi / 60)
CONVENTIONS = ("full", "half")
ORIENTATIONS = ("heading", "north")
CONFUSIONS = ("outside_inner_cone", "inside_inner_cone")


@dataclass(frozen=True)
class FootprintParams:
    """The footprint sensor of IB21 Sec. 6 with our readings (module docstring): ``opening`` (rad) read as a
    ``convention`` ("full" | "half") angle, ``orientation`` ("heading" | "north"), the *true* noise half-widths
    ``noise_bound`` (m, per axis), the full cone apertures (rad), and the ``confusion`` reading of eq. 53."""

    opening: float = OPENING
    convention: str = "full"
    orientation: str = "heading"
    noise_bound: tuple[float, float] = (5.0, 5.0)
    aperture_true: float = APERTURE_TRUE
    aperture_decoy_identify: float = APERTURE_DECOY_IDENTIFY
    aperture_decoy_reveal: float = APERTURE_DECOY_REVEAL
    confusion: str = "outside_inner_cone"

    def __post_init__(self) -> None:
        for name, allowed in (("convention", CONVENTIONS), ("orientation", ORIENTATIONS),
                              ("confusion", CONFUSIONS)):
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name} must be one of {allowed}, not {getattr(self, name)!r}")

    @property
    def tan_half(self) -> float:
        return tan_half(self.opening, self.convention)


# --- footprint ---------------------------------------------------------------------------------------------------


def tan_half(opening: float = OPENING, convention: str = "full") -> float:
    """``tan`` of the half opening: ``tan(opening/2)`` if ``opening`` is the full angle (ours: 82.84 m square at
    100 m for π/4), ``tan(opening)`` if it is the half angle (200 m). IB21 Sec. 6; module docstring."""
    if convention == "full":
        return math.tan(opening / 2)
    if convention == "half":
        return math.tan(opening)
    raise ValueError(f"convention must be one of {CONVENTIONS}, not {convention!r}")


def footprint_corners(xy, heading, altitude, tan_half: float, orientation: str = "heading") -> np.ndarray:
    """Corners (n, 4, 2) of the ground footprints F_i of ``n`` UAVs at ``xy`` (n, 2), heading ``heading`` (n,),
    altitude ``altitude`` (scalar or (n,)), counter-clockwise, starting rear right: the square of half-side
    ``altitude·tan_half`` centred below the UAV, its sides along and across the heading (``"heading"``) or the axes
    (``"north"``). IB21 Sec. 3.2, Sec. 6."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    half = (np.asarray(altitude, dtype=float) * tan_half) * np.ones(len(xy))
    if orientation == "heading":
        psi = np.asarray(heading, dtype=float) * np.ones(len(xy))
    elif orientation == "north":
        psi = np.zeros(len(xy))
    else:
        raise ValueError(f"orientation must be one of {ORIENTATIONS}, not {orientation!r}")
    fwd = half[:, None] * np.stack([np.cos(psi), np.sin(psi)], axis=-1)  # along the heading
    left = half[:, None] * np.stack([-np.sin(psi), np.cos(psi)], axis=-1)  # across it, to the left
    signs = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])  # (fwd, left) of each corner, CCW
    return xy[:, None, :] + signs[None, :, 0, None] * fwd[:, None, :] + signs[None, :, 1, None] * left[:, None, :]


def footprint_polygons(corners) -> np.ndarray:
    """(n,) object array of shapely Polygons of the footprints ``corners`` (n, 4, 2) (the onboard set operations
    of IB21 eqs. 21, 26, 28 use these)."""
    import shapely

    return shapely.polygons(np.asarray(corners, dtype=float))


#: Shewchuk's bound on the rounding error of the float orientation determinant (orient2dfast), with margin.
_ORIENT_ERR = 1e-15


def inside(corners, points) -> np.ndarray:
    """(n, m) bool: is point j in the *closed* footprint i? ``corners`` (n, 4, 2) counter-clockwise and convex (as
    :func:`footprint_corners` gives them), ``points`` (m, 2).

    A point is inside iff it is on the left of, or on, every edge. The orientation determinant is evaluated in
    floats and, where its rounding error could flip its sign (points on an edge or within rounding of one), exactly
    in rationals: the answer is the exact one for the given floats, as GEOS's robust predicates (and so
    shapely's ``covers`` of :func:`footprint_polygons`) give it (a plain float test disagrees with them on edges).
    """
    c = np.asarray(corners, dtype=float)
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    a = c[:, None, :, :]  # (n, 1, 4, 2)
    b = np.roll(c, -1, axis=1)[:, None, :, :]
    q = p[None, :, None, :]  # (1, m, 1, 2)
    left = (a[..., 0] - q[..., 0]) * (b[..., 1] - q[..., 1])
    right = (a[..., 1] - q[..., 1]) * (b[..., 0] - q[..., 0])
    det = left - right  # (n, m, 4): > 0 left of edge a→b
    unsure = np.abs(det) <= _ORIENT_ERR * (np.abs(left) + np.abs(right))
    if unsure.any():
        det = det.copy()
        for i, j, k in zip(*np.nonzero(unsure), strict=True):
            ax, ay = map(Fraction, c[i, k])
            bx, by = map(Fraction, c[i, (k + 1) % 4])
            px, py = map(Fraction, p[j])
            exact = (ax - px) * (by - py) - (ay - py) * (bx - px)
            det[i, j, k] = (exact > 0) - (exact < 0)
    return np.all(det >= 0, axis=-1)


# --- identification cones --------------------------------------------------------------------------------------------


def draw_cones(rng: np.random.Generator, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-object cone angles ``β`` (m,) ~ U(−π/4, π/4) and ``γ`` (m,) ~ U(2π/60, 3π/60) (IB21 eqs. 51, 54)."""
    beta = rng.uniform(*BETA_RANGE, size=m)
    gamma = rng.uniform(*GAMMA_RANGE, size=m)
    return beta, gamma


def cone_axis(heading, beta, gamma) -> np.ndarray:
    """Unit axes (m, 3) ``a = (sin γ cos(x3 + β), sin γ sin(x3 + β), cos γ)`` of the objects' cones, turning with
    their heading x3 (IB21 eqs. 51, 54; the three trailing zeros of the 6-D print are dropped)."""
    az = np.asarray(heading, dtype=float) + np.asarray(beta, dtype=float)
    gamma = np.asarray(gamma, dtype=float)
    sg = np.sin(gamma)
    return np.stack(np.broadcast_arrays(sg * np.cos(az), sg * np.sin(az), np.cos(gamma)), axis=-1).reshape(-1, 3)


def cone_g(uav_xyz, obj_xyz, axis, half_aperture) -> np.ndarray:
    """(n, m) ``g = Δᵀa − ‖Δ‖‖a‖cos λ`` with ``Δ = p_uav − p_obj`` (IB21 eqs. 50, 52, 53 as printed): ``≥ 0`` iff the
    UAV is in the closed one-nappe cone of half-aperture ``λ`` (scalar or (m,)) with vertex at the object and axis
    ``axis`` (m, 3). ``uav_xyz`` (n, 3), ``obj_xyz`` (m, 3)."""
    dot, lengths = _cone_terms(uav_xyz, obj_xyz, axis)
    return dot - lengths * np.cos(half_aperture)


def _cone_terms(uav_xyz, obj_xyz, axis) -> tuple[np.ndarray, np.ndarray]:
    """``Δᵀa`` and ``‖Δ‖‖a‖`` (n, m) of :func:`cone_g`, which depend on no aperture (computed once for several)."""
    d = np.asarray(uav_xyz, dtype=float)[:, None, :] - np.asarray(obj_xyz, dtype=float)[None, :, :]
    a = np.asarray(axis, dtype=float)
    return np.einsum("nmk,mk->nm", d, a), np.linalg.norm(d, axis=-1) * np.linalg.norm(a, axis=-1)


def in_cone(uav_xyz, obj_xyz, axis, half_aperture) -> np.ndarray:
    """(n, m) bool ``g ≥ 0`` (:func:`cone_g`; IB21 eqs. 50, 52, 53): the UAV is inside the object's cone."""
    return cone_g(uav_xyz, obj_xyz, axis, half_aperture) >= 0


def confusion_map(n_decoys: int, n_targets: int, rng: np.random.Generator | None = None) -> np.ndarray:
    """J (n_decoys,): the true target each decoy is confused with (IB21 eq. 4; J is deterministic but not given).
    Ours: ``J(ℓ) = ℓ mod N_t`` (0-based; 3 decoys onto 3 targets one to one, 6 decoys two each), or a uniform draw
    from ``rng`` if one is given. With no true target a would-be confusion is reported as ``IDENTIFIED_FALSE``."""
    if n_targets == 0:
        return np.full(n_decoys, IDENTIFIED_FALSE, dtype=int)
    if rng is not None:
        return rng.integers(0, n_targets, size=n_decoys)
    return np.arange(n_decoys) % n_targets


def _indices(is_decoy: np.ndarray) -> np.ndarray:
    """Each object's index among its kind: j among the true targets, ℓ among the decoys, in object order."""
    idx = np.empty(len(is_decoy), dtype=int)
    idx[~is_decoy] = np.arange(np.count_nonzero(~is_decoy))
    idx[is_decoy] = np.arange(np.count_nonzero(is_decoy))
    return idx


def identify(uav_xyz, obj_xyz, axis, is_decoy, J=None, *, aperture_true: float = APERTURE_TRUE,
             aperture_decoy_identify: float = APERTURE_DECOY_IDENTIFY,
             aperture_decoy_reveal: float = APERTURE_DECOY_REVEAL,
             confusion: str = "outside_inner_cone") -> np.ndarray:
    """(n, m) int label UAV i would read on object j if it detected it (IB21 eqs. 3, 4 and the unnumbered rules of
    Sec. 3.2), regardless of the footprint.

    ``is_decoy`` (m,) bool; true targets are numbered 0..N_t−1 and decoys 0..N_f−1 in object order; ``J`` (N_f,) is
    the confusion map (default :func:`confusion_map`). Apertures are the paper's full angles 2λ. A true target j:
    j if ``g^t ≥ 0`` (eq. 50) else ``UNLABELLED``. A decoy ℓ: ``UNLABELLED`` if ``g^f < 0`` (eq. 52); else ``J(ℓ)``
    if ``q^f ≥ 0``, ``IDENTIFIED_FALSE`` if ``q^f < 0``, with ``q^f`` eq. 53 negated (``"outside_inner_cone"``, the
    text's and Fig. 3's reading, ours) or as printed (``"inside_inner_cone"``); module docstring.
    """
    if confusion not in CONFUSIONS:
        raise ValueError(f"confusion must be one of {CONFUSIONS}, not {confusion!r}")
    is_decoy = np.asarray(is_decoy, dtype=bool)
    idx = _indices(is_decoy)
    if J is None:
        J = confusion_map(int(is_decoy.sum()), int((~is_decoy).sum()))
    J = np.asarray(J, dtype=int)
    n, m = len(np.asarray(uav_xyz).reshape(-1, 3)), len(is_decoy)
    if m == 0:
        return np.zeros((n, 0), dtype=int)
    half_g = np.where(is_decoy, aperture_decoy_identify, aperture_true) / 2
    dot, lengths = _cone_terms(uav_xyz, obj_xyz, axis)  # cone_g's terms, once for both cones (the same numbers)
    g = dot - lengths * np.cos(half_g)  # eq. 50 for targets, eq. 52 for decoys
    g_inner = dot - lengths * np.cos(aperture_decoy_reveal / 2)  # eq. 53 as printed
    q = -g_inner if confusion == "outside_inner_cone" else g_inner
    confused_as = np.full(m, IDENTIFIED_FALSE)
    confused_as[is_decoy] = J
    label = np.where(is_decoy, np.where(q >= 0, confused_as, IDENTIFIED_FALSE), idx)
    return np.where(g >= 0, label, UNLABELLED)


# --- the sensor --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ObjectConstants:
    """What :func:`sense` needs of the sensed objects besides their poses: none of it changes during a run, so a
    sensor derives it once (:meth:`of`) rather than every frame. ``is_decoy`` (m,); ``beta`` (m,) the cone azimuth
    offsets and ``sin_gamma``, ``cos_gamma`` (m,) the sine and cosine of the cone tilts (eqs. 51, 54, as
    :func:`cone_axis` computes them); ``cos_g`` (m,) the cosine of each object's identification half-aperture (eq. 50
    for a target, eq. 52 for a decoy) and ``cos_inner`` the decoys' confusion one (eq. 53); ``idx`` (m,) each
    object's index among its kind and ``confused_as`` (m,) the target each decoy is confused with (``J``, eq. 4;
    ``IDENTIFIED_FALSE`` for targets); ``negate``: ``q^f`` is eq. 53 negated (``"outside_inner_cone"``). Of the sensor
    itself, which does not change either: ``tan_half`` (:attr:`FootprintParams.tan_half`) and the noise half-widths
    ``bound_x``, ``bound_y``. :attr:`cones` groups what the compiled pass reads of the cones."""

    is_decoy: np.ndarray
    beta: np.ndarray
    sin_gamma: np.ndarray
    cos_gamma: np.ndarray
    cos_g: np.ndarray
    cos_inner: float
    idx: np.ndarray
    confused_as: np.ndarray
    negate: bool
    tan_half: float
    bound_x: float
    bound_y: float

    @classmethod
    def of(cls, params: FootprintParams, is_decoy, beta, gamma, J=None) -> ObjectConstants:
        """The constants of objects of kinds ``is_decoy`` and cone angles ``beta``, ``gamma`` (m,) under ``params``,
        with the confusion map ``J`` (default :func:`confusion_map`); the same numbers :func:`identify` and
        :func:`cone_axis` compute."""
        if params.confusion not in CONFUSIONS:
            raise ValueError(f"confusion must be one of {CONFUSIONS}, not {params.confusion!r}")
        is_decoy = np.asarray(is_decoy, dtype=bool)
        if J is None:
            J = confusion_map(int(is_decoy.sum()), int((~is_decoy).sum()))
        confused_as = np.full(len(is_decoy), IDENTIFIED_FALSE)
        confused_as[is_decoy] = np.asarray(J, dtype=int)
        gamma = np.asarray(gamma, dtype=float)
        return cls(is_decoy, np.asarray(beta, dtype=float), np.sin(gamma), np.cos(gamma),
                   np.cos(np.where(is_decoy, params.aperture_decoy_identify, params.aperture_true) / 2),
                   float(np.cos(params.aperture_decoy_reveal / 2)), _indices(is_decoy), confused_as,
                   params.confusion == "outside_inner_cone", params.tan_half,
                   *np.asarray(params.noise_bound, dtype=float).tolist())

    @cached_property
    def cones(self) -> tuple:
        """The objects' cone constants as the compiled pass takes them (:func:`_sense_kernel`): ``(sin_gamma,
        cos_gamma, cos_g, cos_inner, is_decoy, idx, confused_as, negate)``, built once."""
        return (self.sin_gamma, self.cos_gamma, self.cos_g, self.cos_inner, self.is_decoy, self.idx, self.confused_as,
                self.negate)


def sense(uav_xyz, uav_heading, obj_xy, obj_heading, is_decoy, beta, gamma, noise_u,
          params: FootprintParams = FootprintParams(), J=None, stamped=None,
          compiled: bool = True) -> tuple[Detections, np.ndarray]:
    """One frame of the footprint sensor of every UAV (truth side; IB21 Sec. 3.2, Sec. 6, eqs. 3-8, 50-54).

    ``uav_xyz`` (n, 3) and ``uav_heading`` (n,) are the UAVs' true poses (they place the footprint and the cone
    tests), ``obj_xy`` (m, 2) and ``obj_heading`` (m,) the objects' (on the ground, z = 0), ``is_decoy`` (m,),
    ``beta`` and ``gamma`` (m,) their cone angles (:func:`draw_cones`), ``noise_u`` (n, m, 2) uniforms in [0, 1)
    for every (UAV, object) pair, in view or not (so the draws do not depend on the geometry), ``J`` the confusion
    map (default :func:`confusion_map`), ``stamped`` (n, 2) the positions the UAVs' navigation stamps on their
    detections (default their true ones).

    Every object in UAV i's closed footprint is detected, with ``z = p + w̄·(2u − 1)`` (uniform in ``±noise_bound``
    per axis) and the label of :func:`identify`. Returns the
    :class:`~swarmtrack.sensors.detections.Detections` (UAV-major, objects in order) and, for the world only, the
    object index each came from.

    A caller that senses the same objects every frame calls :func:`sense_frame` with their constants
    (:class:`ObjectConstants`, built once from ``is_decoy``, ``beta``, ``gamma``, ``params`` and ``J``) and, if it
    has them, the ``(cos, sin)`` of ``uav_heading``: the compiled pass then recomputes neither.
    """
    uav_xyz = np.asarray(uav_xyz, dtype=float).reshape(-1, 3)
    obj_xy = np.asarray(obj_xy, dtype=float).reshape(-1, 2)
    n, m = len(uav_xyz), len(obj_xy)
    noise_u = np.asarray(noise_u, dtype=float).reshape(n, m, 2)
    if compiled and m:
        return sense_frame(uav_xyz, uav_heading, obj_xy, obj_heading, noise_u, params,
                           ObjectConstants.of(params, is_decoy, beta, gamma, J), stamped)
    corners = footprint_corners(uav_xyz[:, :2], uav_heading, uav_xyz[:, 2], params.tan_half, params.orientation)
    seen = inside(corners, obj_xy)  # (n, m)
    obj_xyz = np.column_stack([obj_xy, np.zeros(m)])
    labels = identify(uav_xyz, obj_xyz, cone_axis(obj_heading, beta, gamma), is_decoy, J,
                      aperture_true=params.aperture_true, aperture_decoy_identify=params.aperture_decoy_identify,
                      aperture_decoy_reveal=params.aperture_decoy_reveal, confusion=params.confusion)
    owner, source, z, label = _detections(seen, labels, obj_xy, noise_u, np.asarray(params.noise_bound, dtype=float))
    pos = uav_xyz[:, :2] if stamped is None else np.asarray(stamped, dtype=float).reshape(n, 2)
    return Detections(owner, z, pos[owner], label, n, footprint=corners), source


def sense_frame(uav_xyz: np.ndarray, uav_heading, obj_xy: np.ndarray, obj_heading, noise_u: np.ndarray,
                params: FootprintParams, constants: ObjectConstants, stamped=None,
                uav_trig: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[Detections, np.ndarray]:
    """:func:`sense`'s compiled pass for a caller whose arrays are already what it converts them to (``uav_xyz``
    (n, 3), ``obj_xy`` (m, 2) with m > 0, ``noise_u`` (n, m, 2), all float) and that holds the objects' ``constants``
    (and may pass ``uav_trig``, the ``(cos, sin)`` of ``uav_heading``): the same detections and sources, without the
    conversions (the world's sensor, every frame)."""
    corners, owner, source, z, label = _frame_compiled(uav_xyz, uav_heading, obj_xy, obj_heading, noise_u, params,
                                                       constants, uav_trig)
    pos = uav_xyz[:, :2] if stamped is None else np.asarray(stamped, dtype=float).reshape(len(uav_xyz), 2)
    return Detections(owner, z, pos[owner], label, len(uav_xyz), footprint=corners), source


def _detections(seen, labels, obj_xy, noise_u, bound):
    """The detections of the (UAV, object) pairs ``seen`` (n, m), UAV-major: their ``owner``, ``source``, the
    measurement ``z = p + w̄·(2u − 1)`` (uniform in ``±bound`` per axis, IB21 eqs. 5-8) and the ``label``."""
    owner, source = np.nonzero(seen)
    z = obj_xy[source] + bound * (2.0 * noise_u[owner, source] - 1.0)
    return owner, source, z, labels[owner, source]


@numba.njit(cache=True)
def _detections_kernel(seen, labels, obj, noise, bound_x, bound_y):  # pragma: no cover (compiled)
    """:func:`_detections` (its reference; tested equal) in one pass, the same arithmetic in the same order."""
    n, m = seen.shape
    count = 0
    for i in range(n):
        for j in range(m):
            count += seen[i, j]
    owner = np.empty(count, dtype=np.int64)
    source = np.empty(count, dtype=np.int64)
    z = np.empty((count, 2))
    label = np.empty(count, dtype=np.int64)
    r = 0
    for i in range(n):
        for j in range(m):
            if seen[i, j]:
                owner[r], source[r], label[r] = i, j, labels[i, j]
                z[r, 0] = obj[j, 0] + bound_x * (2.0 * noise[i, j, 0] - 1.0)
                z[r, 1] = obj[j, 1] + bound_y * (2.0 * noise[i, j, 1] - 1.0)
                r += 1
    return owner, source, z, label


def _frame_compiled(uav_xyz, uav_heading, obj_xy, obj_heading, noise_u, params, constants: ObjectConstants,
                    uav_trig=None):
    """:func:`sense`'s footprints and detections ``(corners, owner, source, z, label)`` in one compiled call
    (:func:`_frame_kernel`: :func:`_sense_kernel` then :func:`_detections_kernel`, the numbers of
    :func:`_sense_compiled` and :func:`_detections`), unless a test is within rounding of a footprint edge: then
    :func:`_sense_compiled`'s exact decision and the detections gathered after it."""
    uav_trig = _uav_trig(uav_heading, len(uav_xyz), params.orientation, uav_trig)
    obj = np.ascontiguousarray(obj_xy)
    noise = np.ascontiguousarray(noise_u)
    c = constants
    az = np.asarray(obj_heading, dtype=float) + c.beta  # the cone axes' azimuths (eqs. 51, 54)
    done, corners, owner, source, z, label = _frame_kernel(
        (np.ascontiguousarray(uav_xyz), *uav_trig), c.tan_half, (obj, np.cos(az), np.sin(az)), c.cones, noise,
        c.bound_x, c.bound_y)
    if done:
        return corners, owner, source, z, label
    corners, seen, labels = _sense_compiled(uav_xyz, uav_heading, obj_xy, obj_heading, params, constants, uav_trig)
    return (corners, *_detections_kernel(seen, labels, obj, noise, c.bound_x, c.bound_y))


def _uav_trig(uav_heading, n: int, orientation: str, uav_trig=None) -> tuple[np.ndarray, np.ndarray]:
    """The ``(cos ψ, sin ψ)`` (n,) the footprints turn by: numpy's of the headings (or ``uav_trig``, the caller's),
    or of 0 for footprints along the axes."""
    if orientation == "heading":
        if uav_trig is None:
            psi = np.asarray(uav_heading, dtype=float) * np.ones(n)
            uav_trig = np.cos(psi), np.sin(psi)
        return uav_trig
    if orientation == "north":
        return np.ones(n), np.zeros(n)  # cos 0, sin 0
    raise ValueError(f"orientation must be one of {ORIENTATIONS}, not {orientation!r}")


@numba.njit(cache=True)
def _frame_kernel(uavs, tan_half, objects, cones, noise, bound_x, bound_y):  # pragma: no cover (compiled)
    """:func:`_sense_kernel` then, when no orientation test was within rounding of an edge, :func:`_detections_kernel`:
    ``(True, corners, owner, source, z, label)``; else ``(False, corners, …)`` with empty detections."""
    corners, seen, unsure, labels = _sense_kernel(uavs, tan_half, objects, cones)
    if unsure.any():
        none = np.empty(0, dtype=np.int64)
        return False, corners, none, none, np.empty((0, 2)), none
    owner, source, z, label = _detections_kernel(seen, labels, objects[0], noise, bound_x, bound_y)
    return True, corners, owner, source, z, label


def _sense_compiled(uav_xyz, uav_heading, obj_xy, obj_heading, params, constants: ObjectConstants, uav_trig=None):
    """:func:`sense`'s footprints, detections and labels in one compiled pass (:func:`_sense_kernel`) with the same
    arithmetic as :func:`footprint_corners`, :func:`inside`, :func:`cone_axis` and :func:`identify` (its readable
    reference; tested equal): the sines and cosines are numpy's, computed here (or given, ``uav_trig``) as those
    functions compute them, and the rare orientation tests within rounding of an edge are decided exactly by
    :func:`inside` itself."""
    uav_trig = _uav_trig(uav_heading, len(uav_xyz), params.orientation, uav_trig)
    c = constants
    az = np.asarray(obj_heading, dtype=float) + c.beta  # the cone axes' azimuths (eqs. 51, 54)
    corners, seen, unsure, labels = _sense_kernel((np.ascontiguousarray(uav_xyz), *uav_trig), params.tan_half,
                                                  (np.ascontiguousarray(obj_xy), np.cos(az), np.sin(az)), c.cones)
    if unsure.any():  # the footprints with a test within rounding of an edge: decided exactly, as the reference does
        rows = np.flatnonzero(unsure)
        seen[rows] = inside(corners[rows], obj_xy)
    return corners, seen, labels


@numba.njit(cache=True)
def _sense_kernel(uavs, tan_half, objects, cones):  # pragma: no cover (compiled)
    """The footprints ``corners`` (n, 4, 2), ``seen`` (n, m) by :func:`inside`'s float test, ``unsure`` (n,) the
    footprints with a test within rounding of an edge, and the ``labels`` (n, m) of :func:`identify`. ``uavs`` =
    ``(uav (n, 3), cos ψ, sin ψ)`` the UAVs' poses, ``objects`` = ``(obj (m, 2), cos az, sin az)`` the objects'
    positions and cone azimuths (eqs. 51, 54), ``cones`` = :attr:`ObjectConstants.cones`."""
    uav, cos_psi, sin_psi = uavs
    obj, cos_az, sin_az = objects
    sin_gamma, cos_gamma, cos_g, cos_inner, is_decoy, idx, confused_as, negate = cones
    n, m = len(uav), len(obj)
    signs = ((-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0))
    axis = np.empty((m, 3))  # cone_axis, and its norm as np.linalg.norm sums it
    axis_len = np.empty(m)
    for j in range(m):
        axis[j, 0] = sin_gamma[j] * cos_az[j]
        axis[j, 1] = sin_gamma[j] * sin_az[j]
        axis[j, 2] = cos_gamma[j]
        axis_len[j] = math.sqrt(axis[j, 0] * axis[j, 0] + axis[j, 1] * axis[j, 1] + axis[j, 2] * axis[j, 2])
    corners = np.empty((n, 4, 2))
    seen = np.empty((n, m), dtype=np.bool_)  # inside's float test: left of or on every edge
    unsure = np.zeros(n, dtype=np.bool_)  # footprints with an orientation test within rounding of an edge
    labels = np.empty((n, m), dtype=np.int64)
    for i in range(n):
        half = uav[i, 2] * tan_half  # footprint_corners' altitude·tan_half
        fx, fy = half * cos_psi[i], half * sin_psi[i]
        lx, ly = half * -sin_psi[i], half * cos_psi[i]
        for k in range(4):
            corners[i, k, 0] = uav[i, 0] + signs[k][0] * fx + signs[k][1] * lx
            corners[i, k, 1] = uav[i, 1] + signs[k][0] * fy + signs[k][1] * ly
        for j in range(m):
            qx, qy = obj[j, 0], obj[j, 1]
            seen[i, j] = True
            for k in range(4):
                ax, ay = corners[i, k, 0], corners[i, k, 1]
                bx, by = corners[i, (k + 1) % 4, 0], corners[i, (k + 1) % 4, 1]
                left = (ax - qx) * (by - qy)
                right = (ay - qy) * (bx - qx)
                d = left - right
                if not d >= 0:  # NaN too, as np.all(det >= 0)
                    seen[i, j] = False
                if abs(d) <= _ORIENT_ERR * (abs(left) + abs(right)):
                    unsure[i] = True
            d0, d1, d2 = uav[i, 0] - qx, uav[i, 1] - qy, uav[i, 2] - 0.0
            dot = 0.0 + d0 * axis[j, 0]
            dot = dot + d1 * axis[j, 1]
            dot = dot + d2 * axis[j, 2]
            length = math.sqrt(0.0 + d0 * d0 + d1 * d1 + d2 * d2) * axis_len[j]
            g = dot - length * cos_g[j]
            g_inner = dot - length * cos_inner
            q = -g_inner if negate else g_inner
            if g < 0:
                labels[i, j] = UNLABELLED
            elif is_decoy[j]:
                labels[i, j] = confused_as[j] if q >= 0 else IDENTIFIED_FALSE
            else:
                labels[i, j] = idx[j]
    return corners, seen, unsure, labels
