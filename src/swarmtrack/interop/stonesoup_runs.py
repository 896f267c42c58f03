"""A swarmtrack run as Stone Soup ground truths and tracks, so that Stone Soup's metric generators (OSPA, GOSPA,
SIAP) run on it (for :mod:`swarmtrack.interop.stonesoup`).

:func:`truth_paths` gives one ``GroundTruthPath`` per world object (the targets and decoys by default), and
:func:`estimate_tracks` one ``Track`` per UAV: its onboard estimate at every recorded step. States are in Stone
Soup's order, ``[x, vx, y, vy, …]`` (:mod:`swarmtrack.interop.stonesoup_models`), stamped ``start + t`` (the run's
simulated time ``t`` in seconds after the ``start`` epoch, a ``datetime``), so truths and estimates of one step share
a timestamp. A Stone Soup distance on positions is ``Euclidean(mapping=(0, 2))``. The recording is read chunk by
chunk (:meth:`~swarmtrack.sim.recorder.Recording.chunks`); the Stone Soup objects hold every step.
"""

from __future__ import annotations

import datetime

import numpy as np
from stonesoup.types.array import CovarianceMatrix, StateVector
from stonesoup.types.groundtruth import GroundTruthPath, GroundTruthState
from stonesoup.types.state import GaussianState, State
from stonesoup.types.track import Track

from swarmtrack.interop.stonesoup_models import permutation

#: The recording's group of the swarm's own vehicles (left out of the truths by default).
SWARM = "uavs"


def _stamps(t: np.ndarray, start: datetime.datetime) -> list[datetime.datetime]:
    if not isinstance(start, datetime.datetime):
        raise TypeError(f"start must be a datetime.datetime (the epoch of the run's t = 0), not {type(start).__name__}")
    return [start + datetime.timedelta(seconds=float(s)) for s in t]


def truth_paths(recording, start: datetime.datetime, groups=None) -> set[GroundTruthPath]:
    """One ``GroundTruthPath`` per world object of ``groups`` (names of the recording's ``meta["groups"]``; default:
    every group but the swarm's ``uavs``), with id ``"<group>/<member>"`` (member 1-based) and states
    ``[x, vx, y, vy]`` stamped ``start + t``; its states' metadata say the group and member. Steps where an object's
    truth is not finite are left out."""
    known = recording.meta["groups"]
    names = [g for g in known if g != SWARM] if groups is None else list(groups)
    unknown = sorted(set(names) - set(known))
    if unknown:
        raise ValueError(f"unknown group(s) {unknown}; the recording has {sorted(known)}")
    objects = [(g, k, i) for g in names for k, i in enumerate(range(*known[g]), start=1)]
    paths = {i: GroundTruthPath(id=f"{g}/{k}") for g, k, i in objects}
    p = permutation(4)
    for chunk in recording.chunks(probes_wanted=False):
        stamps = _stamps(chunk.t, start)
        for g, k, i in objects:
            truth = chunk.truth[:, i]
            for s in np.flatnonzero(np.isfinite(truth).all(axis=1)):
                paths[i].append(GroundTruthState(StateVector(truth[s, p]), timestamp=stamps[s],
                                                 metadata={"group": g, "member": k}))
    return set(paths.values())


def estimate_tracks(recording, start: datetime.datetime) -> set[Track]:
    """One ``Track`` per UAV (id ``"uav<i>"``, 1-based) of its onboard estimate at every recorded step: a
    ``GaussianState`` of the ``estimate`` and ``covariance`` probes (the estimator's whole state, Stone Soup's order),
    a ``State`` where the estimator records no covariance, stamped ``start + t``. Steps without an estimate (NaN)
    are left out; a recording without an ``estimate`` probe (the set-membership estimator's) is refused."""
    probes = recording.meta["probes"]
    if "estimate" not in probes:
        raise ValueError(f"the recording has no 'estimate' probe to make tracks of (its probes: {sorted(probes)})")
    n_uavs = int(recording.meta["n_uavs"])
    tracks = [Track(id=f"uav{i + 1}") for i in range(n_uavs)]
    d = int(probes["estimate"][0])
    p = permutation(d)
    gaussian = list(probes.get("covariance", ())) == [d, d]
    for chunk in recording.chunks():
        stamps = _stamps(chunk.t, start)
        x = chunk.probes["estimate"]
        P = chunk.probes["covariance"] if gaussian else None
        for i, track in enumerate(tracks):
            ok = np.isfinite(x[:, i]).all(axis=1)
            if gaussian:
                ok &= np.isfinite(P[:, i]).all(axis=(1, 2))
            for s in np.flatnonzero(ok):
                if gaussian:
                    track.append(GaussianState(StateVector(x[s, i, p]), CovarianceMatrix(P[s, i][np.ix_(p, p)]),
                                               timestamp=stamps[s]))
                else:
                    track.append(State(StateVector(x[s, i, p]), timestamp=stamps[s]))
    return set(tracks)
