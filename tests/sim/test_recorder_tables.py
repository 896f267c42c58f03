"""The recorder's Parquet tables: the same tables however the steps are chunked, blocked and written (the layout's
columns made once per recording, blocks filled again after their chunk is written by the writer thread), the same
values as pyarrow's own conversion of the arrays, floats compressed only where they shrink, and no pandas import."""

import subprocess
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from swarmtrack.sensors.detections import Detections
from swarmtrack.sim import recorder
from swarmtrack.sim.recorder import Chunk, Recorder, Recording, _Layout

GROUPS = {"targets": [0, 2], "decoys": [2, 2], "uavs": [2, 7]}  # an empty group, as a run without decoys has
PROBES = {"estimate": (4,), "covariance": (4, 4), "detected": (), "nis": ()}


def _meta() -> dict:
    return {"dt": 0.05, "groups": GROUPS, "object_phases": [["line", "turn"], ["hover"], [], [], [], [], []],
            "tracked": 0, "phase_names": ["line", "turn"]}


def _steps(K=60, seed=0):
    """K steps of 7 objects (2 targets, 5 UAVs): truth, phase (−1: none), probes, and inputs of the onboard stack."""
    rng = np.random.default_rng(seed)
    for k in range(K):
        truth = rng.standard_normal((7, 4)) * 10
        phase = np.array([k // 30, 0, -1, -1, -1, -1, -1])
        root = rng.standard_normal((5, 4, 4))
        probes = {"estimate": rng.standard_normal((5, 4)), "covariance": root @ np.swapaxes(root, -1, -2),
                  "detected": (rng.random(5) > 0.3).astype(float), "nis": rng.chisquare(2, 5)}
        m = int(rng.integers(0, 8))
        det = Detections(rng.integers(0, 5, m), rng.standard_normal((m, 2)), rng.standard_normal((m, 2)),
                         rng.integers(0, 2, m), 5, taken=None if k % 2 else k * 0.05 - 0.01)
        yield k, k * 0.05, truth, phase, probes, rng.standard_normal((5, 4)), det


def _record(path, chunk_rows: int, monkeypatch, block_steps: int = 512) -> Recording:
    monkeypatch.setattr(recorder, "CHUNK_ROWS", chunk_rows)
    monkeypatch.setattr(recorder, "BLOCK_STEPS", block_steps)
    rec = Recorder(_meta(), 7, 5, PROBES, path, inputs=path is not None)
    for k, t, truth, phase, probes, nav, det in _steps():
        rec.record_inputs(k, t, nav, det)
        rec.record(t, truth, phase, probes)
        truth[:] = np.nan  # the caller's arrays change after the step: the recording keeps its copy
        probes["covariance"][:] = np.nan
    return rec.close()


def _reference_tables(meta: dict, c: Chunk) -> dict:
    """The tables as pyarrow converts them from numpy and Python objects (the recorder's former construction)."""
    k, m, n = len(c.t), meta["n_objects"], meta["n_uavs"]
    group, member = np.empty(m, dtype=object), np.empty(m, dtype=np.int32)
    for name, (start, stop) in meta["groups"].items():
        group[start:stop] = name
        member[start:stop] = np.arange(1, stop - start + 1)
    names = meta["object_phases"]
    offset = np.cumsum([0] + [len(p) for p in names])[:-1]
    dictionary = pa.array([p for obj in names for p in obj], type=pa.string())
    code = np.where(c.phase >= 0, offset[None, :] + c.phase, -1).ravel()
    phase = pa.DictionaryArray.from_arrays(pa.array(code, mask=code < 0, type=pa.int32()), dictionary)
    objects = {"step": np.repeat(np.arange(c.k0, c.k0 + k, dtype=np.int32), m), "t": np.repeat(c.t, m),
               "group": pa.array(np.tile(group, k), type=pa.string()).dictionary_encode(),
               "member": np.tile(member, k),
               **{col: c.truth[..., j].ravel() for j, col in enumerate(("x", "y", "vx", "vy"))},
               "phase_index": c.phase.ravel(), "phase": phase}
    uavs = {"step": np.repeat(np.arange(c.k0, c.k0 + k, dtype=np.int32), n), "t": np.repeat(c.t, n),
            "uav": np.tile(np.arange(1, n + 1, dtype=np.int32), k)}
    for name, shape in meta["probes"].items():
        flat = c.probes[name].reshape(k * n, -1)
        uavs[name] = (pa.array(flat[:, 0]) if not shape else
                      pa.FixedSizeListArray.from_arrays(pa.array(flat.ravel()), int(np.prod(shape))))
    return {"objects": pa.table(objects), "uavs": pa.table(uavs)}


def test_the_layouts_tables_equal_pyarrows_conversion(monkeypatch):
    memory = _record(None, 10_000, monkeypatch)
    layout = _Layout(memory.meta)
    for c in [*memory.chunks(), *memory.chunks()]:  # the tiled columns made once, used again
        got, want = layout.tables(c), _reference_tables(memory.meta, c)
        for name in ("objects", "uavs"):
            assert got[name].schema == want[name].schema, name
            assert got[name].equals(want[name]), name


@pytest.mark.parametrize("chunk_rows, block_steps", [(7 * 9, 512), (7 * 9, 4), (7 * 1000, 7)])
def test_chunked_writes_equal_the_recording_in_memory(tmp_path, monkeypatch, chunk_rows, block_steps):
    """Chunks of 9 steps (a block per chunk: two sets of blocks take turns; or blocks of 4 steps, joined), or one
    chunk of blocks of 7 steps: the files read back equal the recording kept in memory, table by table."""
    memory = _record(None, 10_000, monkeypatch)
    disk = _record(tmp_path / "rec", chunk_rows, monkeypatch, block_steps)
    loaded = Recording.load(tmp_path / "rec")
    (whole,) = memory.chunks()
    parts = list(loaded.chunks())
    assert len(parts) == -(-60 // loaded.meta["chunk_steps"])
    assert [c.k0 for c in parts] == list(range(0, 60, loaded.meta["chunk_steps"]))
    for name in ("t", "truth", "phase"):
        np.testing.assert_array_equal(np.concatenate([getattr(c, name) for c in parts]), getattr(whole, name))
    for name, values in whole.probes.items():
        np.testing.assert_array_equal(np.concatenate([c.probes[name] for c in parts]), values, err_msg=name)
    layout = _Layout(memory.meta)
    for table in ("objects", "uavs"):
        assert pq.read_table(tmp_path / "rec" / f"{table}.parquet").equals(layout.tables(whole)[table]), table
    assert disk.meta == loaded.meta
    # the inputs, written by the same thread, read back as they were handed
    for (k, t, nav, det), (k2, t2, nav2, det2) in zip(_inputs(), loaded.inputs(), strict=True):
        assert (k, t) == (k2, t2) and np.array_equal(nav, nav2) and det.taken == det2.taken
        for field in ("owner", "z", "sensor_pos", "label"):
            np.testing.assert_array_equal(getattr(det, field), getattr(det2, field))


def _inputs():
    return [(k, t, nav, det) for k, t, _, _, _, nav, det in _steps()]


def test_floats_are_compressed_only_where_they_shrink(tmp_path, monkeypatch):
    _record(tmp_path / "rec", 7 * 20, monkeypatch)
    meta = pq.ParquetFile(tmp_path / "rec" / "uavs.parquet").metadata.row_group(0)
    codec = {meta.column(i).path_in_schema: meta.column(i).compression for i in range(meta.num_columns)}
    assert codec["estimate.list.element"] == codec["nis"] == "UNCOMPRESSED"  # noise
    assert codec["covariance.list.element"] == codec["detected"] == "SNAPPY"  # symmetric entries; flags
    assert codec["step"] == codec["uav"] == "SNAPPY"
    objects = pq.ParquetFile(tmp_path / "rec" / "objects.parquet").metadata.row_group(0)
    assert {objects.column(i).path_in_schema: objects.column(i).compression
            for i in range(objects.num_columns)}["x"] == "UNCOMPRESSED"


def test_a_failed_write_is_raised_in_the_recording_thread(tmp_path, monkeypatch):
    def fail(self, tables):
        raise OSError("disk full")

    monkeypatch.setattr(Recorder, "_write_tables", fail)
    with pytest.raises(OSError, match="disk full"):
        _record(tmp_path / "rec", 7 * 9, monkeypatch)


def test_recording_and_reading_back_import_no_pandas(tmp_path):
    code = f"""
import sys
import numpy as np
from swarmtrack.sim.recorder import Recorder, Recording
from swarmtrack.sensors.detections import Detections
rec = Recorder({{"groups": {{"targets": [0, 1], "uavs": [1, 3]}}, "object_phases": [["a"], [], []]}}, 3, 2,
               {{"estimate": (4,), "covariance": (4, 4)}}, {str(tmp_path / "rec")!r}, inputs=True)
for k in range(5):
    rec.record_inputs(k, k * 0.1, np.zeros((2, 4)), Detections(np.zeros(1, int), np.zeros((1, 2)), np.zeros((1, 2)),
                                                              np.zeros(1, int), 2))
    rec.record(k * 0.1, np.zeros((3, 4)), np.array([0, -1, -1]), {{"estimate": np.zeros((2, 4)),
                                                                 "covariance": np.ones((2, 4, 4))}})
rec.close()
loaded = Recording.load({str(tmp_path / "rec")!r})
assert sum(len(c.t) for c in loaded.chunks()) == 5 and len(list(loaded.inputs())) == 5
print("pandas" in sys.modules)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("chunk_rows", [63, 4096])
def test_a_3d_worlds_altitude_is_recorded_beside_the_planar_truth_and_read_back(tmp_path, chunk_rows, monkeypatch):
    """Rows of six truth columns ([x, y, vx, vy, z, vz], World.recorded_truth): the chunks' truth keeps the planar
    four and their altitude the other two, in memory and on disk (z, vz columns, meta "altitude"); a planar
    recording has neither."""
    monkeypatch.setattr(recorder, "CHUNK_ROWS", chunk_rows)
    steps = list(_steps(40, seed=2))
    heights = [np.random.default_rng(k).standard_normal((7, 2)) for k in range(40)]
    recs = []
    for path in (None, tmp_path / "rec"):
        rec = Recorder(_meta(), 7, 5, PROBES, path)
        for (_, t, truth, phase, probes, _, _), h in zip(steps, heights, strict=True):
            rec.record(t, np.concatenate([truth, h], axis=1), phase, probes)
        recs.append(rec.close())
    for got in recs:
        chunks = list(got.chunks())
        assert got.meta["altitude"] is True
        np.testing.assert_array_equal(np.concatenate([c.truth for c in chunks]), [s[2] for s in steps])
        np.testing.assert_array_equal(np.concatenate([c.altitude for c in chunks]), heights)
    assert {"z", "vz"} <= set(pq.read_schema(tmp_path / "rec" / "objects.parquet").names)
    planar = _record(tmp_path / "planar", 4096, monkeypatch)
    assert "altitude" not in planar.meta and all(c.altitude is None for c in planar.chunks())
    assert "z" not in pq.read_schema(tmp_path / "planar" / "objects.parquet").names
