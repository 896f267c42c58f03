"""What a replay hands the onboard stack each estimation step, whatever log it came from."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.sensors.detections import Detections


class LogError(ValueError):
    """A log that cannot be replayed (the message names the file, topic, field or row)."""


@dataclass(frozen=True)
class StepInputs:
    """Estimation step ``k`` at ``t``: every UAV's ``navigation`` (N, d) and its ``detections``, as its onboard
    code gets them; ``positions`` (N, 2) where the UAVs were (what the channel's proximity links read: the log's
    ground truth of the UAVs, or their navigation); ``truth`` (M, 4) every world object's ``[x, y, vx, vy]`` where
    the log holds ground truth (NaN elsewhere) and ``phase`` (M,) its profile phase (−1: none). Only the recorder
    and the channel read ``positions``, ``truth`` and ``phase``."""

    k: int
    t: float
    navigation: np.ndarray
    detections: Detections
    positions: np.ndarray
    truth: np.ndarray
    phase: np.ndarray


class Planned:
    """A reader's steps with their number known before the first is read (``n_steps``; None: not known), so a
    replay shows its length with the progress (:func:`swarmtrack.replay.engine.replay`)."""

    def __init__(self, steps, n_steps: int | None):
        self._steps, self.n_steps = iter(steps), n_steps

    def __iter__(self):
        return self

    def __next__(self) -> StepInputs:
        return next(self._steps)
