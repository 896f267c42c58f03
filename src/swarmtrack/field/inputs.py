"""A field agent's inputs, step by step: the messages of its sources as they arrive, and at each estimation step
its navigation and its detections, as replay places a log's on its grid (:mod:`swarmtrack.replay.grid`), but at
the wall clock's pace.

- **Time.** A message's time is its stamp; the run's t = 0 is the swarm's epoch (``--start``), so step k is at
  ``epoch + k·dt`` on every UAV's clock.
- **Navigation** at step k is the UAV's navigation at the step's time: interpolated between the samples around it,
  else the latest held for up to ``window`` s (:class:`~swarmtrack.replay.grid.Track`); the autopilot's is put as a
  sample at each step's time.
- **Detections** are those that came since the previous step (the latest if several: a frame that came after its
  own step is superseded, and counted), taken
  from where the UAV's navigation put it at their stamp and made the scenario sensor's measurement
  (:class:`~swarmtrack.registry.Measurement`), stamped with their time (:attr:`Detections.taken`).
- **Skipped, counted and named** as in replay (:func:`~swarmtrack.replay.grid.skip`): a message with a NaN or
  infinite value, one stamped before an earlier message of its topic (its clock went backwards), a detection more
  than ``window`` s older than its step (it came too late), one without navigation at its time.
- **Truth** (a monitor's truth source) is kept the same way, interpolated at a step's time when samples around it
  are at most ``truth_gap`` s apart.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable

import numpy as np

from swarmtrack.replay.grid import (
    TRUTH_GAP,
    WINDOW,
    Detection,
    Message,
    Navigation,
    Track,
    Truth,
    finite,
    followed_measurement,
    skip,
)
from swarmtrack.sensors.detections import Detections


class FieldInputs:
    """The inputs of UAV ``uav`` (0-based) of ``scenario`` (or of a monitor: ``uav`` None, truth only) on the clock
    that starts at ``epoch`` (wall-clock s): :meth:`put` from the sources' threads, :meth:`navigation` and
    :meth:`detections` at each step."""

    def __init__(self, scenario, uav: int | None, epoch: float, window: float = WINDOW, truth_gap: float = TRUTH_GAP):
        self.uav, self.epoch, self.window, self.truth_gap = uav, epoch, window, truth_gap
        self.dt = 1.0 / scenario.rates.estimation
        self._lock = threading.Lock()
        self.counts: dict[str, int] = {}  # skipped messages, by cause and topic
        self.heard: dict[str, float] = {}  # when each topic last gave a message (monotonic s)
        self._latest: dict[str, float] = {}  # the latest stamp of each topic
        self._nav, self.truth = Track(), Track()
        self._pending: list[tuple[float, Detection]] = []  # detections since the previous step
        # run times from which navigation, and detections, are the run's (what was stamped before its start is not)
        self.since = self.start = -math.inf
        self._measure: Callable | None = None
        self._label: int | None = None
        if uav is not None:  # a LogError when the field cannot place its sensor's detections (as replay cannot)
            self._measure, self._label, _ = followed_measurement(scenario, "the field", "as replay does")

    def skip(self, cause: str, topic: str) -> None:
        with self._lock:
            skip(self.counts, cause, f" on {topic}")

    def put(self, msg: Message) -> None:
        """A message of a source (any thread): checked, then kept for the step it belongs to."""
        if not finite(msg):
            self.skip("NaN or infinite value in a message", msg.topic)
            return
        t = msg.stamp - self.epoch
        with self._lock:
            self.heard[msg.topic] = time.monotonic()
            if t < (self.start if isinstance(msg, Detection) else self.since):  # before the UAV's first step: not
                return  # a message of its run, never counted
            if msg.stamp < self._latest.get(msg.topic, -math.inf):
                skip(self.counts, "stamped before an earlier message of its topic", f" on {msg.topic}")
                return
            self._latest[msg.topic] = msg.stamp
            if isinstance(msg, Navigation):
                self._nav.add(t, msg.position, msg.velocity)
            elif isinstance(msg, Truth):
                self.truth.add(t, msg.position, msg.velocity)
            else:
                self._pending.append((t, msg))

    def begin(self, t: float) -> None:
        """The UAV's first step is at run time ``t``: navigation stamped more than ``window`` s before it and
        detections stamped before it are dropped, uncounted (frames taken before this process ran its stack)."""
        with self._lock:
            self.since, self.start = t - self.window, t
            self._pending = [(stamp, det) for stamp, det in self._pending if stamp >= t]

    def put_navigation(self, t: float, nav: np.ndarray) -> None:
        """The autopilot's navigation ``[x, y, vx, vy]`` at run time ``t``, as a sample."""
        with self._lock:
            self._nav.add(t, nav[:2], nav[2:4])

    def navigation(self, t: float) -> np.ndarray | None:
        """Its navigation (1, 4) at run time ``t``, None when there is none (none yet, or none for ``window`` s)."""
        with self._lock:
            got = self._nav.at(t, self.window)
            self._nav.forget(t - self.window)
        return None if got is None else np.asarray(got, dtype=float)[None]

    def detections(self, t: float) -> Detections:
        """The detections that came since the previous call, for the step at run time ``t``."""
        with self._lock:
            pending, self._pending = self._pending, []
            rows = []
            for stamp, det in sorted(pending, key=lambda p: p[0]):
                where = self._nav.at(stamp, self.window)
                if stamp < t - self.window:
                    skip(self.counts, "stamped more than the window before its step", f" on {det.topic}")
                elif where is None:
                    skip(self.counts, "detection with no navigation of its UAV at its time", f" on {det.topic}")
                else:
                    rows.append((stamp, det, where))
            if len(rows) > 1:
                skip(self.counts, "a frame that came after its step, superseded by the next",
                     f" on {rows[-1][1].topic}", len(rows) - 1)
        assert self._measure is not None, "a monitor's inputs (uav None) hold truth only"
        if not rows:
            return Detections(np.zeros(0, dtype=np.int64), np.zeros((0, 2)), np.zeros((0, 2)),
                              np.zeros(0, dtype=np.int64), 1, frame=self._frame_of_none())
        stamp, det, where = rows[-1]
        pos = np.asarray([where[:2]], dtype=float)
        z, frame = self._measure(det.offset()[None], pos)
        return Detections(np.zeros(1, dtype=np.int64), z, pos, np.array([self._label]), 1, frame=frame, taken=stamp)

    def _frame_of_none(self):
        """The frame of no detection: an empty one for a sensor that stamps frames, else None."""
        assert self._measure is not None
        _, frame = self._measure(np.zeros((0, 2)), np.zeros((0, 2)))
        return frame

    def truth_at(self, t: float) -> np.ndarray | None:
        """The truth ``[x, y, vx, vy]`` at run time ``t``: interpolated between the two samples around it when they are
        at most ``truth_gap`` apart, or on a sample, else None (absent; :meth:`~swarmtrack.replay.grid.Track.between`,
        replay's rule)."""
        with self._lock:
            got = self.truth.between(t, self.truth_gap)
            self.truth.forget(t - self.truth_gap)
        return None if got is None else np.asarray(got, dtype=float)

    def quiet(self, topics, now: float, after: float) -> list[str]:
        """Those of ``topics`` that gave no message for ``after`` s (or never)."""
        with self._lock:
            return [topic for topic in topics if now - self.heard.get(topic, -math.inf) > after]
