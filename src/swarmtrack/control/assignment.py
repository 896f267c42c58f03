"""Many targets, many UAVs: each UAV assigns the swarm to its confirmed tracks, keeps some UAVs searching for new
targets, and flocks around the track it took as L24's swarm flocks around its one target (issue 40).

Each UAV decides alone, from what it has: its own confirmed tracks (its estimator's view, ``TargetView.tracks``) and
the beacons of the neighbours it hears this control step (their navigation). With ``H`` UAVs heard (itself
included) and ``T`` tracks, it solves the swarm's assignment as it sees it:

* ``trackers = min(H, max(T, min(per_track·T, H − searchers)))`` UAVs follow tracks, each track offered
  ``c = ⌈trackers / T⌉`` places: every track a UAV while there are enough, at most ``per_track`` each, and at least
  ``searchers`` UAVs left over when there are UAVs to spare; the others search;
* the UAVs take the places that minimise the sum of their distances to the tracks (``scipy.optimize
  .linear_sum_assignment`` on the ``H x T·c`` distances): with enough UAVs every track gets ``⌊trackers / T⌋`` or
  more of them, and the UAVs left out, the farthest, search. When two UAVs see the same tracks (the same detections
  in the same order give the same tracks), they solve the same problem and agree; where they do not, each flies its
  own answer.

It then flies its own part:

* following a track: L24's flocking law (:func:`~swarmtrack.control.flocking.flocking_control`, its variant and
  gains) with the track's estimate as the target and, as neighbours, the heard UAVs its solution puts on the same
  track; the flocking integrals start afresh when it changes track;
* searching: a lawnmower over the surveillance ``region`` with lanes ``lane`` m apart, at ``search_speed``; the k-th
  of the S searchers (by UAV number) starts at the k/S-th of the pattern's waypoints and goes on from there.

What it optimises: the sum of the distances from the following UAVs to their tracks, over the assignments that share
the following UAVs evenly between the tracks (``trackers`` of them, above); the rest search.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from swarmtrack.control.flocking import FlockingGains, FlockingState, flocking_control
from swarmtrack.estimation.base import Probe, TargetView
from swarmtrack.network.links import is_sparse

#: Own-label of a UAV that searches (no track).
SEARCHING = -1.0


def lawnmower(region: tuple[float, float, float, float], lane: float) -> np.ndarray:
    """The waypoints (W, 2) of a lawnmower over ``region`` ``(x0, y0, x1, y1)``: lanes along x, ``lane`` m apart
    (half a lane in from the edges), back and forth, and back to the start."""
    x0, y0, x1, y1 = region
    n = max(1, int(np.ceil((y1 - y0) / lane)))
    ys = y0 + (np.arange(n) + 0.5) * (y1 - y0) / n
    xa, xb = x0 + min(lane / 2, (x1 - x0) / 2), x1 - min(lane / 2, (x1 - x0) / 2)
    out = []
    for k, y in enumerate(ys):
        out += [(xa, y), (xb, y)] if k % 2 == 0 else [(xb, y), (xa, y)]
    return np.asarray(out, dtype=float)


def assign(positions: np.ndarray, tracks: np.ndarray, searchers: int, per_track: int) -> np.ndarray:
    """The track index of each of the H UAVs at ``positions`` (H, 2) among ``tracks`` (T, 2), −1 for a UAV that
    searches (module docstring)."""
    h, t = len(positions), len(tracks)
    out = np.full(h, -1, dtype=np.int64)
    if t == 0 or h == 0:
        return out
    trackers = min(h, max(t, min(per_track * t, h - searchers)))
    places = -(-trackers // t)
    cost = np.linalg.norm(positions[:, None, :] - tracks[None, :, :], axis=-1)  # (H, T)
    cost = np.repeat(cost, places, axis=1)  # each track offered `places` columns
    rows, cols = linear_sum_assignment(cost)
    chosen = np.argsort(cost[rows, cols], kind="stable")[:trackers]  # the closest `trackers` take their places
    out[rows[chosen]] = cols[chosen] // places
    return out


@dataclass(frozen=True)
class SearchPattern:
    """The searchers' lawnmower: ``waypoints`` (W, 2), flown at ``speed`` m/s, a waypoint reached within
    ``reach`` m."""

    waypoints: np.ndarray
    speed: float
    reach: float


class TrackAssignmentController:
    """The controller of the module docstring for ``n`` UAVs (the whole swarm, or one UAV's own process: each row
    solves its own assignment, so its rows are the whole swarm's). ``law`` is the flocking law (the numpy reference
    or its compiled twin)."""

    def __init__(self, gains: FlockingGains, variant: str, n: int, chase_after: float, searchers: int,
                 per_track: int, pattern: SearchPattern, law=flocking_control):
        self.gains, self.variant, self.chase_after = gains, variant, chase_after
        self.searchers, self.per_track = searchers, per_track
        self.pattern, self._law = pattern, law
        self.state = FlockingState.zeros(n)
        self.following = np.full(n, SEARCHING)  # the label of each UAV's track, SEARCHING while it searches
        self.waypoint = np.full(n, -1, dtype=np.int64)  # each searcher's next waypoint (−1: not searching)
        self.probes = (Probe("following"),)

    def broadcast(self, t: float, nav: np.ndarray) -> dict:
        """Beacon: own position and velocity."""
        return {"nav": nav}

    def command(self, t: float, nav: np.ndarray, view: TargetView, inbox, dt: float) -> np.ndarray:
        """Acceleration commands (R, 2): each UAV's own assignment (module docstring), then its flocking or its
        search."""
        beacons = inbox.payloads["nav"]
        u = np.zeros((len(nav), 2))
        if t < self.chase_after - 1e-9:  # hold position until the tracks have settled
            return -self.gains.K_vt * nav[:, 2:4]
        links = inbox.links
        for r, me in enumerate(inbox.receivers.tolist()):
            row = np.asarray(links[r].todense()).ravel() if is_sparse(links) else np.asarray(links[r], dtype=bool)
            heard = np.flatnonzero(row)
            heard = np.sort(np.concatenate([[me], heard[heard != me]]))
            tracks, labels = _confirmed(view, r)
            mine = assign(beacons[heard, :2], tracks[:, :2], self.searchers, self.per_track)
            k = mine[np.searchsorted(heard, me)]
            if k < 0:
                u[r] = self._search(r, nav[r], np.flatnonzero(mine < 0), heard, me)
                self._follow(r, SEARCHING)
                continue
            self.waypoint[r] = -1
            self._follow(r, labels[k])
            flock = np.zeros(len(beacons), dtype=bool)
            flock[heard[mine == k]] = True
            state = FlockingState(self.state.e_int_integral[r:r + 1], self.state.v_int_integral[r:r + 1])
            ur, state = self._law(beacons[:, :2], beacons[:, 2:4], tracks[k, :2][None], tracks[k, 2:4][None],
                                  flock[None], state, self.gains, self.variant, dt, receivers=np.array([me]))
            self.state.e_int_integral[r] = state.e_int_integral[0]
            self.state.v_int_integral[r] = state.v_int_integral[0]
            u[r] = ur[0]
        return u

    def _follow(self, r: int, label: float) -> None:
        """Row ``r`` follows ``label`` now: a new track (or search) starts its flocking integrals afresh."""
        if label != self.following[r]:
            self.state.e_int_integral[r] = 0.0
            self.state.v_int_integral[r] = 0.0
            self.following[r] = label

    def _search(self, r: int, nav: np.ndarray, searching: np.ndarray, heard: np.ndarray, me: int) -> np.ndarray:
        """Row ``r``'s lawnmower command: to its next waypoint at the search speed."""
        w = self.pattern.waypoints
        if self.waypoint[r] < 0:  # it starts searching: at its share of the pattern
            rank = int(np.searchsorted(heard[searching], me))
            self.waypoint[r] = (rank * len(w)) // max(1, len(searching))
        to = w[self.waypoint[r]] - nav[:2]
        if np.hypot(*to) <= self.pattern.reach:
            self.waypoint[r] = (self.waypoint[r] + 1) % len(w)
            to = w[self.waypoint[r]] - nav[:2]
        v = self.pattern.speed * to / max(np.hypot(*to), 1e-9)
        u = self.gains.K_vt * (v - nav[2:4])
        norm = np.hypot(*u)
        return u if norm <= self.gains.accel_limit else u * (self.gains.accel_limit / norm)

    def sample(self) -> dict[str, np.ndarray]:
        return {"following": self.following.copy()}


def _confirmed(view: TargetView, r: int) -> tuple[np.ndarray, np.ndarray]:
    """Row ``r``'s confirmed tracks (T, 4) and their labels (T,) from its view (none without ``tracks``)."""
    if view.tracks is None or view.track_labels is None:
        return np.zeros((0, 4)), np.zeros(0)
    some = ~np.isnan(view.track_labels[r])
    return view.tracks[r][some], view.track_labels[r][some]
