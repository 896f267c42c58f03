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
refused (a misspelt one would otherwise be ignored). Rows may come in any order within the map's ``window``
(:mod:`swarmtrack.replay.grid`); a file is read row by row (the ``csv`` module), whatever its size.

Refused, naming the file and line (the header is line 1): an unknown kind, a ``uav`` that is not a whole number
from 1 (or not in the scenario), a truth row with a ``uav``, a row with more or fewer fields than the header (a
truncated last line among them), a cell that is not a number, a row whose kind needs columns the header lacks. An
empty or ``nan`` cell makes the message unusable: it is skipped and counted. With a map whose UAV flies a ULog
(``uavs.N.log``), that UAV's navigation rows are skipped and counted: its navigation is the ULog's.
"""

from __future__ import annotations

import csv
import heapq
import math
from collections.abc import Iterator
from pathlib import Path

from swarmtrack.replay.grid import Detection, Message, Navigation, Truth
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
                    why = f"navigation rows in {path} of a UAV whose navigation is its ULog's"
                    counts[why] = counts.get(why, 0) + 1
                    continue
                yield msg
    except OSError as exc:
        raise LogError(f"{path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise LogError(f"{path}: not a text (UTF-8) CSV file") from None
    except csv.Error as exc:
        raise LogError(f"{path}: not a readable CSV file ({exc})") from None


def messages(paths: list[Path], mapping, counts: dict, n_uavs: int | None = None) -> Iterator[Message]:
    """The messages of the CSV files ``paths``, merged in time-stamp order across files; ``n_uavs``: the scenario's
    (a row of another UAV is refused naming its line). ``mapping`` (or None) only says which UAVs fly a ULog."""
    flown = set() if mapping is None else {n - 1 for n, s in mapping.uavs.items() if s.log is not None}
    streams = [_rows(Path(p), flown, counts, n_uavs) for p in paths]
    return heapq.merge(*streams, key=lambda m: m.stamp)
