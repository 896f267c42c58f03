"""What a run leaves behind: a :class:`Recording`, written by a :class:`Recorder` while the run goes.

Two tables, sampled at every estimation step: ``objects`` (one row per step and world object: the truth
``[x, y, vx, vy]`` and the profile phase of every group's members, UAVs included) and ``uavs`` (one row per step
and UAV: the probes the onboard components declare, e.g. the estimator's full ``estimate`` and ``covariance``).
The recorder keeps them in memory (``path=None``, small runs and tests) or streams them to Parquet files in
chunks of steps (one row group per chunk), so memory does not grow with duration × swarm size. Analysis
(metrics, plots, reproductions) reads recordings through :meth:`Recording.chunks`, never live simulator objects.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from swarmtrack.sensors.detections import Detections
from swarmtrack.sim.inputs import InputLog, read_inputs

#: Version of the on-disk layout (``meta.json`` and the two Parquet files).
FORMAT = 1
#: Rows per chunk (a Parquet row group), about 8-40 MB of columns.
CHUNK_ROWS = 1 << 18


@dataclass(frozen=True)
class Chunk:
    """Consecutive steps ``k0 .. k0 + k − 1``: ``t`` (k,), ``truth`` (k, M, 4), ``phase`` (k, M), ``probes``
    ``name → (k, N, *shape)``."""

    k0: int
    t: np.ndarray
    truth: np.ndarray
    phase: np.ndarray
    probes: dict[str, np.ndarray]


def _tables(meta: dict, c: Chunk) -> dict:
    """The chunk as the two Parquet tables (pyarrow): ``objects`` with the truth of every world object (its
    ``group``, 1-based ``member``, ``phase`` by name) and ``uavs`` with the probes of every UAV (1-based ``uav``);
    multi-dimensional probes are fixed-size lists of their flattened values."""
    import pyarrow as pa

    k, m, n = len(c.t), meta["n_objects"], meta["n_uavs"]
    group, member = np.empty(m, dtype=object), np.empty(m, dtype=np.int32)
    for name, (start, stop) in meta["groups"].items():
        group[start:stop] = name
        member[start:stop] = np.arange(1, stop - start + 1)
    names = meta.get("object_phases") or [[] for _ in range(m)]
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


#: Steps per block of the recorder's buffers (at most a chunk's).
BLOCK_STEPS = 512


class _Block:
    """Up to ``len(t)`` consecutive steps in preallocated arrays: ``t`` (k,), ``truth`` (k, M, 4), ``phase`` (k, M)
    int16 and ``probes`` ``name → (k, N, *shape)`` float, the first ``n`` filled. A step is copied in as
    ``np.array(·, dtype)`` would copy it; its arrays must have the shapes of the block's first step (as stacking the
    steps would require)."""

    def __init__(self, t: np.ndarray, truth: np.ndarray, phase: np.ndarray, probes: dict[str, np.ndarray]):
        self.t, self.truth, self.phase, self.probes = t, truth, phase, probes
        self._arrays = [truth, phase, *probes.values()]  # in put's order: truth, phase, the probes'
        self._shapes = [a.shape[1:] for a in self._arrays]
        self.n = 0

    @classmethod
    def like(cls, steps: int, truth, phase, probes: dict) -> _Block:
        """An empty block of ``steps`` steps shaped as the step ``truth``, ``phase``, ``probes``."""
        return cls(np.empty(steps), np.empty((steps, *np.shape(truth))), np.empty((steps, *np.shape(phase)), np.int16),
                   {k: np.empty((steps, *np.shape(v))) for k, v in probes.items()})

    @property
    def full(self) -> bool:
        return self.n == len(self.t)

    def put(self, t: float, truth, phase, probes: dict) -> None:
        """Copy one step into the next row."""
        i = self.n
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


class Recorder:
    """Collects one row per step; ``probes`` maps each recorded UAV quantity to its shape per UAV.

    A step is copied into preallocated blocks of :data:`BLOCK_STEPS` steps (:class:`_Block`), joined once per chunk,
    rather than kept as a list of small arrays stacked at the end: the same arrays, without the per-step
    allocations."""

    def __init__(self, meta: dict, n_objects: int, n_uavs: int, probes: dict[str, tuple[int, ...]],
                 path: Path | None = None, inputs: bool = False, max_chunk_steps: int | None = None):
        self.meta = {**meta, "format": FORMAT, "n_objects": n_objects, "n_uavs": n_uavs,
                     "probes": {k: list(v) for k, v in probes.items()}}
        self.n_objects, self.n_uavs, self.probes = n_objects, n_uavs, probes
        self.chunk_steps = max(1, CHUNK_ROWS // max(n_objects, n_uavs, 1))
        if max_chunk_steps is not None:  # a long run of a small swarm: a chunk of that many steps at most
            self.chunk_steps = min(self.chunk_steps, max_chunk_steps)
        self.path = None if path is None else Path(path)
        self._blocks: list[_Block] = []  # the steps of the chunk being filled
        self._pending = 0  # steps in those blocks
        self._mem: list[Chunk] = []
        self._writers = None
        self._steps = 0
        self._t_last = 0.0
        #: The onboard stack's inputs (:mod:`swarmtrack.sim.inputs`), kept when ``inputs`` (a run to replay).
        self.inputs = InputLog(self.path) if inputs else None

    def record(self, t: float, truth: np.ndarray, phase: np.ndarray, probes: dict[str, np.ndarray]) -> None:
        """Append one step (arrays are copied)."""
        block = self._blocks[-1] if self._blocks else None
        if block is None or block.full:
            block = _Block.like(min(BLOCK_STEPS, self.chunk_steps - self._pending), truth, phase,
                                {k: probes[k] for k in self.probes})
            self._blocks.append(block)
        block.put(t, truth, phase, probes)
        self._pending += 1
        if self._pending == self.chunk_steps:
            self._flush()

    def record_inputs(self, k: int, t: float, nav: np.ndarray, detections: Detections) -> None:
        """Keep step ``k``'s onboard inputs (when the recorder keeps them: ``inputs=True``)."""
        if self.inputs is not None:
            self.inputs.put(k, t, nav, detections)

    def _flush(self) -> None:
        if not self._pending:
            return
        blocks = self._blocks
        chunk = Chunk(self._steps, _join([b.t[:b.n] for b in blocks]), _join([b.truth[:b.n] for b in blocks]),
                      _join([b.phase[:b.n] for b in blocks]),
                      {k: _join([b.probes[k][:b.n] for b in blocks]) for k in self.probes})
        self._steps += self._pending
        self._t_last = float(chunk.t[-1])
        self._blocks, self._pending = [], 0
        if self.path is None:
            self._mem.append(chunk)
        else:
            self._write(chunk)
        if self.inputs is not None:
            self.inputs.flush()

    def _write(self, c: Chunk) -> None:
        import pyarrow.parquet as pq

        tables = _tables(self.meta, c)
        if self._writers is None:
            self.path.mkdir(parents=True, exist_ok=True)
            # float columns are noise-like: no dictionary encoding, statistics only where a reader filters
            self._writers = {name: pq.ParquetWriter(self.path / f"{name}.parquet", table.schema,
                                                    use_dictionary=["step", "group", "member", "uav", "phase_index",
                                                                    "phase"],
                                                    write_statistics=["step"])
                             for name, table in tables.items()}
        for name, table in tables.items():
            self._writers[name].write_table(table, row_group_size=len(table))

    def close(self) -> Recording:
        """Finish the recording (files closed, ``meta.json`` written last) and return it."""
        self._flush()
        meta = {**self.meta, "n_steps": self._steps, "chunk_steps": self.chunk_steps, "t_last": self._t_last}
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
                    meta: dict | None = None) -> Recording:
        """A one-target recording from whole arrays (capability 1's view above; for tests and external data):
        object 0 is the target, objects 1..N the UAVs."""
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
                **(meta or {})}
        chunk = Chunk(0, t, truth, phases, {"estimate": np.asarray(estimate, dtype=float),
                                            "covariance": np.asarray(covariance, dtype=float)})
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
        import pyarrow.parquet as pq

        m, n = self.meta["n_objects"], self.meta["n_uavs"]
        objects = pq.ParquetFile(self.path / "objects.parquet") if self.meta["n_steps"] else None
        uavs = pq.ParquetFile(self.path / "uavs.parquet") if self.meta["n_steps"] else None
        k0 = 0
        for g in range(objects.num_row_groups if objects else 0):
            o = objects.read_row_group(g)
            k = o.num_rows // m
            truth = np.stack([o.column(c).to_numpy() for c in ("x", "y", "vx", "vy")], axis=-1).reshape(k, m, 4)
            probes = {}
            u = uavs.read_row_group(g) if probes_wanted else None
            for name, shape in self.meta["probes"].items() if probes_wanted else ():
                col = u.column(name).combine_chunks()
                flat = col.to_numpy() if not shape else col.flatten().to_numpy()
                probes[name] = flat.reshape(k, n, *shape)
            yield Chunk(k0, o.column("t").to_numpy()[::m].copy(), truth,
                        o.column("phase_index").to_numpy().reshape(k, m), probes)
            k0 += k

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
        return pa.concat_tables([_tables(self.meta, c)[table] for c in self.chunks()]).to_pandas()

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
