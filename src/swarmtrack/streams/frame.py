"""One step of a run as the live outputs see it (ROS 2 topics, the Foxglove view): a :class:`StepFrame`, made from
what the recorder records (:func:`frame_of`) or from a finished recording (:func:`frames`).

Every driver records through :class:`~swarmtrack.sim.recorder.Recorder`; a :class:`Tap` given to it sees each step
as it is recorded, after the recorder has copied it, and never changes what is recorded. The field agent, which
records nothing, hands its own row to the same taps (``uavs``: its own 1-based number).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import numpy as np

if TYPE_CHECKING:
    from swarmtrack.sim.recorder import Recording


@dataclass(frozen=True)
class StepFrame:
    """Step ``t`` (s, the run's time) of UAVs ``uavs`` (1-based, (N,)):

    - ``uav`` (N, 4) each UAV's ``[x, y, vx, vy]`` (truth in the simulator, its navigation elsewhere; NaN unknown)
      and ``uav_altitude`` (N,) in a 3-D world, else None;
    - ``estimate`` (N, n) and ``covariance`` (N, n, n): each UAV's estimate of the followed target, its state in
      the estimator's order (``[x, y, vx, vy, ...]``), None for an estimator without one (IB21's sets);
    - ``present`` (N,) bool: whose sample came (an absent UAV's numbers are NaN);
    - ``target`` (4,) the followed target's truth ``[x, y, vx, vy]`` when known, else None;
    - ``command`` (N, w) each UAV's command when the driver knows it (the field agent), else None;
    - ``polygons``: ``[(uav, vertices (K, 2))]`` regions to draw (IB21's sets; ``uav`` 0 for the swarm's);
      ``formation`` (N, 2): where each UAV is meant to be (W20's formation), else None;
    - ``plots``: per-UAV series to plot, ``name → (N,)`` (``error``: the estimate's position error, m;
      ``nees``: its NEES of ``[x, y, vx, vy]``; drivers add theirs, e.g. ``latency_ms``)."""

    t: float
    uavs: np.ndarray
    uav: np.ndarray
    present: np.ndarray
    estimate: np.ndarray | None = None
    covariance: np.ndarray | None = None
    target: np.ndarray | None = None
    uav_altitude: np.ndarray | None = None
    command: np.ndarray | None = None
    polygons: list[tuple[int, np.ndarray]] = field(default_factory=list)
    formation: np.ndarray | None = None
    plots: dict[str, np.ndarray] = field(default_factory=dict)


#: Per-UAV recorded columns a frame plots as they are (beside the errors it computes): the NIS of a filter, and what
#: a field monitor records of each UAV's step (its lateness in periods, the median latency of what it heard, ms).
PLOTTED = ("nis", "lateness", "latency_ms")


class Tap(Protocol):
    """A live output: :meth:`open` once with the recording's meta, :meth:`send` each step, :meth:`close` at the
    end (idempotent; after a Ctrl-C too)."""

    def open(self, meta: dict) -> None: ...

    def send(self, frame: StepFrame) -> None: ...

    def close(self) -> None: ...


def shapes_of(kind: str, estimator) -> Callable[[], list] | None:
    """What a live view draws of ``estimator`` (of estimator kind ``kind``) each step, as a call (its registered
    ``shapes``: IB21's sets; imported at the first call, a run without a view never loads it), or None when its kind
    draws nothing."""
    from swarmtrack import registry

    ref = registry.get("estimator", kind).shapes
    if ref is None or estimator is None:
        return None
    return lambda: registry.resolve(ref)(estimator)


def errors(estimate: np.ndarray | None, covariance: np.ndarray | None,
           target: np.ndarray | None) -> dict[str, np.ndarray]:
    """``error`` (N,) the estimates' position error (m) and ``nees`` (N,) their NEES of ``[x, y, vx, vy]``
    (:func:`~swarmtrack.analysis.nees.nees_per_uav`, as the run's metrics compute it); empty
    without an estimate or a target."""
    if estimate is None or covariance is None or target is None or not np.all(np.isfinite(target[:4])):
        return {}
    from swarmtrack.analysis.nees import nees_per_uav

    e = estimate[:, :4] - target[None, :4]
    try:  # the metrics' own NEES (a NaN gives NaN)
        nees = nees_per_uav(e, covariance[:, :4, :4])
    except np.linalg.LinAlgError:  # a singular covariance: not defined
        nees = np.full(len(e), np.nan)
    return {"error": np.hypot(e[:, 0], e[:, 1]), "nees": nees}


def frame_of(meta: dict, t: float, truth: np.ndarray, probes: dict[str, np.ndarray],
             present: np.ndarray | None = None, uavs: np.ndarray | None = None) -> StepFrame:
    """The frame of one recorded step: ``meta`` the recording's, ``truth`` (M, 4 or 6) every object's, ``probes``
    ``name → (N, ...)``, ``present`` (N,) (None: all came); ``uavs`` the UAVs' 1-based numbers (default 1..N). A
    formation controller's ``setpoint`` probe (W20 Ch. 5: where each UAV is meant to be) is the frame's
    ``formation``."""
    start, stop = meta["groups"]["uavs"]
    n = stop - start
    truth = np.asarray(truth, dtype=float)
    tracked = meta.get("tracked")
    target = None if tracked is None else truth[tracked, :4].copy()
    estimate, covariance, setpoint = probes.get("estimate"), probes.get("covariance"), probes.get("setpoint")
    return StepFrame(t=float(t), uavs=np.arange(1, n + 1) if uavs is None else np.asarray(uavs),
                     uav=truth[start:stop, :4].copy(),
                     present=np.ones(n, dtype=bool) if present is None else np.asarray(present, dtype=bool),
                     estimate=None if estimate is None else np.asarray(estimate, dtype=float),
                     covariance=None if covariance is None else np.asarray(covariance, dtype=float),
                     target=target, uav_altitude=truth[start:stop, 4] if truth.shape[1] > 4 else None,
                     formation=None if setpoint is None else np.asarray(setpoint, dtype=float),
                     plots={**errors(estimate, covariance, target),
                            **{name: np.asarray(probes[name], dtype=float) for name in PLOTTED if name in probes}})


def frames(recording: Recording) -> Iterator[StepFrame]:
    """Every step of a finished recording as a frame (what its taps were sent while it ran)."""
    for chunk in recording.chunks():
        for j, t in enumerate(chunk.t):
            truth = chunk.truth[j] if chunk.altitude is None else np.concatenate([chunk.truth[j],
                                                                                  chunk.altitude[j]], axis=1)
            yield frame_of(recording.meta, t, truth, {name: v[j] for name, v in chunk.probes.items()},
                           None if chunk.present is None else chunk.present[j])
