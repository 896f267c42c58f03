"""The ``steps`` of the time-stamped readers (each registers ``stamped``; built in: ``rosbag``, ``ulog``, ``csv``): one
flight from any mix of their logs.

A flight is often logged in pieces: one PX4 ULog per UAV for its navigation, and a ROS bag or a CSV file of the
detections and the ground truth. :func:`steps` sorts the logs given by the reader that recognises each one (a bag:
:mod:`~swarmtrack.replay.rosbag`, a ``.ulg``: :mod:`~swarmtrack.replay.ulog`, a ``.csv``:
:mod:`~swarmtrack.replay.csv_log`), adds the ULogs the map names by ``log`` (:mod:`~swarmtrack.replay.mapping`),
merges their messages by time stamp and places them on the estimation grid (:func:`~swarmtrack.replay.grid.on_grid`,
which also takes the disorder a merge of unevenly stamped logs leaves, within the map's ``window``).

The map's topics are read from the bags; without a bag among the logs they are not read (a CSV's rows say what they
are). A UAV whose map entry names a ULog ``log`` has its navigation from that file only: the bags' and CSVs' other
navigation of it is not read (a bag) or skipped and counted (a CSV).
"""

from __future__ import annotations

import heapq
from pathlib import Path

from swarmtrack import registry
from swarmtrack.replay.grid import MAX_GAP, TRUTH_GAP, WINDOW, on_grid, plan
from swarmtrack.replay.steps import LogError, Planned


def readers() -> dict:
    """The registered time-stamped readers (:attr:`~swarmtrack.replay.formats.LogFormat.stamped`), by name."""
    return {name: f for name, f in registry.kinds(registry.READER).items() if f.stamped is not None}


def group(paths) -> dict[str, list[Path]]:
    """``paths`` by the time-stamped reader that recognises each one (the first by name); a log none recognises is
    refused naming it."""
    known = readers()
    out: dict[str, list[Path]] = {name: [] for name in known}
    for path in map(Path, paths):
        if not path.exists():
            raise LogError(f"{path}: no such file or folder")
        name = next((n for n, reader in known.items() if reader.recognises(path)), None)
        if name is None:
            files = [reader.files for reader in known.values()]
            raise LogError(f"{path}: not {', '.join(files[:-1])} or {files[-1]}")
        out[name].append(path)
    return out


def steps(paths, scenario, mapping, counts: dict) -> Planned:
    """The estimation steps of the logs ``paths`` (any mix of the time-stamped readers' logs: bags, ULogs, CSVs) for
    ``scenario``, ``mapping`` the map file (None: CSVs alone); ``counts`` gets what was skipped (a
    :class:`~swarmtrack.replay.formats.LogFormat`'s ``steps``). The logs are read twice: once for their stamps
    (:func:`~swarmtrack.replay.grid.plan`: t = 0, the number of steps, the gaps; its skips are not counted), then
    for the replay (a reader may read its logs once and give them twice: CSVs are kept whole). Messages of equal
    stamps are merged in the readers' name order."""
    logs = group(paths)
    passes = [p for p in (registry.resolve(f.stamped)(logs[name], scenario, mapping, counts)
                          for name, f in readers().items()) if p is not None]

    def merged(counted: dict):
        return heapq.merge(*(p(counted) for p in passes), key=lambda m: m.stamp)

    window = WINDOW if mapping is None else mapping.window
    max_gap = MAX_GAP if mapping is None else mapping.max_gap
    truth_gap = TRUTH_GAP if mapping is None else mapping.truth_gap
    dt = 1.0 / scenario.rates.estimation
    on_grid((), scenario, {}, window)  # the scenario checked before the logs are read
    start, n = plan(merged({}), dt, window, max_gap, ", ".join(map(str, paths)))
    grid = on_grid(merged(counts), scenario, counts, window, start, n, truth_gap)
    return Planned(grid, n)
