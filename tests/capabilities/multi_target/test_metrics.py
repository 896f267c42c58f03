"""The multi-target metrics (issue 40): GOSPA per step and UAV is the GOSPA of that UAV's reported tracks against the
objects; label switches and track breaks count what they say; a sample that did not come is left out."""

from types import SimpleNamespace

import numpy as np
import pytest

from swarmtrack.analysis.gospa import gospa
from swarmtrack.capabilities.multi_target import metrics
from swarmtrack.sim.recorder import Chunk


def _run(labels, present=None):
    """A recording's stand-in: 1 UAV, 2 objects at (0, 0) and (50, 0); the UAV reports a track on object k at step s
    labelled ``labels[k][s]`` (None: no track), 1 m off."""
    steps = len(labels[0])
    truth = np.zeros((steps, 3, 4))
    truth[:, 1, 0] = 50.0
    truth[:, 2] = [0.0, -30.0, 0.0, 0.0]  # the UAV
    tracks = np.full((steps, 1, 4, 4), np.nan)
    lab = np.full((steps, 1, 4), np.nan)
    for s in range(steps):
        row = 0
        for k in range(2):
            if labels[k][s] is not None:
                tracks[s, 0, row] = [truth[s, k, 0] + 1.0, 0.0, 0.0, 0.0]
                lab[s, 0, row] = labels[k][s]
                row += 1
    rec = SimpleNamespace(n_agents=1, meta={"groups": {"targets": [0, 2], "decoys": [2, 2], "uavs": [2, 3]}})
    chunk = Chunk(0, np.arange(steps, dtype=float), truth, np.zeros((steps, 3), dtype=np.int16),
                  {"tracks": tracks, "track_labels": lab, "n_tracks": (~np.isnan(lab)).sum(-1).astype(float),
                   "bytes_shared": np.zeros((steps, 1))}, present=present)
    return rec, chunk


def test_gospa_per_step_is_the_gospa_of_the_reported_tracks():
    rec, c = _run([[1, 1, 1, None], [2, None, 2, 2]])
    v = metrics.per_step(rec, c)
    for s in range(4):
        some = ~np.isnan(c.probes["track_labels"][s, 0])
        g = gospa(c.probes["tracks"][s, 0, some, :2], c.truth[s, :2, :2], metrics.C, metrics.P, metrics.ALPHA)
        assert v["gospa"][s, 0] == pytest.approx(g.distance, abs=1e-12)
    assert v["n_missed"][:, 0].tolist() == [0, 1, 0, 1]
    assert v["gospa"][0, 0] == pytest.approx(2.0)  # two tracks 1 m off


def test_label_switches_and_track_breaks_count_what_they_say():
    rec, c = _run([[7, 7, 8, 8, None], [3, None, 3, 3, 3]])
    acc = metrics._Continuity(rec)
    acc.add(c, np.ones(5, dtype=bool))
    out = acc.result()
    assert out["label_switches"] == 1 and out["track_breaks"] == 2


def test_a_sample_that_did_not_come_is_left_out():
    present = np.array([[True], [False], [True]])
    rec, c = _run([[1, 1, 1], [2, 2, None]], present=present)
    acc = metrics._Gospa(rec)
    acc.add(c, np.ones(3, dtype=bool))
    out = acc.result()
    assert out["samples"] == 2
    assert out["gospa"] == pytest.approx((2.0 + 1.0 + 5.0) / 2)
