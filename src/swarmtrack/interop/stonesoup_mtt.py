"""Stone Soup's multi-target trackers on plain detections, as live references for the "many targets in clutter"
study (``pip install swarmtrack[stonesoup]``).

Both trackers take the same input as swarmtrack's multi-target estimator, as plain numpy: ``scans[k][s]`` is an
``(M, 2)`` array of the world-frame positions sensor ``s`` detected at step ``k`` (time ``k * dt``), targets'
detections and clutter mixed and unlabelled. Their model is the scenario's:

- targets move at constant velocity, Stone Soup's ``ConstantVelocity`` per axis with ``q = accel_std²`` (continuous
  white-noise acceleration), the state ``[x, vx, y, vy]`` (Stone Soup's order; estimates are returned in swarmtrack's
  ``[x, y, vx, vy]``);
- every sensor measures position, ``LinearGaussian(mapping=(0, 2))`` with noise ``sigma`` (m) on each axis, detects
  a target with probability ``pd``;
- clutter: Poisson ``clutter_rate`` false detections per scan per sensor, uniform over ``bounds = (x0, y0, x1, y1)``
  (density ``clutter_rate / area``).

:func:`gmphd` is Stone Soup's GM-PHD filter (Vo and Ma 2006) over every sensor: the components of Stone Soup's GM-PHD
tutorial (``GaussianMixtureHypothesiser`` over a ``DistanceHypothesiser``, ``PHDUpdater``, ``GaussianMixtureReducer``)
driven step by step, one PHD update per sensor (the iterated corrector). :func:`jpda` is Stone Soup's JPDA tracker
(``PDAHypothesiser``, a JPDA associator, ``MultiTargetMixtureTracker``, ``MultiMeasurementInitiator``) on the first
sensor only. Both return :class:`Tracked`: the estimates per step and the wall time per step.

Stone Soup is imported inside the functions, so this module imports without it; calling either without it raises an
``ImportError`` naming the ``stonesoup`` extra.
"""

from __future__ import annotations

import datetime
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Birth", "Tracked", "gmphd", "jpda"]

#: Stone Soup's ``[x, vx, y, vy]`` → swarmtrack's ``[x, y, vx, vy]`` (the permutation is its own inverse).
TO_SWARMTRACK = np.array([0, 2, 1, 3])
#: The epoch of step 0 (Stone Soup's states need datetimes; only differences matter).
EPOCH = datetime.datetime(2000, 1, 1)


@dataclass(frozen=True)
class Tracked:
    """A tracker's output: ``estimates[k]`` the ``(n_k, 4)`` target estimates ``[x, y, vx, vy]`` at step ``k``
    (swarmtrack's order), and ``seconds_per_step`` the mean wall time of one step's tracking (Stone Soup's work on
    the step's detections, not the conversion of the input to Stone Soup detections)."""

    estimates: list[np.ndarray]
    seconds_per_step: float


@dataclass(frozen=True)
class Birth:
    """The GM-PHD's birth intensity: ONE Gaussian component added before each step's first update, its mean the
    centre of ``bounds`` at rest, its position standard deviation ``position_scale`` times the box's side on each
    axis (the default, 1, makes it nearly flat over the box, at its corners still 0.78 of its peak), its velocity
    standard deviation ``velocity_std`` (m/s) and its ``weight`` the expected number of targets born per step (the
    PHD's mass of new targets). A detection of the step's first sensor far from every known target makes a component
    of weight about ``pd * weight * 0.16 / clutter_rate`` (pruned at once below 1e-5: ``weight`` must exceed about
    ``6e-5 * clutter_rate / pd``, more away from the centre); the other sensors' detections of a real target raise
    it towards 1, clutter's fade by ``1 − pd`` per sensor."""

    weight: float = 0.1
    velocity_std: float = 5.0
    position_scale: float = 1.0


def _stonesoup():
    """Stone Soup, or an ``ImportError`` naming the extra that installs it."""
    try:
        import stonesoup
    except ImportError as exc:
        raise ImportError("swarmtrack.interop.stonesoup_mtt needs Stone Soup: pip install 'swarmtrack[stonesoup]' "
                          "(the extra 'stonesoup')") from exc
    return stonesoup


def _check(dt: float, accel_std: float, sigma: float, pd: float, clutter_rate: float,
           bounds: Sequence[float]) -> tuple[float, float, float, float]:
    """The model's parameters checked; the box as ``(x0, y0, x1, y1)`` floats."""
    box = tuple(float(b) for b in bounds)
    if len(box) != 4 or not np.isfinite(box).all() or not (box[2] > box[0] and box[3] > box[1]):
        raise ValueError(f"bounds must be (x0, y0, x1, y1) with x1 > x0 and y1 > y0; got {bounds!r}")
    for name, value in (("dt", dt), ("sigma", sigma), ("clutter_rate", clutter_rate)):
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be positive and finite (a clutter-free scene: a small clutter_rate such "
                             f"as 1e-3); got {value!r}")
    if not (np.isfinite(accel_std) and accel_std >= 0):
        raise ValueError(f"accel_std must be non-negative and finite; got {accel_std!r}")
    if not 0 < pd <= 1:
        raise ValueError(f"pd must be in (0, 1]; got {pd!r}")
    return box[0], box[1], box[2], box[3]


def _scan(points) -> np.ndarray:
    """One sensor's detections as ``(M, 2)`` floats (an empty scan may be any empty array)."""
    a = np.asarray(points, dtype=float)
    if a.size == 0:
        return np.zeros((0, 2))
    if a.ndim != 2 or a.shape[1] != 2 or not np.isfinite(a).all():
        raise ValueError(f"a scan must be an (M, 2) array of finite positions; got shape {a.shape}")
    return a


def _models(dt, accel_std, sigma):
    """Stone Soup's transition model (CV per axis, ``q = accel_std²``) and the sensors' position measurement."""
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity

    q = float(accel_std) ** 2
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(q), ConstantVelocity(q)])
    measurement = LinearGaussian(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2) * float(sigma) ** 2)
    return transition, measurement


def _detections(scans, dt, measurement) -> tuple[list[datetime.datetime], list[list[set]]]:
    """The scans as Stone Soup ``Detection`` sets: per step its timestamp and per sensor a set."""
    from stonesoup.types.detection import Detection

    stamps, steps = [], []
    for k, sensors in enumerate(scans):
        stamp = EPOCH + datetime.timedelta(seconds=k * float(dt))
        stamps.append(stamp)
        steps.append([{Detection(z.reshape(2, 1), timestamp=stamp, measurement_model=measurement)
                       for z in _scan(points)} for points in sensors])
    return stamps, steps


def _estimates(states) -> np.ndarray:
    """Stone Soup states' means ``[x, vx, y, vy]`` as ``(n, 4)`` rows ``[x, y, vx, vy]``, sorted (by x, then y …:
    a set's order does not depend on Python's hashes)."""
    if not states:
        return np.zeros((0, 4))
    rows = np.array([np.asarray(s.state_vector, dtype=float).reshape(-1)[TO_SWARMTRACK] for s in states])
    return rows[np.lexsort(rows.T[::-1])]


# --- GM-PHD -----------------------------------------------------------------------------------------------------


def _predicted(predictor, component, stamp, survival: float):
    """A GM-PHD component predicted to ``stamp`` with its weight times ``survival`` (a step without sensors)."""
    from stonesoup.types.state import TaggedWeightedGaussianState

    p = predictor.predict(component, timestamp=stamp)
    return TaggedWeightedGaussianState(p.state_vector, p.covar, weight=component.weight * survival,
                                       tag=component.tag, timestamp=stamp)


def gmphd(scans: Sequence[Sequence[np.ndarray]], dt: float, accel_std: float, sigma: float, pd: float,
          clutter_rate: float, bounds: Sequence[float], birth: Birth = Birth(), survival: float = 0.99,
          extraction: float = 0.5) -> Tracked:
    """Stone Soup's GM-PHD filter on every sensor's detections (module docstring for the model).

    The components are those of Stone Soup's GM-PHD tutorial, driven directly rather than through
    ``PointProcessMultiTargetTracker`` (which adds its birth component and applies survival at every update, so it
    cannot take several sensors' scans of one time):

    - ``KalmanPredictor``/``KalmanUpdater`` for each component (linear Gaussian models: the GM-PHD's closed form);
    - ``GaussianMixtureHypothesiser`` (``order_by_detection=True``, as ``PHDUpdater`` wants) over a
      ``DistanceHypothesiser`` gating each component-detection pair at Mahalanobis distance 3;
    - ``PHDUpdater`` with ``prob_detection = pd`` and ``clutter_spatial_density = clutter_rate / area``: the
      iterated-corrector multi-sensor PHD, one update per sensor in turn at the step's timestamp (the later sensors'
      predictions are over zero time, the identity). Survival (``survival``) is applied once a step, by the first
      sensor's updater; the others' have ``prob_survival = 1``;
    - ``GaussianMixtureReducer`` after every update: pruning below 1e-5, merging within squared Mahalanobis
      distance 4, at most 100 components (Vo and Ma's settings);
    - birth: :class:`Birth`, one wide ``TaggedWeightedGaussianState`` (tag ``BIRTH``) over the box's centre,
      added before each step's first update (so one birth a step, whatever the number of sensors). A step with
      no sensors at all (``scans[k] == []``) is the prediction alone; a sensor with no detections is an update.

    Extraction after the step's last update: every component of weight above ``extraction`` (0.5), repeated
    ``round(weight)`` times (at least once), as Vo and Ma extract. ``estimates[k]`` are their means,
    ``[x, y, vx, vy]``. A property of the iterated corrector so extracted: a target the LAST sensor misses has its
    weight cut to ``1 − pd`` of it and is not extracted that step (about ``1 − pd`` of the targets a step; the
    earlier sensors' misses are made good by the later sensors' detections)."""
    _stonesoup()
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.hypothesiser.gaussianmixture import GaussianMixtureHypothesiser
    from stonesoup.measures import Mahalanobis
    from stonesoup.mixturereducer.gaussianmixture import GaussianMixtureReducer
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.types.state import TaggedWeightedGaussianState
    from stonesoup.updater.kalman import KalmanUpdater
    from stonesoup.updater.pointprocess import PHDUpdater

    x0, y0, x1, y1 = _check(dt, accel_std, sigma, pd, clutter_rate, bounds)
    if not (birth.weight > 0 and birth.velocity_std > 0 and birth.position_scale > 0):
        raise ValueError(f"the birth's weight, velocity_std and position_scale must be positive; got {birth}")
    if not 0 < survival <= 1:
        raise ValueError(f"survival must be in (0, 1]; got {survival!r}")
    transition, measurement = _models(dt, accel_std, sigma)
    stamps, steps = _detections(scans, dt, measurement)

    density = clutter_rate / ((x1 - x0) * (y1 - y0))
    kalman = KalmanUpdater(measurement)
    predictor = KalmanPredictor(transition)
    hypothesiser = GaussianMixtureHypothesiser(
        DistanceHypothesiser(predictor, kalman, Mahalanobis(), missed_distance=3),
        order_by_detection=True)
    first = PHDUpdater(kalman, clutter_spatial_density=density, prob_detection=pd, prob_survival=survival)
    others = PHDUpdater(kalman, clutter_spatial_density=density, prob_detection=pd, prob_survival=1)
    reducer = GaussianMixtureReducer(prune_threshold=1e-5, merge_threshold=4, max_number_components=100)
    sx, sy = birth.position_scale * (x1 - x0), birth.position_scale * (y1 - y0)
    birth_mean = [(x0 + x1) / 2, 0.0, (y0 + y1) / 2, 0.0]
    birth_covar = np.diag([sx**2, birth.velocity_std**2, sy**2, birth.velocity_std**2])

    components: list = []
    estimates, elapsed = [], 0.0
    for stamp, sensors in zip(stamps, steps, strict=True):
        start = time.perf_counter()
        if sensors:
            components = [*components, TaggedWeightedGaussianState(
                birth_mean, birth_covar, weight=birth.weight, tag=TaggedWeightedGaussianState.BIRTH, timestamp=stamp)]
        else:  # no sensor reported: the prediction alone (survival applied once), nothing born
            components = [_predicted(predictor, c, stamp, survival) for c in components]
        for s, detections in enumerate(sensors):
            hypotheses = hypothesiser.hypothesise(components, detections, timestamp=stamp)
            mixture = (first if s == 0 else others).update(hypotheses)
            components = list(reducer.reduce(list(mixture.components)))
        kept = [c for c in components if float(c.weight) > extraction for _ in range(max(1, round(float(c.weight))))]
        elapsed += time.perf_counter() - start
        estimates.append(_estimates(kept))
    return Tracked(estimates, elapsed / max(len(stamps), 1))


# --- JPDA -------------------------------------------------------------------------------------------------------


def jpda(scans: Sequence[Sequence[np.ndarray]], dt: float, accel_std: float, sigma: float, pd: float,
         clutter_rate: float, bounds: Sequence[float], velocity_std: float = 5.0, min_points: int = 3,
         max_misses: int = 3, exhaustive: bool = False) -> Tracked:
    """Stone Soup's JPDA tracker on the FIRST sensor's detections (module docstring for the model).

    The composition of Stone Soup's JPDA and initiator/deleter tutorials, run by its ``MultiTargetMixtureTracker``
    (each track's posterior the ``gm_reduce_single`` of its association mixture; detections a track explains better
    than a miss are not offered to the initiator):

    - ``KalmanPredictor``/``KalmanUpdater`` (linear Gaussian models);
    - ``PDAHypothesiser`` with ``prob_detect = pd`` and ``clutter_spatial_density = clutter_rate / area`` (its
      default gate probability 0.95);
    - the associator: ``JPDAwithEHM2`` by default, Stone Soup's JPDA whose exact marginal association probabilities
      are computed on independent clusters of tracks by efficient hypothesis management (Horridge and Maskell 2006);
      ``exhaustive=True`` takes the tutorial's ``JPDA``, which enumerates every joint hypothesis of ALL tracks at
      once (the same probabilities, exponential in the number of tracks: for small scenes only);
    - ``MultiMeasurementInitiator``: a tentative track per unexplained detection (``prior_state`` at rest, velocity
      standard deviation ``velocity_std``), associated by ``GNNWith2DAssignment`` over a ``DistanceHypothesiser``
      (Mahalanobis distance 3), confirmed after ``min_points`` updates and dropped at its first miss
      (``UpdateTimeStepsDeleter(1)``);
    - ``UpdateTimeStepsDeleter(max_misses)``: a confirmed track is deleted after ``max_misses`` steps without a
      detection it explains better than a miss.

    ``estimates[k]`` are the confirmed tracks' states at step ``k``, ``[x, y, vx, vy]``. A step without sensors
    (``scans[k] == []``) is fed as the first sensor's scan with no detections."""
    _stonesoup()
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.dataassociator.probability import JPDA, JPDAwithEHM2
    from stonesoup.deleter.time import UpdateTimeStepsDeleter
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.initiator.simple import MultiMeasurementInitiator
    from stonesoup.measures import Mahalanobis
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.tracker.simple import MultiTargetMixtureTracker
    from stonesoup.types.state import GaussianState
    from stonesoup.updater.kalman import KalmanUpdater

    x0, y0, x1, y1 = _check(dt, accel_std, sigma, pd, clutter_rate, bounds)
    if not (np.isfinite(velocity_std) and velocity_std > 0):
        raise ValueError(f"velocity_std must be positive and finite; got {velocity_std!r}")
    if int(min_points) != min_points or min_points < 1 or int(max_misses) != max_misses or max_misses < 1:
        raise ValueError(f"min_points and max_misses must be positive integers; got {min_points!r}, {max_misses!r}")
    transition, measurement = _models(dt, accel_std, sigma)
    first_sensor = [sensors[:1] for sensors in scans]
    stamps, steps = _detections(first_sensor, dt, measurement)

    predictor, updater = KalmanPredictor(transition), KalmanUpdater(measurement)
    hypothesiser = PDAHypothesiser(predictor=predictor, updater=updater,
                                   clutter_spatial_density=clutter_rate / ((x1 - x0) * (y1 - y0)), prob_detect=pd)
    initiator = MultiMeasurementInitiator(
        prior_state=GaussianState([0, 0, 0, 0], np.diag([0, velocity_std**2, 0, velocity_std**2])),
        measurement_model=measurement, deleter=UpdateTimeStepsDeleter(1),
        data_associator=GNNWith2DAssignment(
            DistanceHypothesiser(predictor, updater, Mahalanobis(), missed_distance=3)),
        updater=updater, min_points=int(min_points))
    feed = ((stamp, sensors[0] if sensors else set()) for stamp, sensors in zip(stamps, steps, strict=True))
    tracker = MultiTargetMixtureTracker(
        initiator=initiator, deleter=UpdateTimeStepsDeleter(int(max_misses)), detector=feed,
        data_associator=(JPDA if exhaustive else JPDAwithEHM2)(hypothesiser=hypothesiser), updater=updater)

    estimates, elapsed = [], 0.0
    steps_iter = iter(tracker)
    for _ in stamps:
        start = time.perf_counter()
        _, tracks = next(steps_iter)
        elapsed += time.perf_counter() - start
        estimates.append(_estimates([track.state for track in tracks]))
    return Tracked(estimates, elapsed / max(len(stamps), 1))
