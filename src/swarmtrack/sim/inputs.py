"""What the onboard code was handed, kept beside a recording so that a run can be replayed (``swarmtrack replay``).

Every estimation step, each UAV's navigation solution and its sensor's :class:`Detections` are the onboard stack's
only inputs besides its inbox (which the channel recomputes from the scenario). A run folder keeps them in two
Parquet tables beside ``objects`` and ``uavs``:

- ``navigation.parquet``: one row per step and UAV: ``step``, ``t``, ``uav`` (1-based), ``navigation`` (the UAV's
  navigation solution, ``[x, y, vx, vy, …]``), the step's ``taken`` (when the sensor took the frame; NaN: now) and
  ``grid`` (−1: none; see :attr:`Detections.grid`), and ``footprint`` (4 corners, flattened) for a sensor that
  reports one;
- ``detections.parquet``: one row per detection: ``step``, ``uav`` (1-based owner), ``label``, ``z``,
  ``sensor_x``/``sensor_y`` (where the UAV's navigation put it; ``sensor_z`` too for a 3-D sensor) and ``frame``
  (``[A | b]`` flattened) for a sensor that stamps one.

The values are stored as float64 as they were handed, so reading them back gives the same :class:`Detections`,
bit for bit (the round trip of :mod:`swarmtrack.replay`).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from swarmtrack.sensors.detections import Detections

#: The tables' file names.
NAVIGATION, DETECTIONS = "navigation.parquet", "detections.parquet"
#: Steps held before they are written (a row group per table): the log's memory is bounded by these, whatever the
#: run's length (the recorder's own chunks can hold tens of thousands of steps of a small swarm).
FLUSH_STEPS = 1024
#: The columns of whole numbers or few values, dictionary-encoded and compressed; the others, the measured floats,
#: are written plain (:func:`writer_options`): a dictionary of noise-like values only costs time.
_CODED = ("step", "t", "uav", "taken", "grid", "label")
#: The columns of a detection's stamped sensor position (``sensor_z``: a 3-D sensor's height).
SENSOR_COLUMNS = ("sensor_x", "sensor_y", "sensor_z")


def arrow(values: np.ndarray, mask: np.ndarray | None = None):
    """A 1-d numeric numpy array as an Arrow array sharing its memory (``mask``: True where null). ``pa.array``
    gives the same array but imports pandas on its first call, 0.3 s of a run's start-up that uses no pandas."""
    import pyarrow as pa

    values = np.ascontiguousarray(values)
    validity, nulls = None, 0
    if mask is not None and (nulls := int(np.count_nonzero(mask))):
        validity = pa.py_buffer(np.packbits(~np.asarray(mask, dtype=bool), bitorder="little"))
    return pa.Array.from_buffers(pa.from_numpy_dtype(values.dtype), len(values), [validity, pa.py_buffer(values)],
                                 null_count=nulls)


def arrow_strings(values: list[str]):
    """A list of strings as an Arrow string array (:func:`arrow`: without importing pandas)."""
    import pyarrow as pa

    data = [v.encode() for v in values]
    offsets = np.cumsum([0, *map(len, data)], dtype=np.int32)
    return pa.Array.from_buffers(pa.string(), len(data), [None, pa.py_buffer(offsets), pa.py_buffer(b"".join(data))])


def numpy_of(column) -> np.ndarray:
    """An Arrow column (array or chunked array) of numbers without nulls as numpy, its values shared where they are
    one chunk (read-only, as ``to_numpy`` gives them; which also imports pandas); a fixed-size list column gives its
    flattened values."""
    import pyarrow as pa

    if isinstance(column, pa.ChunkedArray):
        column = column.chunk(0) if column.num_chunks == 1 else column.combine_chunks()
    if pa.types.is_fixed_size_list(column.type):
        column = column.flatten()
    if column.null_count or not (pa.types.is_integer(column.type) or pa.types.is_floating(column.type)):
        return column.to_numpy(zero_copy_only=False)
    dtype = np.dtype(column.type.to_pandas_dtype())
    if not len(column):
        return np.empty(0, dtype=dtype)
    return np.frombuffer(column.buffers()[1], dtype=dtype, count=len(column), offset=column.offset * dtype.itemsize)


def writer_options(table, coded) -> dict:
    """``pq.ParquetWriter`` options for chunks like ``table``: dictionary encoding and compression (snappy) for the
    ``coded`` columns; the others (floats) plain, compressed only where a sample of ``table`` shrinks below
    :data:`COMPRESS_BELOW` of its size; statistics for ``step`` only."""
    compression = {}
    for name, column in zip(table.column_names, table.columns, strict=True):
        codec = "snappy" if name in coded or _compresses(column) else "none"
        compression[name] = compression[f"{name}.list.element"] = codec  # a list column's values: by their path
    return {"use_dictionary": [c for c in table.column_names if c in coded], "compression": compression,
            "write_statistics": ["step"]}


#: A float column is compressed when snappy shrinks a sample (its first 1 MB) below this fraction of its size: the
#: truth, the estimates and the measurements are noise-like, snappy saves a few % of them at most and costs a
#: 10,000-UAV run seconds to write and read; covariances (their repeated symmetric entries) and flags shrink.
COMPRESS_BELOW = 0.8


def _compresses(column) -> bool:
    import pyarrow as pa

    sample = np.ascontiguousarray(numpy_of(column)[: 1 << 17])
    return sample.nbytes > 0 and len(pa.compress(pa.py_buffer(sample), "snappy", asbytes=True)) < (
        COMPRESS_BELOW * sample.nbytes)


def _fixed(values: np.ndarray, width: int):
    import pyarrow as pa

    return pa.FixedSizeListArray.from_arrays(arrow(np.ascontiguousarray(values, dtype=float).ravel()), width)


class InputLog:
    """Collects each estimation step's navigation and detections (:meth:`put`) and writes them in chunks
    (:meth:`flush`, a row group per table) to ``path``; ``path=None`` keeps them in memory (:attr:`steps`)."""

    def __init__(self, path: Path | None, submit=None):
        self.path = None if path is None else Path(path)
        self.steps: list[tuple[int, float, np.ndarray, Detections]] = []
        self._pending: list[tuple[int, float, np.ndarray, Detections]] = []
        self._writers: dict | None = None
        #: ``submit(fn, *args)`` runs a write (the recorder's writer thread); None: now, in this thread
        self._submit = submit
        self.meta: dict | None = None

    def put(self, k: int, t: float, nav: np.ndarray, det: Detections) -> None:
        """Step ``k`` at ``t``: every UAV's navigation (N, d) (copied) and the detections handed to the stack."""
        if self.meta is None:
            self.meta = {"navigation": int(nav.shape[1]), "z": int(det.z.shape[1]),
                         "sensor": int(det.sensor_pos.shape[1]),  # 3: a 3-D sensor's stamped height too
                         "frame": det.frame is not None, "footprint": det.footprint is not None}
        (self.steps if self.path is None else self._pending).append((k, t, np.array(nav, dtype=float), det))
        if len(self._pending) >= FLUSH_STEPS:
            self.flush()

    def flush(self) -> None:
        """Write the steps put since the last flush (a row group per table)."""
        if self.path is None or not self._pending:
            return
        import pyarrow as pa
        import pyarrow.parquet as pq

        tables = {name: pa.Table.from_arrays(list(cols.values()), names=list(cols))
                  for name, cols in ((NAVIGATION, self._navigation()), (DETECTIONS, self._detections()))}
        if self._writers is None:
            self.path.mkdir(parents=True, exist_ok=True)
            self._writers = {name: pq.ParquetWriter(self.path / name, table.schema,
                                                    **writer_options(table, _CODED))
                             for name, table in tables.items()}
        if self._submit is None:
            self._write(tables)
        else:
            self._submit(self._write, tables)
        self._pending = []

    def _write(self, tables: dict) -> None:
        for name, table in tables.items():
            self._writers[name].write_table(table, row_group_size=max(1, len(table)))

    def _navigation(self) -> dict:
        steps = self._pending
        n, d = steps[0][2].shape
        k = np.array([s[0] for s in steps], dtype=np.int32)
        cols = {"step": arrow(np.repeat(k, n)), "t": arrow(np.repeat(np.array([s[1] for s in steps], float), n)),
                "uav": arrow(np.tile(np.arange(1, n + 1, dtype=np.int32), len(steps))),
                "navigation": _fixed(np.concatenate([s[2] for s in steps]), d),
                "taken": arrow(np.repeat(np.array([np.nan if s[3].taken is None else s[3].taken for s in steps],
                                                  float), n)),
                "grid": arrow(np.repeat(np.array([-1 if s[3].grid is None else s[3].grid for s in steps], np.int32),
                                        n))}
        if self.meta["footprint"]:
            cols["footprint"] = _fixed(np.concatenate([s[3].footprint for s in steps]), 8)
        return cols

    def _detections(self) -> dict:
        dets = [s[3] for s in self._pending]
        counts = [len(d) for d in dets]

        def cat(field):
            return np.concatenate([field(d) for d in dets])

        cols = {"step": arrow(np.repeat(np.array([s[0] for s in self._pending], dtype=np.int32), counts)),
                "uav": arrow(cat(lambda d: d.owner).astype(np.int32) + 1),
                "label": arrow(cat(lambda d: d.label).astype(np.int32)),
                "z": _fixed(cat(lambda d: d.z), self.meta["z"]),
                **{name: arrow(cat(lambda d, a=a: d.sensor_pos[:, a]))
                   for a, name in enumerate(SENSOR_COLUMNS[:self.meta["sensor"]])}}
        if self.meta["frame"]:
            cols["frame"] = _fixed(cat(lambda d: d.frame), 6)
        return cols

    def close(self) -> dict | None:
        """Write what is left; the log's description for the recording's ``meta`` (None: nothing was put). With a
        ``submit``, its writes must have been done (the recorder waits for them)."""
        self.flush()
        for w in (self._writers or {}).values():
            w.close()
        return self.meta


def read_inputs(path: Path, meta: dict, n_uavs: int) -> Iterator[tuple[int, float, np.ndarray, Detections]]:
    """The steps an :class:`InputLog` wrote to ``path`` (``meta``: its description), in order: ``(k, t, nav,
    detections)``, a row group at a time."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    nav_file, det_file = pq.ParquetFile(path / NAVIGATION), pq.ParquetFile(path / DETECTIONS)
    d, m = meta["navigation"], meta["z"]
    det_groups = (det_file.read_row_group(g) for g in range(det_file.num_row_groups))
    held = None  # detection rows read ahead of the navigation's row group
    for g in range(nav_file.num_row_groups):
        nav = nav_file.read_row_group(g)
        steps = numpy_of(nav.column("step"))[::n_uavs]
        last = steps[-1]
        parts = [] if held is None else [held]
        while not parts or parts[-1].num_rows == 0 or numpy_of(parts[-1].column("step"))[-1] < last:
            nxt = next(det_groups, None)
            if nxt is None:
                break
            parts.append(nxt)
        dets = pa.concat_tables(parts) if parts else None
        det_step = np.zeros(0, np.int32) if dets is None else numpy_of(dets.column("step"))
        after = int(np.searchsorted(det_step, last, side="right"))  # the rows are in step order
        held = dets.slice(after) if dets is not None and after < len(det_step) else None
        yield from _steps(nav, dets, det_step, steps, n_uavs, d, m, meta)


def _flat(table, name: str, width: int) -> np.ndarray:
    return numpy_of(table.column(name)).reshape(-1, width)


def _steps(nav, dets, det_step, steps, n, d, m, meta):
    width = meta.get("sensor", 2)  # logs written before 3-D sensors have x and y
    t = numpy_of(nav.column("t"))[::n]
    navigation = _flat(nav, "navigation", d).reshape(len(steps), n, d)
    taken = numpy_of(nav.column("taken"))[::n]
    grid = numpy_of(nav.column("grid"))[::n]
    footprint = _flat(nav, "footprint", 8).reshape(len(steps), n, 4, 2) if meta["footprint"] else None
    if dets is not None and dets.num_rows:
        owner = numpy_of(dets.column("uav")).astype(np.int64) - 1
        label = numpy_of(dets.column("label")).astype(np.int64)
        z = _flat(dets, "z", m)
        pos = np.stack([numpy_of(dets.column(name)) for name in SENSOR_COLUMNS[:width]], axis=1)
        frame = _flat(dets, "frame", 6).reshape(-1, 2, 3) if meta["frame"] else None
    else:
        owner = label = np.zeros(0, np.int64)
        z, pos, frame = np.zeros((0, m)), np.zeros((0, width)), (np.zeros((0, 2, 3)) if meta["frame"] else None)
    bounds = np.searchsorted(det_step, np.append(steps, steps[-1] + 1))
    for j, k in enumerate(steps):
        r = slice(bounds[j], bounds[j + 1])
        yield int(k), float(t[j]), navigation[j], Detections(
            owner[r], z[r], pos[r], label[r], n, None if grid[j] < 0 else int(grid[j]),
            None if frame is None else frame[r], None if footprint is None else footprint[j],
            None if np.isnan(taken[j]) else float(taken[j]))
