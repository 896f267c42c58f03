"""Log reader ``csv``: CSV files with a documented header, one row per message (long format); no map needed.

=============  ===========================================================================================
``t``          the message's time stamp (s; any clock, the same for every log of the flight)
``uav``        the UAV, numbered from 1 (empty for ``truth``)
``kind``       ``navigation`` (the UAV's navigation solution), ``detection`` (its detection of the target) or
               ``truth`` (the followed target's ground truth)
``x``, ``y``   navigation, truth: the position in the map frame (ENU, m); detection: the target relative to
               the UAV (target minus UAV) along the map frame's axes (m)
``vx``, ``vy`` optional: navigation's or truth's velocity (m/s, ENU); left empty or absent, the positions'
               finite differences are used
``range``,     optional: a detection as range (m) and bearing (rad, from the map's x axis, counter-clockwise),
``bearing``    read where the row's ``x``, ``y`` are empty
=============  ===========================================================================================

Columns come in those pairs, in any order; ``t``, ``uav`` and ``kind`` are required, and other column names are
refused (a misspelt one would otherwise be ignored). Rows may come in any order: a CSV is a file, not a stream, so
it is read whole, kept as columns (about 60 bytes a row), and its messages are given to the grid sorted by time
stamp (stable; :class:`Table`), as if the file had been sorted.

Refused, naming the file and line (the header is line 1): an unknown kind, a ``uav`` that is not a whole number
from 1 (or not in the scenario), a truth row with a ``uav``, a row with more or fewer fields than the header (a
truncated last line among them), a cell that is not a number, a row whose kind needs columns the header lacks. An
empty or ``nan`` cell makes the message unusable: it is skipped and counted. With a map whose UAV flies a ULog
(``uavs.N.log``), that UAV's navigation rows are skipped and counted: its navigation is the ULog's.
"""

from __future__ import annotations

import csv
import math
from array import array
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from swarmtrack.replay.grid import Detection, Message, Navigation, Truth, skip
from swarmtrack.replay.steps import LogError

#: The header's columns: the required ones, then the optional pairs.
REQUIRED = ("t", "uav", "kind")
PAIRS = (("x", "y"), ("vx", "vy"), ("range", "bearing"))
KINDS = ("navigation", "detection", "truth")


def accepts(path: Path) -> bool:
    path = Path(path)
    return path.is_file() and path.suffix.lower() == ".csv"


def _columns(header: list[str], path: Path) -> dict[str, int]:
    names = [h.strip() for h in header]
    known = set(REQUIRED) | {c for pair in PAIRS for c in pair}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise LogError(f"{path}: line 1: unknown column {unknown[0]!r} (the header's columns: "
                       f"{', '.join(REQUIRED)}, x, y, vx, vy, range, bearing; docs/replay.md)")
    twice = [n for n in names if names.count(n) > 1]
    if twice:
        raise LogError(f"{path}: line 1: column {twice[0]!r} comes twice")
    missing = [c for c in REQUIRED if c not in names]
    if missing:
        raise LogError(f"{path}: line 1: no column {missing[0]!r} (the header needs {', '.join(REQUIRED)})")
    for a, b in PAIRS:
        if (a in names) != (b in names):
            raise LogError(f"{path}: line 1: columns {a} and {b} come together (the header has "
                           f"{a if a in names else b} only)")
    return {n: i for i, n in enumerate(names)}


class _Row:
    """One row's cells by column name, read as the reader needs them (errors name the file and line)."""

    def __init__(self, cells: list[str], columns: dict[str, int], path: Path, line: int):
        self.cells, self.columns, self.where = cells, columns, f"{path}: line {line}"

    def has(self, *names: str) -> bool:
        return all(n in self.columns for n in names)

    def text(self, name: str) -> str:
        return self.cells[self.columns[name]].strip()

    def number(self, name: str) -> float:
        """The cell as a float; an empty cell is NaN (an unusable message, skipped and counted)."""
        cell = self.text(name)
        if not cell:
            return math.nan
        try:
            return float(cell)
        except ValueError:
            raise LogError(f"{self.where}: column {name}: {cell!r} is not a number") from None

    def pair(self, a: str, b: str, kind: str) -> tuple[float, float]:
        if not self.has(a, b):
            raise LogError(f"{self.where}: a {kind} row needs columns {a} and {b}, which the header lacks")
        return self.number(a), self.number(b)

    def optional_pair(self, a: str, b: str) -> tuple[float, float] | None:
        """The pair where both cells are given, else None."""
        if not self.has(a, b) or not (self.text(a) or self.text(b)):
            return None
        return self.number(a), self.number(b)

    def uav(self, kind: str, n_uavs: int | None) -> int | None:
        """The row's 0-based UAV (None for truth)."""
        cell = self.text("uav")
        if kind == "truth":
            if cell:
                raise LogError(f"{self.where}: a truth row leaves uav empty (got {cell!r})")
            return None
        try:
            number = float(cell)  # "2.0" too: what a table with empty cells in an integer column writes
        except ValueError:
            number = math.nan
        if not number.is_integer():
            raise LogError(f"{self.where}: column uav: {cell!r} is not a UAV number (1, 2, …)")
        number = int(number)
        if number < 1:
            raise LogError(f"{self.where}: column uav: UAVs are numbered from 1; got {number}")
        if n_uavs is not None and number > n_uavs:
            raise LogError(f"{self.where}: uav {number} is not in the scenario, which has {n_uavs} UAV(s) "
                           "(swarm.n_uavs)")
        return number - 1


def _message(row: _Row, path: Path, n_uavs: int | None) -> Message:
    kind = row.text("kind")
    if kind not in KINDS:
        raise LogError(f"{row.where}: kind {kind!r} is not one of {', '.join(KINDS)}")
    uav = row.uav(kind, n_uavs)
    stamp = row.number("t")
    if kind == "detection":
        topic = f"detections of UAV {uav + 1} in {path}"
        if not row.has("x", "y") and not row.has("range", "bearing"):
            raise LogError(f"{row.where}: a detection row needs columns x, y or range, bearing, which the header "
                           "lacks")
        relative = row.optional_pair("x", "y")
        if relative is None and row.has("range", "bearing"):
            return Detection(topic, uav, stamp, range_bearing=row.pair("range", "bearing", kind))
        return Detection(topic, uav, stamp, relative=relative or row.pair("x", "y", kind))
    position, velocity = row.pair("x", "y", kind), row.optional_pair("vx", "vy")
    if kind == "truth":
        return Truth(f"truth in {path}", stamp, position, velocity)
    return Navigation(f"navigation of UAV {uav + 1} in {path}", uav, stamp, position, velocity)


def _rows(path: Path, flown: set[int], counts: dict, n_uavs: int | None) -> Iterator[Message]:
    """The messages of one CSV file, in its rows' order; ``flown``: the 0-based UAVs whose navigation is a ULog's."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as f:
            reader = csv.reader(f)
            header = next(reader, None)
            if header is None:
                raise LogError(f"{path}: empty (a CSV log starts with its header: {', '.join(REQUIRED)}, x, y, …)")
            columns = _columns(header, path)
            for cells in reader:
                if not any(c.strip() for c in cells):
                    continue  # a blank line
                if len(cells) != len(columns):
                    raise LogError(f"{path}: line {reader.line_num}: {len(cells)} field(s) where the header has "
                                   f"{len(columns)} (a truncated file?)")
                msg = _message(_Row(cells, columns, path, reader.line_num), path, n_uavs)
                if isinstance(msg, Navigation) and msg.uav in flown:
                    skip(counts, "navigation rows in", f" {path} of a UAV whose navigation is its ULog's")
                    continue
                yield msg
    except OSError as exc:
        raise LogError(f"{path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise LogError(f"{path}: not a text (UTF-8) CSV file") from None
    except csv.Error as exc:
        raise LogError(f"{path}: not a readable CSV file ({exc})") from None


class Table:
    """The messages of CSV files, read whole and kept as columns (about 60 bytes a row; a row's message object is
    made when it is read back), given back sorted by time stamp: a CSV is a file, not a stream, so rows grouped by
    kind (every truth row, then every detection row) replay as the sorted file does. The sort is stable (rows of one
    stamp keep the files' order, the files the order given); a row whose stamp is not a finite number comes first,
    to be skipped and counted as unusable."""

    _KINDS = (Navigation, Detection, Detection, Truth)  # codes: navigation, relative, range-bearing, truth

    def __init__(self, paths: list[Path]):
        self.paths = list(paths)
        self.stamp, self.code, self.uav, self.file = array("d"), array("b"), array("i"), array("i")
        self.a, self.b, self.va, self.vb, self.has_v = array("d"), array("d"), array("d"), array("d"), array("b")

    def add(self, msg: Message, file: int) -> None:
        if isinstance(msg, Detection):
            code, (a, b) = (1, msg.relative) if msg.relative is not None else (2, msg.range_bearing)
        else:
            code, (a, b) = (0 if isinstance(msg, Navigation) else 3), msg.position
        v = getattr(msg, "velocity", None)
        self.stamp.append(msg.stamp)
        self.code.append(code)
        self.uav.append(getattr(msg, "uav", -1))
        self.file.append(file)
        self.a.append(a)
        self.b.append(b)
        self.va.append(math.nan if v is None else v[0])
        self.vb.append(math.nan if v is None else v[1])
        self.has_v.append(v is not None)

    def __len__(self) -> int:
        return len(self.stamp)

    def __iter__(self) -> Iterator[Message]:
        stamp = np.frombuffer(self.stamp, dtype=np.float64) if len(self) else np.zeros(0)
        order = np.argsort(np.where(np.isfinite(stamp), stamp, -np.inf), kind="stable")
        topics: dict[tuple[int, int, int], str] = {}
        for j in order.tolist():
            code, uav, f = self.code[j], self.uav[j], self.file[j]
            topic = topics.get((code, uav, f))
            if topic is None:
                topic = topics[code, uav, f] = _topic(code, uav, self.paths[f])
            pair = (self.a[j], self.b[j])
            v = (self.va[j], self.vb[j]) if self.has_v[j] else None
            if code == 0:
                yield Navigation(topic, uav, self.stamp[j], pair, v)
            elif code == 3:
                yield Truth(topic, self.stamp[j], pair, v)
            elif code == 1:
                yield Detection(topic, uav, self.stamp[j], relative=pair)
            else:
                yield Detection(topic, uav, self.stamp[j], range_bearing=pair)


def _topic(code: int, uav: int, path: Path) -> str:
    if code == 3:
        return f"truth in {path}"
    return f"{'navigation' if code == 0 else 'detections'} of UAV {uav + 1} in {path}"


def read(paths: list[Path], mapping, counts: dict, n_uavs: int | None = None) -> Table:
    """The messages of the CSV files ``paths``, read whole (errors name the file and line), to be given back in
    time-stamp order (:class:`Table`); ``n_uavs``: the scenario's (a row of another UAV is refused naming its
    line). ``mapping`` (or None) only says which UAVs fly a ULog."""
    flown = set() if mapping is None else {n - 1 for n, s in mapping.uavs.items() if s.log is not None}
    table = Table([Path(p) for p in paths])
    for f, path in enumerate(table.paths):
        for msg in _rows(path, flown, counts, n_uavs):
            table.add(msg, f)
    return table


def messages(paths: list[Path], mapping, counts: dict, n_uavs: int | None = None) -> Iterator[Message]:
    """The messages of the CSV files ``paths`` in time-stamp order (:func:`read`)."""
    return iter(read(paths, mapping, counts, n_uavs))


def stamped(paths: list[Path], scenario, mapping, counts: dict):
    """The CSVs' messages per pass (:attr:`~swarmtrack.replay.formats.LogFormat.stamped`): read once, whole, their
    skips counted in ``counts``; None without a CSV."""
    if not paths:
        return None
    table = read(paths, mapping, counts, scenario.swarm.n_uavs)
    return lambda counted: iter(table)
