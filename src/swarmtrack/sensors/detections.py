"""Detections: what a sensor hands the onboard code, ragged over the swarm.

A sensing step yields any number of detections per UAV (none when nothing is in range, several when several
objects are). Row ``r`` was taken by UAV ``owner[r]`` from where its own navigation put it (``sensor_pos[r]``)
and carries the measurement ``z[r]`` and, where the sensor reports one, a ``label[r]`` the UAV can read
(``-1``: none, e.g. an unidentified object). The object a detection came from is *not* here: the world keeps
it beside (``source``) for the recorder and the metrics only, so onboard code cannot look at it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Label of a detection whose object the sensor cannot tell.
UNLABELLED = -1
#: Label of a detection the sensor recognised as a false target (a decoy "identified as false", IB21 Sec. 3.2).
IDENTIFIED_FALSE = -2


@dataclass(frozen=True)
class Detections:
    """``owner`` (M,) int, ``z`` (M, m), ``sensor_pos`` (M, d) (d = 2, or 3 for a 3-D sensor), ``label`` (M,) int;
    ``n_uavs`` owners exist."""

    owner: np.ndarray
    z: np.ndarray
    sensor_pos: np.ndarray
    label: np.ndarray
    n_uavs: int
    #: When every UAV detected each of ``grid`` objects (rows UAV-major, labels ``0..grid-1`` in order), so that
    #: per-UAV lookups are reshapes; None otherwise.
    grid: int | None = None
    #: A sensor whose measurement is affine in the object's ground position, ``z = A p + b``, stamps ``[A | b]``
    #: (M, 2, 3) as the UAV's own devices give it (the camera: W20 eq. 4.16); None for other sensors.
    frame: np.ndarray | None = None
    #: A sensor that sees a region stamps each UAV's footprint corners (N, 4, 2), counter-clockwise, as its own pose
    #: places them, even when nothing was in view (a frame with nothing in it still explored the region; IB21
    #: Sec. 3.2); None for other sensors.
    footprint: np.ndarray | None = None
    #: The time (s) the measurements were taken, stamped by the sensor: one sensing step is one instant, and a
    #: sensor with latency delivers it late (``taken`` < the time the onboard code receives it). None: now.
    taken: float | None = None

    def __len__(self) -> int:
        return len(self.owner)

    def of_uavs(self, uavs) -> Detections:
        """The detections of the swarm's UAVs ``uavs`` (sorted, distinct, 0-based), their owners renumbered
        ``0..R-1`` in that order: what one UAV's own process (or a subset's) is handed."""
        uavs = np.asarray(uavs, dtype=np.int64)
        pick = np.isin(self.owner, uavs)
        return Detections(np.searchsorted(uavs, self.owner[pick]), self.z[pick], self.sensor_pos[pick],
                          self.label[pick], len(uavs), self.grid, None if self.frame is None else self.frame[pick],
                          None if self.footprint is None else self.footprint[uavs], self.taken)

    def of_each_uav(self) -> list[Detections]:
        """:meth:`of_uavs` of every UAV alone (``[i]``), in one pass over the owners."""
        order = np.argsort(self.owner, kind="stable")  # each UAV's detections in their order here, as of_uavs keeps
        bounds = np.searchsorted(self.owner[order], np.arange(self.n_uavs + 1))
        out = []
        for i in range(self.n_uavs):
            pick = order[bounds[i]:bounds[i + 1]]
            out.append(Detections(np.zeros(len(pick), dtype=np.int64), self.z[pick], self.sensor_pos[pick],
                                  self.label[pick], 1, self.grid, None if self.frame is None else self.frame[pick],
                                  None if self.footprint is None else self.footprint[i:i + 1], self.taken))
        return out

    def of_label(self, label) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per-UAV arrays of the detection labelled ``label`` (one label, or one per UAV (N,): UAVs of a batch of
        worlds follow their own world's target): ``z`` (N, m), ``sensor_pos`` (N, d) and ``seen`` (N,); rows of UAVs
        that did not detect it are NaN. A sensor gives at most one per UAV and label."""
        n, m, d = self.n_uavs, self.z.shape[-1], self.sensor_pos.shape[-1]
        if np.ndim(label):
            pick = self.label == np.asarray(label)[self.owner]
        elif self.grid is not None and 0 <= label < self.grid:
            return (self.z.reshape(n, self.grid, m)[:, label].copy(),
                    self.sensor_pos.reshape(n, self.grid, d)[:, label].copy(), np.ones(n, dtype=bool))
        else:
            pick = self.label == label
        owners = self.owner[pick]
        z = np.full((n, m), np.nan)
        pos = np.full((n, d), np.nan)
        z[owners] = self.z[pick]
        pos[owners] = self.sensor_pos[pick]
        seen = np.zeros(n, dtype=bool)
        seen[owners] = True
        return z, pos, seen

    def frame_of_label(self, label) -> np.ndarray:
        """Per-UAV ``[A | b]`` (N, 2, 3) of the detection labelled ``label`` (one label, or one per UAV as in
        :meth:`of_label`; NaN where none; needs ``frame``)."""
        assert self.frame is not None, "needs frame"
        out = np.full((self.n_uavs, 2, 3), np.nan)
        pick = self.label == (np.asarray(label)[self.owner] if np.ndim(label) else label)
        out[self.owner[pick]] = self.frame[pick]
        return out
