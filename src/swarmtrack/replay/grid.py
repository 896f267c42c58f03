"""Time-stamped log messages placed on the estimation grid, as a replay's :class:`StepInputs`.

Readers of time-stamped logs (bags, ULog, CSV) yield :class:`Navigation`, :class:`Detection` and :class:`Truth`
messages in the order the log holds them; :func:`on_grid` turns them into estimation steps:

- **Time.** A message's time is its own stamp (a ROS header's, a ULog sample's), not when it was logged; the
  replay's t = 0 is the earliest stamp of the first ``window`` seconds (or the map's ``start``), step k is at
  ``k·dt`` after it, and the replay ends with the log (the scenario's duration is not read).
- **Out of order, uneven rates.** Messages are held until the log has gone ``window`` seconds past them, so a
  message that comes after later-stamped ones (within the window) is placed at its own stamp. One stamped more than
  ``window`` before an earlier message **of its own topic** means the topic's clock went backwards: the replay stops
  naming the topic. One that comes more than ``window`` after the rest of the log (another topic's clock ran ahead)
  is skipped and counted as late.
- **Navigation** at step k (and where a detection was taken) is the UAV's navigation interpolated linearly between
  the samples around that time (held at the last sample for up to ``window`` s after it; none before the first);
  its velocity is the samples' finite difference where the message has none.
- **Detections** go to the nearest step of their stamp, taken from where the UAV's navigation put it at the stamp.
  A relative position ``(dx, dy)`` along the map frame's axes or a range and bearing becomes the scenario sensor's
  measurement (:data:`MEASUREMENTS`).
- **Truth** of the followed target at step k is interpolated the same way; NaN where the log holds none.

Memory holds the messages of about ``window`` seconds of log, whatever the log's size.
"""

from __future__ import annotations

import heapq
import math
from bisect import bisect_right, insort
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field

import numpy as np

from swarmtrack.replay.steps import LogError, StepInputs, layout
from swarmtrack.sensors.detections import Detections


@dataclass(frozen=True)
class Navigation:
    """UAV ``uav``'s (0-based) navigation solution stamped ``stamp`` (s): ``position`` ``(x, y)`` in the map frame
    (ENU), ``velocity`` ``(vx, vy)`` or None."""

    topic: str
    uav: int
    stamp: float
    position: tuple[float, float]
    velocity: tuple[float, float] | None = None


@dataclass(frozen=True)
class Detection:
    """UAV ``uav``'s detection of the target stamped ``stamp``: ``relative`` ``(dx, dy)`` (target minus UAV along
    the map frame's axes) or ``range_bearing`` ``(ρ, β)`` (β from the map's x axis, counter-clockwise)."""

    topic: str
    uav: int
    stamp: float
    relative: tuple[float, float] | None = None
    range_bearing: tuple[float, float] | None = None


@dataclass(frozen=True)
class Truth:
    """The followed target's ground truth stamped ``stamp``."""

    topic: str
    stamp: float
    position: tuple[float, float]
    velocity: tuple[float, float] | None = None


Message = Navigation | Detection | Truth


def _range_bearing(rel: np.ndarray, pos: np.ndarray) -> tuple[np.ndarray, None]:
    """L24 Sec. 3.2's ``z = [ρ, β]`` of relative positions (M, 2)."""
    return np.stack([np.hypot(rel[:, 0], rel[:, 1]), np.arctan2(rel[:, 1], rel[:, 0])], axis=1), None


def _camera(rel: np.ndarray, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """W20 eq. 4.16's affine measurement ``z = A p + b`` with ``A = I``, ``b = −p_uav``: the relative position
    itself, stamped with its frame ``[I | −p_uav]``."""
    frame = np.zeros((len(rel), 2, 3))
    frame[:, 0, 0] = frame[:, 1, 1] = 1.0
    frame[:, :, 2] = -pos
    return rel.copy(), frame


def _range_bearing_relative(det: Detections) -> np.ndarray:
    return det.z[:, :1] * np.stack([np.cos(det.z[:, 1]), np.sin(det.z[:, 1])], axis=1)


def _camera_relative(det: Detections) -> np.ndarray:
    """``p = A⁻¹ (z − b)`` (solved), less where the UAV was."""
    p = np.linalg.solve(det.frame[:, :, :2], (det.z - det.frame[:, :, 2])[..., None])[..., 0]
    return p - det.sensor_pos


#: Per sensor kind: how a relative position becomes its measurement ``(z, frame)`` given where the UAV was, and
#: back (its detections' target relative to the UAV along the map frame's axes, for ``swarmtrack export``).
MEASUREMENTS: dict[str, tuple[Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray | None]],
                              Callable[[Detections], np.ndarray]]] = {
    "range_bearing": (_range_bearing, _range_bearing_relative), "camera": (_camera, _camera_relative)}


def _stamp(sample: tuple) -> float:
    return sample[0]


@dataclass
class _Track:
    """A time-ordered buffer of one stream's (stamp, position, velocity) samples, for interpolation."""

    samples: list = field(default_factory=list)

    def add(self, stamp: float, position, velocity) -> None:
        insort(self.samples, (stamp, tuple(position), None if velocity is None else tuple(velocity)))

    def at(self, t: float, hold: float) -> tuple[float, float, float, float] | None:
        """``(x, y, vx, vy)`` at ``t``: interpolated between the samples around it, held for ``hold`` s after the
        last one, None before the first or when there are none; the velocity is the samples' finite difference where
        they carry none. (Plain floats: a replay interpolates every UAV's track at every step.)"""
        s = self.samples
        if not s or t < s[0][0]:
            return None
        i = bisect_right(s, t, key=_stamp) - 1  # the last sample at or before t
        t0, (x0, y0), v0 = s[i]
        if i + 1 < len(s):
            t1, (x1, y1), v1 = s[i + 1]
            w = (t - t0) / (t1 - t0) if t1 > t0 else 0.0
            x, y = (1 - w) * x0 + w * x1, (1 - w) * y0 + w * y1
            if v0 is not None and v1 is not None:
                return x, y, (1 - w) * v0[0] + w * v1[0], (1 - w) * v0[1] + w * v1[1]
            if t1 > t0:
                return x, y, (x1 - x0) / (t1 - t0), (y1 - y0) / (t1 - t0)
            return x, y, 0.0, 0.0
        if t - t0 > hold:
            return None
        if v0 is not None:
            return x0, y0, v0[0], v0[1]
        if i > 0 and t0 > s[i - 1][0]:
            tp, (xp, yp), _ = s[i - 1]
            return x0, y0, (x0 - xp) / (t0 - tp), (y0 - yp) / (t0 - tp)
        return x0, y0, 0.0, 0.0

    def forget(self, before: float) -> None:
        """Drop the samples not needed to interpolate at ``before`` or later."""
        s = self.samples
        keep = max(bisect_right(s, before, key=_stamp) - 1, 0)
        if keep > 1:
            del s[:keep - 1]


def on_grid(messages: Iterable[Message], scenario, counts: dict, window: float = 1.0,
            start: float | None = None) -> Iterator[StepInputs]:
    """The estimation steps of ``messages`` (see the module's docstring); ``counts`` gets what was skipped."""
    from swarmtrack.sim.build import build_component
    from swarmtrack.sim.world import sensed_objects

    kind = scenario.sensor.kind
    if kind not in MEASUREMENTS:
        raise LogError(f"sensor.kind {kind}: a replay from time-stamped logs makes {', '.join(MEASUREMENTS)} "
                       "measurements (replay a run folder for other sensors)")
    followed = scenario.estimator.followed_target()
    if followed is None:
        raise LogError(f"estimator.kind {scenario.estimator.kind} follows no single target: a replay from "
                       "time-stamped logs gives detections of one target")
    rows = layout(scenario)
    tracked = rows["targets"].start + followed - 1
    sensed = sensed_objects(rows, build_component("sensor", scenario, scenario).sensed)  # the world's label order
    if tracked not in sensed:
        raise LogError(f"sensor.kind {kind} does not see the followed target (estimator.target {followed})")
    grid = _Grid(scenario, counts, window, start, int(np.flatnonzero(sensed == tracked)[0]), MEASUREMENTS[kind][0],
                 tracked)
    for msg in messages:
        yield from grid.put(msg)
    yield from grid.finish()


def _finite(msg: Message) -> bool:
    """Every number of the message is finite (its stamp and its pairs)."""
    if not math.isfinite(msg.stamp):
        return False
    for name in ("position", "velocity", "relative", "range_bearing"):
        pair = getattr(msg, name, None)
        if pair is not None and not (math.isfinite(pair[0]) and math.isfinite(pair[1])):
            return False
    return True


class _Grid:
    def __init__(self, scenario, counts: dict, window: float, start: float | None, label: int, measure, tracked: int):
        self.n = scenario.swarm.n_uavs
        self.dt = 1.0 / scenario.rates.estimation
        self.rows = layout(scenario)
        self.m = sum(sl.stop - sl.start for sl in self.rows.values())
        self.counts, self.window, self.t0, self.label = counts, window, start, label
        self.measure, self.tracked = measure, tracked
        self.navs = [_Track() for _ in range(self.n)]
        self.truth = _Track()
        self.pending: list = []  # (stamp, order, Detection) heap
        self.latest: dict[str, float] = {}  # the latest stamp of each topic
        self.newest = -math.inf  # the latest stamp of the log so far
        self.early: list = []  # the messages of the first window (before t0 is known)
        self.first = math.inf  # their earliest stamp
        self.k = 0  # the next step to emit
        self._order = 0

    def _skip(self, why: str, n: int = 1) -> None:
        self.counts[why] = self.counts.get(why, 0) + n

    def put(self, msg: Message) -> Iterator[StepInputs]:
        if not _finite(msg):
            self._skip(f"NaN or infinite value in a message on {msg.topic}")
            return
        last = self.latest.get(msg.topic, -math.inf)
        if msg.stamp < last - self.window:
            raise LogError(f"{msg.topic}: time stamps go backwards (a message stamped {msg.stamp:.6f} s after one "
                           f"stamped {last:.6f} s, more than the replay window of {self.window:g} s)")
        self.latest[msg.topic] = max(last, msg.stamp)
        self.newest = max(self.newest, msg.stamp)
        if self.t0 is None:
            self.early.append(msg)
            self.first = min(self.first, msg.stamp)
            if self.newest - self.first < self.window:
                return
            self._start()
        else:
            self._place(msg)
        yield from self._emit(self.newest - self.window)

    def _place(self, msg: Message) -> None:
        t = msg.stamp - self.t0
        if t < -0.5 * self.dt:
            self._skip("stamped before the replay's start")
            return
        if t < (self.k - 0.5) * self.dt:  # its step was emitted: it came more than the window late
            self._skip("came later than the replay window")
            return
        if isinstance(msg, Navigation):
            self.navs[msg.uav].add(t, msg.position, msg.velocity)
        elif isinstance(msg, Truth):
            self.truth.add(t, msg.position, msg.velocity)
        else:
            heapq.heappush(self.pending, (t, self._order, msg))
            self._order += 1

    def _emit(self, upto: float) -> Iterator[StepInputs]:
        """Every step whose time (and whose detections' window) the log has gone past."""
        while (self.k + 0.5) * self.dt <= upto - self.t0 + 1e-9:  # stamps in ns: a step's end is not rounded away
            yield self._step()

    def _start(self) -> None:
        """t = 0 at the first window's earliest stamp; its messages placed."""
        self.t0, early, self.early = self.first, self.early, []
        for m in early:
            self._place(m)

    def finish(self) -> Iterator[StepInputs]:
        if self.t0 is None and self.early:
            self._start()
        if self.t0 is None:
            raise LogError("the logs hold no message of the map's topics")
        yield from self._emit(self.newest + 0.5 * self.dt)  # up to the step of the log's last stamp

    def _step(self) -> StepInputs:
        k, dt = self.k, self.dt
        t = k * dt
        nav = np.full((self.n, 4), np.nan)
        for i, track in enumerate(self.navs):
            got = track.at(t, self.window)
            if got is not None:
                nav[i] = got
        owners, rel, pos = [], [], []
        while self.pending and self.pending[0][0] < (k + 0.5) * dt:
            stamp, _, det = heapq.heappop(self.pending)
            where = self.navs[det.uav].at(stamp, self.window)
            if where is None:
                self._skip("detection with no navigation of its UAV at its time")
                continue
            if det.relative is not None:
                d = np.asarray(det.relative, dtype=float)
            else:
                r, b = det.range_bearing
                d = np.array([r * math.cos(b), r * math.sin(b)])
            owners.append(det.uav)
            rel.append(d)
            pos.append(where[:2])
        truth = np.full((self.m, 4), np.nan)
        got = self.truth.at(t, self.window)
        if got is not None:
            truth[self.tracked] = got
        uavs = self.rows["uavs"]
        truth[uavs] = nav
        for track in (*self.navs, self.truth):
            track.forget(t - self.window)
        self.k += 1
        phase = np.full(self.m, -1, dtype=np.int16)
        phase[self.tracked] = 0  # the one phase of a log (replay.engine.LOGGED)
        return StepInputs(k, t, nav, self._detections(owners, rel, pos), nav[:, :2].copy(), truth, phase)

    def _detections(self, owners: list, rel: list, pos: list) -> Detections:
        owner = np.asarray(owners, dtype=np.int64)
        order = np.argsort(owner, kind="stable")  # one per UAV and label: the latest of a UAV's wins below
        owner = owner[order]
        rel = np.asarray(rel, dtype=float).reshape(-1, 2)[order]
        pos = np.asarray(pos, dtype=float).reshape(-1, 2)[order]
        last = np.ones(len(owner), dtype=bool)
        last[:-1] = owner[1:] != owner[:-1]
        if not last.all():
            self._skip("a second detection of the target by one UAV in one estimation step", int((~last).sum()))
            owner, rel, pos = owner[last], rel[last], pos[last]
        z, frame = self.measure(rel, pos)
        return Detections(owner, z, pos, np.full(len(owner), self.label, dtype=np.int64), self.n, frame=frame)
