"""Log reader ``ulog``: PX4 ULog files (``.ulg``), read with ``pyulog``, for each UAV's navigation.

A flight logs one ULog per vehicle; the map names each UAV's file and message (:mod:`swarmtrack.replay.mapping`)::

    uavs:
      1: {log: uav1.ulg, navigation: vehicle_local_position}
      2: {log: uav2.ulg, navigation: vehicle_odometry, time_offset: -12.5}

``log`` is resolved against the map file's folder, or is the ULog of that file name given on the command line.
What the reader takes from a message (PX4's ``msg/VehicleLocalPosition.msg``, ``msg/VehicleOdometry.msg``):

- **Time.** ``timestamp_sample`` (when the data was sampled) where the message has one and it is not 0, else
  ``timestamp``: µs since the vehicle booted, in seconds, plus the UAV's ``time_offset`` (s), which puts the boot
  clock on the other logs' clock (a bag's or a CSV's stamps). Stamps that go back on a message stop the replay
  (:mod:`swarmtrack.replay.grid`).
- **Position** ``x``, ``y`` (``vehicle_local_position``, older ``vehicle_odometry``) or ``position[0]``,
  ``position[1]`` (``vehicle_odometry`` since PX4 v1.14): PX4's local frame, NED (x north, y east), made ENU
  (x east, y north: :func:`swarmtrack.autopilot.frames.ned_to_enu`); its origin is taken to be the map frame's.
  A map's ``position: NAME`` reads ``NAME[0]``, ``NAME[1]`` or ``NAME.x``, ``NAME.y`` instead.
- **Velocity** ``vx``, ``vy`` or ``velocity[0]``, ``velocity[1]`` alike, where the message says they are valid and
  NED; otherwise the positions' finite differences are used.
- **Validity.** A message with ``xy_valid`` false, or whose frame is not NED (``vehicle_odometry``'s ``pose_frame``
  ≠ 1 ``POSE_FRAME_NED``; ``local_frame`` ≠ 0 ``LOCAL_FRAME_NED`` before v1.14), is skipped and counted; velocities
  with ``v_xy_valid`` false, ``velocity_frame`` not NED or NaN are left out (the message's position is kept).

Refused, naming the file: a file that is not a ULog, one that ends inside a message (**truncated**: pyulog would
read what comes before the cut without a word; a log cut short by a power loss is refused too, rather than replayed
as if the flight had ended there; a file cut exactly between two messages cannot be told from one that ends there),
a message the map names that the file does not hold, a ``position`` field that is not there. A stretch pyulog finds
damaged mid-file and skips (``file_corruption``) is counted, not fatal. pyulog reads a file whole (the messages the
map names only).
"""

from __future__ import annotations

import contextlib
import heapq
import io
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from swarmtrack.autopilot.frames import ned_to_enu
from swarmtrack.replay.grid import Navigation, skip
from swarmtrack.replay.steps import LogError

#: The first bytes of every ULog file (PX4's "ULog File Format": "ULog", then 0x01 0x12 0x35).
MAGIC = b"ULog\x01\x12\x35"
#: Where a message's planar position and velocity are, tried in turn (PX4's field names).
POSITION = (("x", "y"), ("position[0]", "position[1]"))
VELOCITY = (("vx", "vy"), ("velocity[0]", "velocity[1]"))
#: pyulog's read size when it searches for a sync marker after damage (a short read there is not a cut).
_SYNC_SEARCH = 512


def accepts(path: Path) -> bool:
    """A ``.ulg`` file, or any file that starts with the ULog magic bytes."""
    path = Path(path)
    if not path.is_file():
        return False
    return path.suffix.lower() == ".ulg" or _magic(path)


def _magic(path: Path) -> bool:
    try:
        with Path(path).open("rb") as f:
            return f.read(len(MAGIC)) == MAGIC
    except OSError:
        return False


class _Watched(io.BufferedReader):
    """A file that remembers whether a read ended inside what was asked for: the file ends inside a message. (At
    a clean end pyulog asks for a message header, 3 bytes, and gets none.)"""

    cut = False

    def read(self, size: int | None = -1) -> bytes:
        data = super().read(size)
        if size is not None and size > 0 and len(data) < size and size != _SYNC_SEARCH and (data or size != 3):
            self.cut = True
        return data


def _load(path: Path, names: list[str]):
    """The ULog at ``path`` with the messages ``names`` (pyulog prints its warnings; they are kept quiet)."""
    try:
        from pyulog import ULog
    except ImportError:  # a ULog the map names: swarmtrack replay checked only the logs it was given
        from swarmtrack.extras import refusal

        raise LogError(f"{path}: {refusal('reading PX4 ULog files', 'logs', ['pyulog'])}") from None
    try:
        f = _Watched(io.FileIO(path, "r"))
    except OSError as exc:
        raise LogError(f"{path}: {exc.strerror or exc}") from None
    truncated = f"{path}: the ULog is truncated (the file ends inside a message)"
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            log = ULog(f, message_name_filter_list=names)
    except Exception as exc:  # pyulog's ULogException and whatever a damaged header makes its parser raise
        raise LogError(truncated if f.cut and _magic(path) else
                       f"{path}: not a readable PX4 ULog file ({exc})") from None
    finally:
        f.close()
    if f.cut:
        raise LogError(truncated)
    return log


def _pair(fields: dict, candidates, path: Path, name: str, what: str | None) -> tuple[str, str] | None:
    for a, b in candidates:
        if a in fields and b in fields:
            return a, b
    if what is None:
        return None
    raise LogError(f"{path}: message {name} has no {what} field ({' or '.join(f'{a}, {b}' for a, b in candidates)}"
                   f"; its fields: {', '.join(f for f in fields if not f.startswith('_padding'))})")


def _navigation(path: Path, uav: int, sources, counts: dict) -> Iterator[Navigation]:
    """UAV ``uav``'s (0-based) navigation messages in ``path``, in the file's order."""
    name, field = sources.navigation.topic, sources.navigation.position
    log = _load(path, [name])
    topic = f"{name} in {path}"
    if log.file_corruption:
        skip(counts, "a damaged stretch of", f" {path} (pyulog's file_corruption)")
    data = next((d for d in log.data_list if d.name == name and d.multi_id == 0), None)  # its first instance
    if data is None:
        formats = sorted(log.message_formats)
        have = ", ".join(formats[:20]) + (" …" if len(formats) > 20 else "") if formats else "none"
        raise LogError(f"{path}: no message {name} (the map names it for uavs.{uav + 1}.navigation; the log's "
                       f"formats: {have})")
    fields = data.data
    candidates = POSITION if field is None else ((f"{field}[0]", f"{field}[1]"), (f"{field}.x", f"{field}.y"))
    pair = _pair(fields, candidates, path, name, "position")
    assert pair is not None  # _pair raises when it has no position to name
    px, py = pair
    stamp = fields["timestamp"].astype(np.float64)
    if "timestamp_sample" in fields:
        sample = fields["timestamp_sample"]
        stamp = np.where(sample > 0, sample.astype(np.float64), stamp)
    stamp = stamp * 1e-6 + sources.time_offset
    position = ned_to_enu(np.stack([fields[px], fields[py]], axis=1).astype(np.float64))
    ok = np.ones(len(stamp), dtype=bool)
    for flag, good, cause, detail in _validity(fields):
        bad = ok & (fields[flag] != good)
        if bad.any():
            skip(counts, cause, f"{detail} on {topic}", int(bad.sum()))
        ok &= ~bad
    velocity, has_velocity = _velocity(fields, path, name)
    for i in np.flatnonzero(ok):
        yield Navigation(topic, uav, float(stamp[i]), (float(position[i, 0]), float(position[i, 1])),
                         (float(velocity[i, 0]), float(velocity[i, 1])) if has_velocity[i] else None)


def _validity(fields: dict) -> list[tuple[str, int, str, str]]:
    """The flags a message's position must carry: (field, value it must have, why: its cause and detail)."""
    out = [("xy_valid", 1, "xy_valid false", "")] if "xy_valid" in fields else []
    if "pose_frame" in fields:  # VehicleOdometry since PX4 v1.14: POSE_FRAME_NED = 1
        out.append(("pose_frame", 1, "pose_frame not NED", " (1)"))
    elif "local_frame" in fields:  # before: LOCAL_FRAME_NED = 0
        out.append(("local_frame", 0, "local_frame not NED", " (0)"))
    return out


def _velocity(fields: dict, path: Path, name: str) -> tuple[np.ndarray, np.ndarray]:
    """The messages' ENU velocities (n, 2) and which are usable."""
    n = len(fields["timestamp"])
    pair = _pair(fields, VELOCITY, path, name, None)
    if pair is None:
        return np.zeros((n, 2)), np.zeros(n, dtype=bool)
    velocity = ned_to_enu(np.stack([fields[pair[0]], fields[pair[1]]], axis=1).astype(np.float64))
    usable = np.isfinite(velocity).all(axis=1)
    if "v_xy_valid" in fields:
        usable &= fields["v_xy_valid"] != 0
    if "velocity_frame" in fields:  # VELOCITY_FRAME_NED = 1 since v1.14, LOCAL_FRAME_NED = 0 before
        usable &= fields["velocity_frame"] == (1 if "pose_frame" in fields else 0)
    return velocity, usable


def _files(paths: list[Path], mapping) -> dict[int, Path]:
    """Each UAV's ULog (its map's ``log``): the file of that name given on the command line, else the map's path
    (resolved against the map file's folder when the map was read from a file)."""
    given = [Path(p) for p in paths]
    if mapping is None:
        if given:
            raise LogError(f"{given[0]}: a ULog needs a map (--map) naming the UAV it is (uavs.N.log) and its "
                           "navigation message (docs/replay.md)")
        return {}
    out, used = {}, set()
    for number, sources in mapping.uavs.items():
        if sources.log is None:
            continue
        log = Path(sources.log)
        same = [p for p in given if p.resolve() == log.resolve()] or [p for p in given if p.name == log.name]
        if len(same) > 1:
            raise LogError(f"uavs.{number}.log: {log.name} matches {len(same)} logs given "
                           f"({', '.join(map(str, same))}); name it by its path")
        path = same[0] if same else log
        if not path.exists():
            raise LogError(f"uavs.{number}.log: {path}: no such file")
        if not accepts(path):
            raise LogError(f"uavs.{number}.log: {path} is not a PX4 ULog file (log: names a UAV's own ULog; a "
                           "bag's or a CSV's UAVs are told by their topics or rows)")
        out[number] = path
        used.update(same)
    for p in given:
        if p not in used:
            raise LogError(f"{p}: no UAV of the map names this ULog (uavs.N.log: {p.name})")
    return out


def messages(paths: list[Path], mapping, counts: dict) -> Iterator[Navigation]:
    """The navigation of every UAV whose map entry names a ULog ``log`` (``paths``: the ULogs given on the command
    line, matched to the map's by path or file name), merged in time-stamp order across files."""
    files = _files(paths, mapping)
    streams = [_navigation(path, number - 1, mapping.uavs[number], counts) for number, path in files.items()]
    return heapq.merge(*streams, key=lambda m: m.stamp)


def stamped(paths: list[Path], scenario, mapping, counts: dict):
    """The ULogs' navigation per pass (:attr:`~swarmtrack.replay.formats.LogFormat.stamped`): of the ULogs given and
    those the map names (``uavs.N.log``); None when there are neither."""
    if not paths and (mapping is None or all(s.log is None for s in mapping.uavs.values())):
        return None
    return lambda counted: messages(paths, mapping, counted)
