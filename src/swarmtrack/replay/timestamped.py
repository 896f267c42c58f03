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
from pathlib import Path

from swarmtrack.replay import csv_log, rosbag, ulog
from swarmtrack.replay.grid import MAX_GAP, TRUTH_GAP, WINDOW, on_grid, plan
from swarmtrack.replay.steps import LogError, Planned

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


def steps(paths, scenario, mapping, counts: dict) -> Planned:
    """The estimation steps of the logs ``paths`` (any mix of bags, ULogs and CSVs) for ``scenario``, ``mapping``
    the map file (None: CSVs alone); ``counts`` gets what was skipped (a :class:`~swarmtrack.replay.formats.LogFormat`'s
    ``steps``). The logs are read twice: once for their stamps (:func:`~swarmtrack.replay.grid.plan`: t = 0, the
    number of steps, the gaps; its skips are not counted), then for the replay; CSVs are read once, kept whole."""
    logs = group(paths)
    if logs["rosbag"] and mapping is None:
        raise LogError(f"{logs['rosbag'][0]}: a ROS bag needs a map (--map) naming its topics (docs/replay.md)")
    table = csv_log.read(logs["csv"], mapping, counts, scenario.swarm.n_uavs) if logs["csv"] else None

    def merged(counted: dict):
        streams = []
        if logs["rosbag"]:
            streams.append(rosbag.messages(logs["rosbag"], mapping, counted))
        if logs["ulog"] or (mapping is not None and any(s.log is not None for s in mapping.uavs.values())):
            streams.append(ulog.messages(logs["ulog"], mapping, counted))
        if table is not None:
            streams.append(iter(table))
        return heapq.merge(*streams, key=lambda m: m.stamp)

    window = WINDOW if mapping is None else mapping.window
    max_gap = MAX_GAP if mapping is None else mapping.max_gap
    truth_gap = TRUTH_GAP if mapping is None else mapping.truth_gap
    dt = 1.0 / scenario.rates.estimation
    on_grid((), scenario, {}, window)  # the scenario checked before the logs are read
    start, n = plan(merged({}), dt, window, max_gap, ", ".join(map(str, paths)))
    grid = on_grid(merged(counts), scenario, counts, window, start, n, truth_gap)
    return Planned(grid, n)
