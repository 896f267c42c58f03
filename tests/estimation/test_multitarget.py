"""Each UAV's LMB filter in the swarm (issue 40): with every UAV's detections delivered, each UAV's tracks are the
centralised filter's, labels included; lost messages cost accuracy, never finiteness; messages are bounded; labels
name the detection that began a track; fused tracks travel over several hops."""

import numpy as np
import pytest

from swarmtrack.analysis.gospa import gospa
from swarmtrack.estimation.multitarget import BIRTHS, PER_DETECTION, PER_TRACK
from swarmtrack.scenarios.loader import load_scenario
from swarmtrack.sim.engine import simulate


def _probes(name, overrides):
    rec = simulate(load_scenario(name, ["duration=30", *overrides]))
    chunks = list(rec.chunks())
    return rec, {k: np.concatenate([c.probes[k] for c in chunks]) for k in chunks[0].probes}, \
        np.concatenate([c.truth for c in chunks])


def test_with_every_detection_delivered_each_uav_is_the_centralised_filter():
    _, swarm, _ = _probes("mtt-box-hard", [])
    _, centre, _ = _probes("mtt-box-hard", ["estimator.share=centre"])
    for name in ("tracks", "track_labels", "existence", "track_position_cov"):
        np.testing.assert_array_equal(swarm[name], centre[name], err_msg=name)
    assert (swarm["n_tracks"][-1] >= 8).all()


def test_lost_messages_cost_accuracy_but_every_track_stays_finite_and_proper():
    _, p, truth = _probes("mtt-box-hard", ["network.loss_probability=0.6"])
    some = ~np.isnan(p["track_labels"])
    assert np.isfinite(p["tracks"][some]).all()
    cov = p["track_position_cov"][some]
    assert (np.linalg.eigvalsh(cov) > 0).all() and np.array_equal(cov, np.swapaxes(cov, -1, -2))
    last = [gospa(p["tracks"][-1, i, some[-1, i], :2], truth[-1, :10, :2], 10.0).distance for i in range(4)]
    assert max(last) < 15.0  # ten targets: missing three would cost 15


def test_a_message_carries_at_most_max_shared_detections_and_its_size_is_reported():
    _, p, _ = _probes("mtt-box-hard", ["estimator.max_shared=5"])
    assert p["detections_shared"].max() == 5
    # bytes: the detections (5 numbers each, their count and the sender's position) and the tracks (16 each, count)
    tracks_sent = (p["bytes_shared"] / 8 - 1 - 3 - PER_DETECTION * p["detections_shared"]) / PER_TRACK
    np.testing.assert_allclose(tracks_sent, np.round(tracks_sent))
    assert (tracks_sent >= 0).all() and (tracks_sent <= 32).all()


def test_a_label_names_the_step_uav_and_detection_that_began_the_track():
    rec, p, _ = _probes("mtt-box-easy", [])
    labels = p["track_labels"][~np.isnan(p["track_labels"])].astype(np.int64)
    step, m = np.divmod(labels, BIRTHS)
    k, j = np.divmod(step, 4)
    assert (k >= 0).all() and (k < 30).all() and set(j.tolist()) <= {0, 1, 2, 3} and (m < 64).all()
    np.testing.assert_array_equal(p["track_labels"][:, 0], p["track_labels"][:, 3])  # every UAV: the same labels


@pytest.mark.parametrize("fuse", [True, False])
def test_fused_tracks_travel_beyond_the_neighbours(fuse):
    """Three UAVs in a line over thirty objects at rest, each UAV seeing a square of the box's middle band: the last
    hears only the middle one, which hears the first. The objects only the first sees reach the last only through
    fused tracks."""
    overrides = ["targets.count=30", "targets.speed=1e-6", "targets.accel_noise=1e-9", "estimator.accel_std=0.01",
                 "swarm.n_uavs=3", "swarm.initial_positions=[[-66.7, 0.0], [0.0, 0.0], [66.7, 0.0]]",
                 "network.topology=line", "sensor.half_width=33.4", "sensor.clutter_rate=0.3",
                 f"estimator.fuse_tracks={str(fuse).lower()}"]
    _, p, truth = _probes("mtt-box-easy", overrides)
    first = (np.abs(truth[0, :30, :2] - [-66.7, 0.0]) <= 33.4).all(axis=1)  # what only the first UAV sees
    assert first.sum() >= 1
    last = p["tracks"][-1, 2][~np.isnan(p["track_labels"][-1, 2])]
    d = np.linalg.norm(truth[-1, :30, None, :2] - last[None, :, :2], axis=-1).min(axis=1) if len(last) else \
        np.full(30, np.inf)
    assert (d[first] < 2.0).all() if fuse else (d[first] > 10.0).all()


def test_a_batch_that_comes_after_its_step_is_dropped_and_counted():
    _, p, _ = _probes("mtt-box-hard", ["network.delay=1.0"])  # one estimation step: every neighbour's batch late
    assert (p["late_batches"][1:] == 3).all() and (p["late_batches"][0] == 0).all()
    _, q, _ = _probes("mtt-box-hard", ["network.delay=1.0", "estimator.fuse_tracks=false"])
    _, alone, _ = _probes("mtt-box-hard", ["estimator.share=none", "estimator.fuse_tracks=false"])
    np.testing.assert_array_equal(q["tracks"], alone["tracks"])  # a late batch changes nothing
