"""What a run leaves behind: a :class:`Recording`, written by a :class:`Recorder` while the run goes.

Two tables, sampled at every estimation step: ``objects`` (one row per step and world object: the truth
``[x, y, vx, vy]`` and the profile phase of every group's members, UAVs included) and ``uavs`` (one row per step
and UAV: the probes the onboard components declare, e.g. the estimator's full ``estimate`` and ``covariance``).
The recorder keeps them in memory (``path=None``, small runs and tests) or streams them to Parquet files in
chunks of steps (one row group per chunk), so memory does not grow with duration × swarm size. Analysis
(metrics, plots, reproductions) reads recordings through :meth:`Recording.chunks`, never live simulator objects.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from swarmtrack.sensors.detections import Detections
from swarmtrack.sim.inputs import InputLog, arrow, arrow_strings, numpy_of, read_inputs, writer_options
from swarmtrack.streams.frame import frame_of

#: Version of the on-disk layout (``meta.json`` and the two Parquet files).
FORMAT = 1
#: Rows per chunk (a Parquet row group), about 8-40 MB of columns.
CHUNK_ROWS = 1 << 18
#: How often (per second of wall clock) the taps' shapes are drawn again (a live view's rate, as Foxglove's).
DRAW_RATE = 50.0


#: The truth columns of every object, and those a 3-D world adds (its altitude channel).
TRUTH_COLUMNS = ("x", "y", "vx", "vy")
ALTITUDE_COLUMNS = ("z", "vz")


@dataclass(frozen=True)
class Chunk:
    """Consecutive steps ``k0 .. k0 + k − 1``: ``t`` (k,), ``truth`` (k, M, 4), ``phase`` (k, M), ``probes``
    ``name → (k, N, *shape)``; ``altitude`` (k, M, 2) every object's ``[z, vz]`` in a 3-D world, else None;
    ``present`` (k, N) bool: whether each UAV's sample came (None: every sample came, as in the simulator).

    A sample that did not come (a UAV whose process was lost, a sample late to a real-time world, a UAV under its
    operator's control) is *absent*: its probes hold NaN, and it is left out of every metric. A present sample
    whose numbers are NaN or infinite is a diverged filter, and the metrics say so. A truth that is not finite (a
    replayed log without ground truth at that time) is absent too (:func:`swarmtrack.analysis.coverage.judged`)."""

    k0: int
    t: np.ndarray
    truth: np.ndarray
    phase: np.ndarray
    probes: dict[str, np.ndarray]
    altitude: np.ndarray | None = None
    present: np.ndarray | None = None


def _tables(meta: dict, c: Chunk) -> dict:
    """The chunk as the two Parquet tables (pyarrow): ``objects`` with the truth of every world object (its
    ``group``, 1-based ``member``, ``phase`` by name) and ``uavs`` with the probes of every UAV (1-based ``uav``);
    multi-dimensional probes are fixed-size lists of their flattened values."""
    return _Layout(meta).tables(c)


#: Columns dictionary-encoded and compressed (whole numbers, few values); the others, the floats, are written plain
#: and compressed only where they shrink (:func:`~swarmtrack.sim.inputs.writer_options`).
_CODED = ("step", "t", "group", "member", "uav", "phase_index", "phase", "present")


class _Layout:
    """What :func:`_tables` repeats in every chunk of a recording, made once: each object's group (dictionary codes)
    and member number, the phase names' dictionary and each object's offset in it, and the columns that tile them
    over a chunk of ``k`` steps (kept for the last ``k``: a recording's chunks but its last have one size)."""

    def __init__(self, meta: dict):
        self.meta = meta
        m = meta["n_objects"]
        group, self.member = np.full(m, -1, dtype=np.int32), np.empty(m, dtype=np.int32)
        for name, (start, stop) in meta["groups"].items():
            group[start:stop] = list(meta["groups"]).index(name)
            self.member[start:stop] = np.arange(1, stop - start + 1)
        # the group names in the order of their first object, as dictionary_encode() of the names would give them
        first = [int(g) for g in dict.fromkeys(group.tolist()) if g >= 0]
        self.group_names = arrow_strings([list(meta["groups"])[g] for g in first])
        recode = np.full(len(meta["groups"]) + 1, -1, dtype=np.int32)
        recode[first] = np.arange(len(first), dtype=np.int32)
        self.group = recode[group]  # -1 (None) for an object in no group
        names = meta.get("object_phases") or [[] for _ in range(m)]
        self.offset = np.cumsum([0] + [len(p) for p in names])[:-1]
        self.phases = arrow_strings([p for obj in names for p in obj])
        self._k, self._tiled = -1, {}

    def _tile(self, k: int) -> dict:
        """The columns of a chunk of ``k`` steps that do not depend on its steps."""
        import pyarrow as pa

        if k != self._k:
            n = self.meta["n_uavs"]
            group = np.tile(self.group, k)
            self._tiled = {"group": pa.DictionaryArray.from_arrays(arrow(group, group < 0), self.group_names),
                           "member": arrow(np.tile(self.member, k)),
                           "uav": arrow(np.tile(np.arange(1, n + 1, dtype=np.int32), k))}
            self._k = k
        return self._tiled

    def tables(self, c: Chunk) -> dict:
        import pyarrow as pa

        k, m, n = len(c.t), self.meta["n_objects"], self.meta["n_uavs"]
        tiled = self._tile(k)
        step = np.arange(c.k0, c.k0 + k, dtype=np.int32)
        code = np.where(c.phase >= 0, self.offset[None, :] + c.phase, -1).ravel().astype(np.int32)
        heights = {} if c.altitude is None else \
            {col: arrow(c.altitude[..., j].ravel()) for j, col in enumerate(ALTITUDE_COLUMNS)}
        objects = {"step": arrow(np.repeat(step, m)), "t": arrow(np.repeat(c.t, m)), "group": tiled["group"],
                   "member": tiled["member"],
                   **{col: arrow(c.truth[..., j].ravel()) for j, col in enumerate(TRUTH_COLUMNS)}, **heights,
                   "phase_index": arrow(c.phase.ravel()),
                   "phase": pa.DictionaryArray.from_arrays(arrow(code, code < 0), self.phases)}
        uavs = {"step": arrow(np.repeat(step, n)), "t": arrow(np.repeat(c.t, n)), "uav": tiled["uav"]}
        if self.meta.get("presence"):
            came = np.ones(k * n, dtype=np.uint8) if c.present is None else c.present.ravel().astype(np.uint8)
            uavs["present"] = arrow(came)
        for name, shape in self.meta["probes"].items():
            flat = c.probes[name].reshape(k * n, -1)
            uavs[name] = (arrow(flat[:, 0]) if not shape else
                          pa.FixedSizeListArray.from_arrays(arrow(flat.ravel()), int(np.prod(shape))))
        return {name: pa.Table.from_arrays(list(cols.values()), names=list(cols))
                for name, cols in (("objects", objects), ("uavs", uavs))}


#: Steps per block of the recorder's buffers (at most a chunk's).
BLOCK_STEPS = 512


class _Block:
    """Up to ``len(t)`` consecutive steps in preallocated arrays: ``t`` (k,), ``truth`` (k, M, 4), ``phase`` (k, M)
    int16 and ``probes`` ``name → (k, N, *shape)`` float, the first ``n`` filled. A step is copied in as
    ``np.array(·, dtype)`` would copy it; its arrays must have the shapes of the block's first step (as stacking the
    steps would require)."""

    def __init__(self, t: np.ndarray, truth: np.ndarray, phase: np.ndarray, probes: dict[str, np.ndarray],
                 present: np.ndarray | None = None):
        self.t, self.truth, self.phase, self.probes, self.present = t, truth, phase, probes, present
        self._arrays = [truth, phase, *probes.values()]  # in put's order: truth, phase, the probes'
        self._shapes = [a.shape[1:] for a in self._arrays]
        self.n = 0

    @classmethod
    def like(cls, steps: int, truth, phase, probes: dict, presence: int | None = None) -> _Block:
        """An empty block of ``steps`` steps shaped as the step ``truth``, ``phase``, ``probes`` (and a present
        mask of ``presence`` UAVs, None: none)."""
        return cls(np.empty(steps), np.empty((steps, *np.shape(truth))), np.empty((steps, *np.shape(phase)), np.int16),
                   {k: np.empty((steps, *np.shape(v))) for k, v in probes.items()},
                   None if presence is None else np.ones((steps, presence), dtype=bool))

    @property
    def full(self) -> bool:
        return self.n == len(self.t)

    def fits(self, steps: int, truth, phase, probes: dict) -> bool:
        """Whether this block, emptied, is the one :meth:`like` would make for that step."""
        return (len(self.t) == steps and list(self.probes) == list(probes)
                and self._shapes == [np.shape(v) for v in (truth, phase, *probes.values())])

    def put(self, t: float, truth, phase, probes: dict, present=None) -> None:
        """Copy one step into the next row (``present``: the UAVs whose samples came, None: all)."""
        i = self.n
        if self.present is not None:
            self.present[i] = True if present is None else present
        values = (truth, phase, *map(probes.__getitem__, self.probes))
        for dst, shape, value in zip(self._arrays, self._shapes, values, strict=True):
            if getattr(value, "shape", None) != shape:
                _check_shape(value, shape)
            dst[i] = value  # not broadcast: the shapes are equal
        self.t[i] = t
        self.n = i + 1


def _check_shape(value, shape: tuple) -> None:
    """Refuse a step's ``value`` of another shape than its row's (assignment would broadcast it)."""
    if np.shape(value) != shape:
        raise ValueError(f"a recorded step has shape {np.shape(value)}, earlier steps {shape}")


def _join(parts: list[np.ndarray]) -> np.ndarray:
    """The blocks' filled rows as one array (a copy: the chunk does not keep the blocks)."""
    return parts[0].copy() if len(parts) == 1 else np.concatenate(parts)


def _view(parts: list[np.ndarray]) -> np.ndarray:
    """The blocks' filled rows as one array, the block's own rows when there is one block (no copy)."""
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


class Recorder:
    """Collects one row per step; ``probes`` maps each recorded UAV quantity to its shape per UAV.

    A step is copied into preallocated blocks of :data:`BLOCK_STEPS` steps (:class:`_Block`), joined once per chunk,
    rather than kept as a list of small arrays stacked at the end: the same arrays, without the per-step
    allocations. A recording on disk writes each chunk (and the input log's steps) in a writer thread while the
    next chunk's steps are run, from the blocks themselves: two sets of blocks take turns, one filled while the
    other is written, so memory holds two chunks at most and the writes come in the order of the steps."""

    def __init__(self, meta: dict, n_objects: int, n_uavs: int, probes: dict[str, tuple[int, ...]],
                 path: Path | None = None, inputs: bool = False, max_chunk_steps: int | None = None,
                 presence: bool = False, taps=(), shapes=None):
        self.meta = {**meta, "format": FORMAT, "n_objects": n_objects, "n_uavs": n_uavs,
                     "probes": {k: list(v) for k, v in probes.items()}}
        if presence:  # a driver whose samples may not come (live, replay): each step says which came
            self.meta["presence"] = True
        self.presence = presence
        self.n_objects, self.n_uavs, self.probes = n_objects, n_uavs, probes
        self.chunk_steps = max(1, CHUNK_ROWS // max(n_objects, n_uavs, 1))
        if max_chunk_steps is not None:  # a long run of a small swarm: a chunk of that many steps at most
            self.chunk_steps = min(self.chunk_steps, max_chunk_steps)
        self.path = None if path is None else Path(path)
        self._blocks: list[_Block] = []  # the steps of the chunk being filled
        self._pending = 0  # steps in those blocks
        self._writing: list[_Block] = []  # the blocks of the chunk being written to disk
        self._spare: list[_Block] = []  # the blocks of a chunk written to disk, to fill again
        self._layout: _Layout | None = None
        self._pool = None  # the writer thread (a recording on disk)
        self._futures: list = []  # the writes submitted to it and not yet waited for
        self._mem: list[Chunk] = []
        self._altitude = False  # whether the steps carry a 3-D world's altitude
        self._writers = None
        self._steps = 0
        self._t_last = 0.0
        #: The onboard stack's inputs (:mod:`swarmtrack.sim.inputs`), kept when ``inputs`` (a run to replay).
        self.inputs = InputLog(self.path, None if self.path is None else self._submit) if inputs else None
        #: Live outputs (:class:`~swarmtrack.streams.frame.Tap`: ROS 2 topics, the Foxglove view), opened with the
        #: recording's meta now and sent each step once it is recorded; they read, never change, what is recorded.
        self.taps = list(taps)
        self.shapes = shapes  # what the taps draw of the onboard state each step (streams.frame.shapes_of), or None
        self._drawn: tuple[float, list] = (-math.inf, [])  # the shapes last drawn, and when (monotonic s)
        for tap in self.taps:
            tap.open(self.meta)

    def record(self, t: float, truth: np.ndarray, phase: np.ndarray, probes: dict[str, np.ndarray],
               present: np.ndarray | None = None) -> None:
        """Append one step (arrays are copied). ``truth`` (M, 4) ``[x, y, vx, vy]``, or (M, 6) with a 3-D world's
        ``[z, vz]`` after them (:meth:`~swarmtrack.sim.world.World.recorded_truth`). ``present`` (N,) bool: whose
        samples came (a recorder made with ``presence``; None: all); an absent UAV's probes are recorded as given
        (NaN) and left out of the metrics (:class:`Chunk`)."""
        if present is not None and not self.presence:
            raise ValueError("a present mask given to a recorder made without presence=True")
        self._altitude = np.shape(truth)[-1] > len(TRUTH_COLUMNS)
        block = self._blocks[-1] if self._blocks else None
        if block is None or block.full:
            steps, probes_now = min(BLOCK_STEPS, self.chunk_steps - self._pending), {k: probes[k] for k in self.probes}
            block = self._spare.pop() if self._spare else None  # a block of a chunk already on disk
            if block is None or not block.fits(steps, truth, phase, probes_now):
                block = _Block.like(steps, truth, phase, probes_now, self.n_uavs if self.presence else None)
            self._blocks.append(block)
        block.put(t, truth, phase, probes, present)
        self._pending += 1
        if self.taps:
            frame = frame_of(self.meta, t, truth, probes, present)
            if self.shapes is not None:
                frame = dataclasses.replace(frame, polygons=self._draw())
            for tap in self.taps:
                tap.send(frame)
        if self._pending == self.chunk_steps:
            self._flush()

    def _draw(self) -> list:
        """The taps' shapes, drawn again at most :data:`DRAW_RATE` times a second of wall clock (a view's rate;
        drawing IB21's raster sets costs milliseconds, a step of the simulator a fraction of one)."""
        now = time.monotonic()
        if now - self._drawn[0] >= 1.0 / DRAW_RATE:
            self._drawn = (now, self.shapes())
        return self._drawn[1]

    def record_inputs(self, k: int, t: float, nav: np.ndarray, detections: Detections) -> None:
        """Keep step ``k``'s onboard inputs (when the recorder keeps them: ``inputs=True``)."""
        if self.inputs is not None:
            self.inputs.put(k, t, nav, detections)

    def _flush(self) -> None:
        if not self._pending:
            return
        blocks = self._blocks
        # a chunk kept in memory owns its arrays; one written to disk may be the blocks themselves, filled again after
        join = _join if self.path is None else _view
        truth, altitude = join([b.truth[:b.n] for b in blocks]), None
        if truth.shape[-1] > len(TRUTH_COLUMNS):  # a 3-D world's rows are [x, y, vx, vy, z, vz]
            truth, altitude = np.ascontiguousarray(truth[..., :4]), np.ascontiguousarray(truth[..., 4:])
        present = join([b.present[:b.n] for b in blocks]) if self.presence else None
        chunk = Chunk(self._steps, join([b.t[:b.n] for b in blocks]), truth, join([b.phase[:b.n] for b in blocks]),
                      {k: join([b.probes[k][:b.n] for b in blocks]) for k in self.probes}, altitude, present)
        self._steps += self._pending
        self._t_last = float(chunk.t[-1])
        self._blocks, self._pending = [], 0
        if self.path is None:
            self._mem.append(chunk)
        else:
            self._wait()  # the chunk before is on disk (at most one chunk is being written): its blocks are free
            for b in self._writing:
                b.n = 0
            self._spare, self._writing = self._writing, blocks
            self._write(chunk)
        if self.inputs is not None:
            self.inputs.flush()

    def _submit(self, fn, *args) -> None:
        """Run ``fn(*args)`` (a write to disk) in the writer thread, after the writes submitted before it: the
        Parquet encoding and the file writes (they release the GIL) go on while the next chunk's steps are run."""
        if self._pool is None:
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(1, thread_name_prefix="swarmtrack-recorder")
        self._futures.append(self._pool.submit(fn, *args))

    def _wait(self) -> None:
        """Wait until the writes submitted are done; the first that failed raises its exception here."""
        futures, self._futures = self._futures, []
        for f in futures:
            f.result()

    def _write(self, c: Chunk) -> None:
        import pyarrow.parquet as pq

        if self._layout is None:
            self._layout = _Layout(self.meta)
        tables = self._layout.tables(c)
        if self._writers is None:
            self.path.mkdir(parents=True, exist_ok=True)
            # the float columns plain, compressed where they shrink; statistics only where a reader filters
            self._writers = {name: pq.ParquetWriter(self.path / f"{name}.parquet", table.schema,
                                                    **writer_options(table, _CODED))
                             for name, table in tables.items()}
        self._submit(self._write_tables, tables)

    def _write_tables(self, tables: dict) -> None:
        for name, table in tables.items():
            self._writers[name].write_table(table, row_group_size=len(table))

    def close(self) -> Recording:
        """Finish the recording (files closed, ``meta.json`` written last; the taps closed) and return it."""
        for tap in self.taps:
            tap.close()
        self._flush()
        if self.inputs is not None:
            self.inputs.flush()
        self._wait()
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None
        meta = {**self.meta, "n_steps": self._steps, "chunk_steps": self.chunk_steps, "t_last": self._t_last}
        if self._altitude:
            meta["altitude"] = True  # the objects' table has z, vz (a 3-D world)
        if self.inputs is not None and self.inputs.meta is not None:
            meta["inputs"] = self.inputs.close()
        if self.path is None:
            return Recording(meta, self._mem, inputs=None if self.inputs is None else self.inputs.steps)
        if self._writers is not None:
            for w in self._writers.values():
                w.close()
        self.path.mkdir(parents=True, exist_ok=True)
        (self.path / "meta.json").write_text(json.dumps(meta, indent=2))
        return Recording(meta, path=self.path)


class Recording:
    """A finished run: ``meta`` (scenario, groups, tracked object, probes …) and its steps, in memory or on disk.

    :meth:`chunks` streams the steps; the properties below gather whole arrays for capability 1's analysis of
    small runs: ``t`` (K,), ``phase`` (K,) of the tracked target, ``target`` (K, 4) its truth, ``uav`` (K, N, 4)
    the UAVs' truth, ``estimate`` (K, N, 4) and ``covariance`` (K, N, 4, 4) each UAV's onboard estimate of the
    target's ``[x, y, vx, vy]``.
    """

    def __init__(self, meta: dict, chunks: list[Chunk] | None = None, path: Path | None = None,
                 inputs: list | None = None):
        self.meta, self._chunks, self.path = meta, chunks, path
        self._inputs = inputs
        self._cache: dict[str, np.ndarray] = {}

    @classmethod
    def from_arrays(cls, t, phase, phase_names, target, uav, estimate, covariance, d, r_comm, chase_start=0.0,
                    meta: dict | None = None, present=None) -> Recording:
        """A one-target recording from whole arrays (capability 1's view above; for tests and external data):
        object 0 is the target, objects 1..N the UAVs; ``present`` (K, N) bool: the samples that came (None:
        all)."""
        t = np.asarray(t, dtype=float)
        n = np.shape(uav)[1]
        truth = np.concatenate([np.asarray(target, dtype=float)[:, None, :], np.asarray(uav, dtype=float)], axis=1)
        phases = np.full(truth.shape[:2], -1, dtype=np.int16)
        phases[:, 0] = phase
        full = {"dt": float(t[1] - t[0]) if len(t) > 1 else 0.0, "groups": {"targets": [0, 1], "uavs": [1, 1 + n]},
                "object_phases": [list(phase_names)] + [[]] * n,
                "tracked": 0, "phase_names": list(phase_names), "d": d, "r_comm": r_comm, "chase_start": chase_start,
                "format": FORMAT, "n_objects": n + 1, "n_uavs": n, "n_steps": len(t),
                "t_last": float(t[-1]) if len(t) else 0.0, "probes": {"estimate": [4], "covariance": [4, 4]},
                **({} if present is None else {"presence": True}), **(meta or {})}
        chunk = Chunk(0, t, truth, phases, {"estimate": np.asarray(estimate, dtype=float),
                                            "covariance": np.asarray(covariance, dtype=float)},
                      present=None if present is None else np.asarray(present, dtype=bool))
        return cls(full, [chunk])

    @classmethod
    def load(cls, path: Path) -> Recording:
        """A recording written to ``path`` (its ``meta.json`` and Parquet files)."""
        path = Path(path)
        meta = json.loads((path / "meta.json").read_text())
        if meta.get("format") != FORMAT:
            raise ValueError(f"{path}: recording format {meta.get('format')!r}, this version reads {FORMAT}")
        return cls(meta, path=path)

    # --- streaming ------------------------------------------------------------------------------------
    def chunks(self, probes_wanted: bool = True) -> Iterator[Chunk]:
        """The recording's steps, a chunk at a time; ``probes_wanted=False`` reads the truth only."""
        if self._chunks is not None:
            yield from self._chunks
            return
        if not self.meta["n_steps"]:
            return
        from concurrent.futures import ThreadPoolExecutor

        import pyarrow.parquet as pq

        # read, not memory-mapped: the pages of a mapped file stay resident, and a long run's files are gigabytes
        objects, uavs = (pq.ParquetFile(self.path / f"{name}.parquet") for name in ("objects", "uavs"))
        m = self.meta["n_objects"]
        k0 = np.cumsum([0] + [objects.metadata.row_group(g).num_rows // m for g in range(objects.num_row_groups)])
        wanted = list(self.meta["probes"]) if probes_wanted else []
        # the next chunk is read (pyarrow releases the GIL) while the caller works on this one
        with ThreadPoolExecutor(1, thread_name_prefix="swarmtrack-reader") as pool:
            ahead = pool.submit(self._read, objects, uavs, wanted, 0, int(k0[0]))
            for g in range(objects.num_row_groups):
                chunk = ahead.result()
                if g + 1 < objects.num_row_groups:
                    ahead = pool.submit(self._read, objects, uavs, wanted, g + 1, int(k0[g + 1]))
                yield chunk

    def _read(self, objects, uavs, wanted: list[str], g: int, k0: int) -> Chunk:
        """Row group ``g`` as a chunk of steps from ``k0``: the columns it holds, no others."""
        m, n = self.meta["n_objects"], self.meta["n_uavs"]
        heights = ALTITUDE_COLUMNS if self.meta.get("altitude") else ()
        o = objects.read_row_group(g, columns=["t", *TRUTH_COLUMNS, *heights, "phase_index"])
        k = o.num_rows // m
        truth = np.stack([numpy_of(o.column(c)) for c in TRUTH_COLUMNS], axis=-1).reshape(k, m, 4)
        altitude = np.stack([numpy_of(o.column(c)) for c in heights], axis=-1).reshape(k, m, 2) if heights else None
        presence = ["present"] if self.meta.get("presence") else []
        u = uavs.read_row_group(g, columns=wanted + presence) if wanted or presence else None
        probes = {name: numpy_of(u.column(name)).reshape(k, n, *self.meta["probes"][name]) for name in wanted}
        present = numpy_of(u.column("present")).reshape(k, n).astype(bool) if presence else None
        return Chunk(k0, numpy_of(o.column("t"))[::m].copy(), truth, numpy_of(o.column("phase_index")).reshape(k, m),
                     probes, altitude, present)

    def inputs(self) -> Iterator[tuple[int, float, np.ndarray, Detections]]:
        """The onboard stack's inputs step by step, ``(k, t, navigation (N, d), detections)``, as they were handed
        (:mod:`swarmtrack.sim.inputs`); a recording made without them raises ``LookupError``."""
        if "inputs" not in self.meta:
            raise LookupError("the recording holds no inputs (navigation and detections): it was made by a run "
                              "that did not keep them")
        if self._inputs is not None:
            return iter(self._inputs)
        return read_inputs(self.path, self.meta["inputs"], self.meta["n_uavs"])

    # --- tables -----------------------------------------------------------------------------------------
    def frame(self, table: str = "uavs"):
        """``objects`` or ``uavs`` as a pandas DataFrame (one row per step and object / UAV; see :func:`_tables`).
        The whole table in memory: for runs that fit."""
        import pyarrow as pa

        if self.path is not None:
            import pyarrow.parquet as pq

            return pq.read_table(self.path / f"{table}.parquet").to_pandas()
        layout = _Layout(self.meta)
        return pa.concat_tables([layout.tables(c)[table] for c in self.chunks()]).to_pandas()

    def write_csv(self, folder: Path) -> list[Path]:
        """Both tables as CSV (``objects.csv``, ``uavs.csv``), list probes spread over columns ``name_1`` …"""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        paths = []
        for table in ("objects", "uavs"):
            df = self.frame(table)
            for name, shape in self.meta["probes"].items() if table == "uavs" else ():
                if shape:
                    values = np.stack(df.pop(name).to_numpy())
                    labels = ["_".join(str(i + 1) for i in idx) for idx in np.ndindex(*shape)]
                    for j, label in enumerate(labels):
                        df[f"{name}_{label}"] = values[:, j]
            df = df.drop(columns=[c for c in ("phase_index",) if c in df])
            paths.append(folder / f"{table}.csv")
            df.to_csv(paths[-1], index=False)
        return paths

    def _gather(self, key: str, pick) -> np.ndarray:
        if key not in self._cache:
            parts = [pick(c) for c in self.chunks()]
            self._cache[key] = np.concatenate(parts) if parts else np.zeros((0,))
        return self._cache[key]

    # --- capability 1's view ---------------------------------------------------------------------------
    @property
    def tracked(self) -> int | None:
        """World object index of the target the estimators follow (None: they follow no single target)."""
        return self.meta["tracked"]

    @property
    def uav_slice(self) -> slice:
        start, stop = self.meta["groups"]["uavs"]
        return slice(start, stop)

    @property
    def t(self) -> np.ndarray:
        return self._gather("t", lambda c: c.t)

    @property
    def phase(self) -> np.ndarray:
        return self._gather("phase", lambda c: c.phase[:, self.tracked].astype(np.int64))

    @property
    def phase_names(self) -> list[str]:
        return list(self.meta["phase_names"])

    @property
    def target(self) -> np.ndarray:
        return self._gather("target", lambda c: c.truth[:, self.tracked])

    @property
    def uav(self) -> np.ndarray:
        return self._gather("uav", lambda c: c.truth[:, self.uav_slice])

    @property
    def estimate(self) -> np.ndarray:
        return self._gather("estimate", lambda c: c.probes["estimate"][..., :4])

    @property
    def covariance(self) -> np.ndarray:
        return self._gather("covariance", lambda c: c.probes["covariance"][..., :4, :4])

    @property
    def target_altitude(self) -> np.ndarray:
        """(K, 2) the tracked target's ``[z, vz]`` (a 3-D run)."""
        return self._gather("target_altitude", lambda c: c.altitude[:, self.tracked])

    @property
    def uav_altitude(self) -> np.ndarray:
        """(K, N, 2) the UAVs' ``[z, vz]`` (a 3-D run)."""
        return self._gather("uav_altitude", lambda c: c.altitude[:, self.uav_slice])

    @property
    def altitude_estimate(self) -> np.ndarray:
        """(K, N, 2) each UAV's estimate of the target's ``[z, vz]`` (a 3-D model's states 4 and 5)."""
        return self._gather("altitude_estimate", lambda c: c.probes["estimate"][..., 4:6])

    @property
    def d(self) -> float:
        return float(self.meta["d"])

    @property
    def r_comm(self) -> float:
        return float(self.meta["r_comm"])

    @property
    def chase_start(self) -> float:
        return float(self.meta.get("chase_start", 0.0))

    @property
    def n_agents(self) -> int:
        return int(self.meta["n_uavs"])

    @property
    def t_last(self) -> float:
        """Time of the last recorded step, s."""
        return float(self.meta["t_last"])

    @property
    def dt(self) -> float:
        return float(self.meta["dt"])
