"""Recordings: streamed to Parquet in chunks, read back equal; metrics the same however the steps are chunked."""

import json

import numpy as np
import pytest

from swarmtrack.analysis.metrics import summary
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim import recorder
from swarmtrack.sim.engine import simulate
from swarmtrack.sim.recorder import Recording


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("l24-ct", ["duration=12", "estimator.model=ct"])


def _close(a, b):
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for k in a:
            _close(a[k], b[k])
    elif isinstance(a, float):
        assert a == pytest.approx(b, rel=1e-12, abs=1e-12)
    else:
        assert a == b


@pytest.mark.slow
def test_a_recording_streamed_to_disk_reads_back_equal_to_the_one_in_memory(scenario, tmp_path, monkeypatch):
    memory = simulate(scenario)
    monkeypatch.setattr(recorder, "CHUNK_ROWS", 100)  # many small row groups
    disk = simulate(scenario, record_to=tmp_path / "rec")
    loaded = Recording.load(tmp_path / "rec")
    assert loaded.meta["chunk_steps"] < loaded.meta["n_steps"]
    assert sum(1 for _ in loaded.chunks()) == 10  # 240 steps of 25
    for name in ("t", "phase", "target", "uav", "estimate", "covariance"):
        assert np.array_equal(getattr(memory, name), getattr(loaded, name)), name
    full = np.concatenate([c.probes["estimate"] for c in loaded.chunks()])
    assert full.shape[-1] == 5  # the CT model's whole state is recorded, not only [x, y, vx, vy]
    assert np.array_equal(full, np.concatenate([c.probes["estimate"] for c in memory.chunks()]))
    assert disk.meta == loaded.meta


@pytest.mark.slow
def test_metrics_do_not_depend_on_how_the_steps_are_chunked(scenario, monkeypatch):
    whole = summary(simulate(scenario))
    monkeypatch.setattr(recorder, "CHUNK_ROWS", 7)  # two steps of 4 objects per chunk
    _close(whole, summary(simulate(scenario)))


def test_a_recording_of_another_format_is_refused(scenario, tmp_path):
    simulate(load_scenario("l24-cv", ["duration=1"]), record_to=tmp_path)
    meta = json.loads((tmp_path / "meta.json").read_text())
    (tmp_path / "meta.json").write_text(json.dumps({**meta, "format": 99}))
    with pytest.raises(ValueError, match="recording format 99"):
        Recording.load(tmp_path)


@pytest.mark.slow
def test_the_steps_are_the_same_however_the_buffers_are_blocked(scenario, monkeypatch):
    """The recorder copies the steps into blocks of BLOCK_STEPS steps and joins them per chunk: the same arrays with
    blocks of 7 steps (several per chunk, a chunk ending inside a block) as with one block per chunk."""
    whole = list(simulate(scenario).chunks())
    monkeypatch.setattr(recorder, "BLOCK_STEPS", 7)
    monkeypatch.setattr(recorder, "CHUNK_ROWS", 4 * 100)  # 100 steps of 4 objects per chunk
    blocked = list(simulate(scenario).chunks())
    assert len(whole) == 1 and len(blocked) == 3
    for name in ("t", "truth", "phase"):
        np.testing.assert_array_equal(np.concatenate([getattr(c, name) for c in blocked]), getattr(whole[0], name))
    for name, values in whole[0].probes.items():
        np.testing.assert_array_equal(np.concatenate([c.probes[name] for c in blocked]), values, err_msg=name)


def test_a_step_of_another_shape_is_refused_not_broadcast():
    rec = recorder.Recorder({}, 2, 3, {"p": ()})
    rec.record(0.0, np.zeros((2, 4)), np.zeros(2), {"p": np.zeros(3)})
    with pytest.raises(ValueError, match="shape"):
        rec.record(0.05, np.zeros((2, 4)), np.zeros(2), {"p": np.zeros(1)})
