"""The ``steps`` of the time-stamped readers (``rosbag``, ``ulog``, ``csv``): one flight from any mix of their logs.

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
from collections.abc import Iterator
from pathlib import Path

from swarmtrack.replay import csv_log, rosbag, ulog
from swarmtrack.replay.grid import on_grid
from swarmtrack.replay.steps import LogError, StepInputs

#: The time-stamped readers, in the order they are asked whether they recognise a log.
READERS = {"rosbag": rosbag, "ulog": ulog, "csv": csv_log}


def group(paths) -> dict[str, list[Path]]:
    """``paths`` by the reader that recognises each one; a log none recognises is refused naming it."""
    out: dict[str, list[Path]] = {name: [] for name in READERS}
    for path in map(Path, paths):
        if not path.exists():
            raise LogError(f"{path}: no such file or folder")
        name = next((n for n, reader in READERS.items() if reader.accepts(path)), None)
        if name is None:
            raise LogError(f"{path}: not a ROS bag (.bag, .mcap, .db3, a folder with metadata.yaml), a PX4 ULog "
                           "(.ulg) or a CSV file (.csv)")
        out[name].append(path)
    return out


def steps(paths, scenario, mapping, counts: dict) -> Iterator[StepInputs]:
    """The estimation steps of the logs ``paths`` (any mix of bags, ULogs and CSVs) for ``scenario``, ``mapping``
    the map file (None: CSVs alone); ``counts`` gets what was skipped (a :class:`~swarmtrack.replay.formats.LogFormat`'s
    ``steps``)."""
    logs = group(paths)
    streams = []
    if logs["rosbag"]:
        if mapping is None:
            raise LogError(f"{logs['rosbag'][0]}: a ROS bag needs a map (--map) naming its topics (docs/replay.md)")
        streams.append(rosbag.messages(logs["rosbag"], mapping, counts))
    if logs["ulog"] or (mapping is not None and any(s.log is not None for s in mapping.uavs.values())):
        streams.append(ulog.messages(logs["ulog"], mapping, counts))
    if logs["csv"]:
        streams.append(csv_log.messages(logs["csv"], mapping, counts, scenario.swarm.n_uavs))
    window = 1.0 if mapping is None else mapping.window
    return on_grid(heapq.merge(*streams, key=lambda m: m.stamp), scenario, counts, window)
