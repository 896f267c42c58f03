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
  measurement (its registration's :class:`~swarmtrack.registry.Measurement`).
- **Truth** of the followed target at step k is interpolated between the two truth samples around it when they
  are at most ``truth_gap`` (:data:`TRUTH_GAP`) apart, and NaN (absent) elsewhere: before the first sample, after
  the last, across a longer gap. A step waits (its inputs computed, not yet handed on) until the sample after it
  has come or can no longer come within ``truth_gap``, so a sparse truth topic gives truth at every step between
  its samples whatever the ``window``.
- **Gaps and length.** :func:`plan` reads the messages' stamps once before the replay: t = 0, the number of steps
  (shown with the progress), and a gap in the logs longer than ``max_gap`` (:data:`MAX_GAP`) refused naming its
  times and the message after it (a row stamped 1e9 s would otherwise be 10¹⁰ steps).
- **Skipped messages** are counted by cause (:func:`skip`); each cause says what the user can do (:data:`SKIPS`).

Memory holds the messages of about ``window`` seconds of log (``truth_gap`` seconds of steps while a truth sample
is awaited), whatever the log's size, and 8 bytes per message's stamp for :func:`plan`.
"""

from __future__ import annotations

import heapq
import math
from array import array
from bisect import bisect_right, insort
from collections import deque
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field

import numpy as np

from swarmtrack import registry
from swarmtrack.onboard.context import layout, sensor_labels
from swarmtrack.replay.steps import LogError, StepInputs
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

    def offset(self) -> np.ndarray:
        """``(dx, dy)`` of the target from the UAV along the map frame's axes, from whichever the message carries."""
        if self.relative is not None:
            return np.asarray(self.relative, dtype=float)
        assert self.range_bearing is not None, "a detection carries a relative position or a range and bearing"
        r, b = self.range_bearing
        return np.array([r * math.cos(b), r * math.sin(b)])


@dataclass(frozen=True)
class Truth:
    """The followed target's ground truth stamped ``stamp``."""

    topic: str
    stamp: float
    position: tuple[float, float]
    velocity: tuple[float, float] | None = None


Message = Navigation | Detection | Truth

#: The map's ``window`` by default (s): how long a message may come after later-stamped ones and still be placed.
WINDOW = 1.0
#: The map's ``truth_gap`` by default (s): truth is interpolated between two samples at most this far apart (a
#: 0.5 Hz truth topic); across a longer gap it is absent (NaN), not a straight line through a turn.
TRUTH_GAP = 2.0
#: A step this close (s) after a truth sample is on it (stamps in ns, steps at k·dt: the last step of a log lands
#: on its last sample to rounding).
ON_SAMPLE = 1e-6
#: The map's ``max_gap`` by default (s): a longer stretch of the logs without any message is refused (a wrong
#: stamp, or two flights in one log), never stepped through.
MAX_GAP = 60.0

#: Why a message can be skipped mid-log (the start of its count's key, :func:`skip`) → what the user can do.
SKIPS = {
    "NaN or infinite value in a message": "the message is left out; if the value should be there, fix the log (in "
                                          "a CSV an empty or nan cell)",
    "stamped before the replay's start": "the replay starts at the earliest stamp of the logs' first window: a log "
                                         "on another clock? align a ULog with the map's uavs.N.time_offset, or "
                                         "raise the map's window",
    "came later than the replay window": "raise the map's window (s, default 1) to wait longer for late messages, "
                                         "or sort the log by time stamp (a CSV is sorted when read)",
    "detection with no navigation of its UAV at its time": "its UAV's navigation starts after it or pauses longer "
                                                           "than the map's window: log navigation from before the "
                                                           "first detection, or raise the map's window",
    "a second detection of the target by one UAV in one estimation step": "the latest one is used; to use them "
                                                                          "all, raise the scenario's "
                                                                          "rates.estimation (it must divide "
                                                                          "rates.physics)",
    "covariance not positive definite": "the message's x-y covariance is not a covariance (an all-zero one is read "
                                        "as not given): fix the logger, or map a topic without one",
    "stamped before an earlier message of its topic": "the field: its sender's clock went backwards (a restarted "
                                                      "sensor, a clock stepped by NTP): fix the sender's clock "
                                                      "synchronisation (docs/field.md, \"Clocks\")",
    "stamped more than the window before its step": "the field: it came too late to be fused (a slow link, or the "
                                                    "sender's clock behind this UAV's): check NTP/PTP, or raise the "
                                                    "map's window",
    "a frame that came after its step, superseded by the next": "the field: the sensor's detection came after the "
                                                                  "step it was taken for (a busy machine or a slow "
                                                                  "link), beside the next one; the latest is used: "
                                                                  "fix the load, or raise the scenario's "
                                                                  "rates.estimation",
    "message of another type than its source names": "the field: the source's samples say they are of another type: "
                                                     "name the type its publisher sends (?type=)",
    "message that does not decode as its type": "the field: the bytes are not CDR of the source's type: name the type "
                                                "its publisher sends (?type=)",
    "a damaged stretch of": "pyulog skipped it; copy the log from the vehicle again if you can",
    "xy_valid false": "PX4 had no valid horizontal position then (EKF converging, GPS lost): nothing to do, or map "
                      "another message in uavs.N.navigation",
    "pose_frame not NED": "name a message in NED in uavs.N.navigation (e.g. vehicle_local_position)",
    "local_frame not NED": "name a message in NED in uavs.N.navigation (e.g. vehicle_local_position)",
    "navigation rows in": "that UAV's navigation is its ULog's (the map's uavs.N.log): drop log: from the map to "
                          "use the CSV's rows instead",
}


def skip(counts: dict, cause: str, where: str = "", n: int = 1) -> None:
    """Count ``n`` messages skipped for ``cause`` (a key of :data:`SKIPS`) under the key ``cause + where`` (``where``:
    " on TOPIC", the file …)."""
    if cause not in SKIPS:
        raise KeyError(f"replay: skip cause {cause!r} has no remedy in replay.grid.SKIPS")
    key = cause + where
    counts[key] = counts.get(key, 0) + n


def remedy(key: str) -> str:
    """What the user can do about the skipped messages counted under ``key`` (:func:`skip`'s)."""
    cause = max((c for c in SKIPS if key.startswith(c)), key=len, default=None)
    return "" if cause is None else SKIPS[cause]


def _stamp(sample: tuple) -> float:
    return sample[0]


@dataclass
class Track:
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

    def between(self, t: float, gap: float):
        """``(x, y, vx, vy)`` at ``t`` between the two samples around it when they are at most ``gap`` s apart, or
        on a sample (with the one before it, at most ``gap`` s earlier, for its velocity); None otherwise."""
        s = self.samples
        i = bisect_right(s, t, key=_stamp) - 1  # the last sample at or before t
        if i < 0:
            return None
        if i + 1 < len(s) and s[i + 1][0] - s[i][0] <= gap:
            return self.at(t, 0.0)
        if t - s[i][0] <= ON_SAMPLE and i > 0 and s[i][0] - s[i - 1][0] <= gap:  # on a sample: the pair before it
            return Track(s[i - 1:i + 1]).at(t, ON_SAMPLE)
        return None

    def forget(self, before: float) -> None:
        """Drop the samples not needed to interpolate at ``before`` or later."""
        s = self.samples
        keep = max(bisect_right(s, before, key=_stamp) - 1, 0)
        if keep > 1:
            del s[:keep - 1]


def plan(messages: Iterable[Message], dt: float, window: float = WINDOW, max_gap: float = MAX_GAP,
         logs: str = "the logs") -> tuple[float, int]:
    """t = 0 and the number of steps of ``messages`` (their stamps are read; the grid's rules: t = 0 at the earliest
    stamp of the first ``window`` seconds, the last step at the latest stamp), before the replay starts. A stretch
    of more than ``max_gap`` seconds without a message (their finite stamps sorted) is a :class:`LogError` naming
    its two stamps and topics and ``logs``."""
    stamps, topic_of, topics = array("d"), array("i"), {}
    first, newest, t0 = math.inf, -math.inf, None
    for msg in messages:
        stamp = msg.stamp
        if not math.isfinite(stamp):
            continue
        stamps.append(stamp)
        topic_of.append(topics.setdefault(msg.topic, len(topics)))
        newest = max(newest, stamp)
        if t0 is None:
            first = min(first, stamp)
            if newest - first >= window:
                t0 = first
    if not stamps:
        raise LogError(f"{logs}: the logs hold no message of the map's topics (or none with a finite time stamp)")
    t0 = first if t0 is None else t0
    values = np.frombuffer(stamps, dtype=np.float64)
    order = np.argsort(values, kind="stable")
    gaps = np.diff(values[order])
    if len(gaps) and gaps.max() > max_gap:
        j = int(np.argmax(gaps > max_gap))
        names = list(topics)
        before, after = int(order[j]), int(order[j + 1])
        raise LogError(f"{logs}: no message from {values[before]:.6f} s ({names[topic_of[before]]}) to "
                       f"{values[after]:.6f} s ({names[topic_of[after]]}): a gap of {gaps[j]:.6g} s, longer than "
                       f"the replay's max_gap of {max_gap:g} s. A message stamped wrong, or two flights in one log? "
                       "Correct or remove it, or replay each flight alone, or raise max_gap in the map (--map)")
    upto = newest + 0.5 * dt - t0 + 1e-9  # the grid's last step (_Grid.finish)
    n = max(int((newest - t0) / dt) - 1, 0)
    while (n + 0.5) * dt <= upto:
        n += 1
    return t0, n


def on_grid(messages: Iterable[Message], scenario, counts: dict, window: float = WINDOW,
            start: float | None = None, n_steps: int | None = None,
            truth_gap: float = TRUTH_GAP) -> Iterator[StepInputs]:
    """The estimation steps of ``messages`` (see the module's docstring); ``counts`` gets what was skipped. ``start``
    and ``n_steps`` (from :func:`plan`): t = 0 and the number of steps, else found as the messages come. The
    scenario is checked at once (its sensor makes measurements from relative positions; it follows one target)."""
    measure, label, tracked = followed_measurement(scenario, "a replay from time-stamped logs",
                                                   "replay a run folder for other sensors")
    grid = _Grid(scenario, counts, window, start, label, measure, tracked, n_steps, truth_gap)
    return grid.run(messages)


def followed_measurement(scenario, who: str, otherwise: str) -> tuple:
    """What turns a message's relative position into the scenario sensor's measurement (its registration's
    :class:`~swarmtrack.registry.Measurement`), the sensor's label of the followed target and its row: what ``who``
    (a replay of logs, the field) needs; a :class:`LogError` saying what ``who`` takes (and ``otherwise``) when the
    sensor makes no such measurement or the estimator follows no single target."""
    kind = scenario.sensor.kind
    measurement = registry.get("sensor", kind).measurement
    if measurement is None:
        known = [name for name, k in registry.kinds("sensor").items() if k.measurement is not None]
        raise LogError(f"sensor.kind {kind}: {who} makes {', '.join(known)} measurements ({otherwise})")
    followed = scenario.estimator.followed_target()
    if followed is None:
        raise LogError(f"estimator.kind {scenario.estimator.kind} follows no single target: {who} gives "
                       "detections of one target")
    tracked = layout(scenario)["targets"].start + followed - 1
    label = sensor_labels(scenario)("targets", followed - 1)  # seen: validation checked it
    return registry.resolve(measurement.of_relative), label, tracked


def skipped_lines(counts: dict[str, int]) -> list[str]:
    """One line per kind of message skipped (:func:`skip`), with what the user can do about it."""
    return [f"{n} message(s) skipped: {why}: {remedy(why)}" for why, n in sorted(counts.items()) if n]


def finite(msg: Message) -> bool:
    """Every number of the message is finite (its stamp and its pairs)."""
    if not math.isfinite(msg.stamp):
        return False
    for name in ("position", "velocity", "relative", "range_bearing"):
        pair = getattr(msg, name, None)
        if pair is not None and not (math.isfinite(pair[0]) and math.isfinite(pair[1])):
            return False
    return True


class _Grid:
    def __init__(self, scenario, counts: dict, window: float, start: float | None, label: int, measure, tracked: int,
                 n_steps: int | None = None, truth_gap: float = TRUTH_GAP):
        self.n_steps, self.truth_gap = n_steps, truth_gap
        self.waiting: deque[StepInputs] = deque()  # steps whose truth awaits the truth sample after them
        self.n = scenario.swarm.n_uavs
        self.dt = 1.0 / scenario.rates.estimation
        self.rows = layout(scenario)
        self.m = sum(sl.stop - sl.start for sl in self.rows.values())
        self.counts, self.window, self.t0, self.label = counts, window, start, label
        self.measure, self.tracked = measure, tracked
        self.navs = [Track() for _ in range(self.n)]
        self.truth = Track()
        self.pending: list = []  # (stamp, order, Detection) heap
        self.latest: dict[str, float] = {}  # the latest stamp of each topic
        self.newest = -math.inf  # the latest stamp of the log so far
        self.early: list = []  # the messages of the first window (before t0 is known)
        self.first = math.inf  # their earliest stamp
        self.k = 0  # the next step to emit
        self._order = 0

    def run(self, messages: Iterable[Message]) -> Iterator[StepInputs]:
        for msg in messages:
            yield from self.put(msg)
        yield from self.finish()

    def put(self, msg: Message) -> Iterator[StepInputs]:
        if not finite(msg):
            skip(self.counts, "NaN or infinite value in a message", f" on {msg.topic}")
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
        self._emit(self.newest - self.window)
        yield from self._release()

    def _place(self, msg: Message) -> None:
        t = msg.stamp - self.t0
        if t < -0.5 * self.dt:
            skip(self.counts, "stamped before the replay's start")
            return
        if t < (self.k - 0.5) * self.dt:  # its step was emitted: it came more than the window late
            skip(self.counts, "came later than the replay window")
            return
        if self.n_steps is not None and t >= (self.n_steps - 0.5) * self.dt and not isinstance(msg, Truth):
            return  # past the planned last step (a message the plan read and this pass would not, e.g. a skip)
        if isinstance(msg, Navigation):
            self.navs[msg.uav].add(t, msg.position, msg.velocity)
        elif isinstance(msg, Truth):
            self.truth.add(t, msg.position, msg.velocity)
        else:
            heapq.heappush(self.pending, (t, self._order, msg))
            self._order += 1

    def _emit(self, upto: float) -> None:
        """Every step whose time (and whose detections' window) the log has gone past, to :attr:`waiting`."""
        while (self.k + 0.5) * self.dt <= upto - self.t0 + 1e-9:  # stamps in ns: a step's end is not rounded away
            if self.n_steps is not None and self.k >= self.n_steps:
                return
            self.waiting.append(self._step())

    def _release(self, final: bool = False) -> Iterator[StepInputs]:
        """The waiting steps whose truth is known (all of them when the log has ended: ``final``), in order."""
        while self.waiting:
            step = self.waiting[0]
            got = self._truth_at(step.t, final)
            if got is False:
                return
            if got is not None:
                step.truth[self.tracked] = got
            self.waiting.popleft()
            yield step

    def _truth_at(self, t: float, final: bool):
        """The truth at ``t`` (between two samples at most ``truth_gap`` apart), None (absent), or False (not known
        yet: the sample after ``t`` may still come)."""
        got = self.truth.between(t, self.truth_gap)
        if got is not None:
            return got
        s = self.truth.samples
        i = bisect_right(s, t, key=_stamp) - 1  # the last sample at or before t: no other can come (it would be late)
        if i < 0 or i + 1 < len(s) or final or (self.k - 0.5) * self.dt - s[i][0] > self.truth_gap:
            return None  # the next sample is (or will be) more than truth_gap after this one
        return False

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
        if self.n_steps is None:
            self._emit(self.newest + 0.5 * self.dt)  # up to the step of the log's last stamp
        else:
            while self.k < self.n_steps:
                self.waiting.append(self._step())
        yield from self._release(final=True)

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
                skip(self.counts, "detection with no navigation of its UAV at its time")
                continue
            owners.append(det.uav)
            rel.append(det.offset())
            pos.append(where[:2])
        truth = np.full((self.m, 4), np.nan)  # the followed target's when it is known (_release)
        uavs = self.rows["uavs"]
        truth[uavs] = nav
        for track in self.navs:
            track.forget(t - self.window)
        self.truth.forget(min(t - self.window, self.waiting[0].t if self.waiting else t))
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
            skip(self.counts, "a second detection of the target by one UAV in one estimation step",
                 n=int((~last).sum()))
            owner, rel, pos = owner[last], rel[last], pos[last]
        z, frame = self.measure(rel, pos)
        return Detections(owner, z, pos, np.full(len(owner), self.label, dtype=np.int64), self.n, frame=frame)
