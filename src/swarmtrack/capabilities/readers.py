"""The built-in log readers of ``swarmtrack replay`` (:class:`~swarmtrack.replay.formats.LogFormat`).

===========  ===========================================================================================
``run``      a swarmtrack run folder: its recorded navigation and detections, replayed as they were handed
``rosbag``   ROS 1 bags, ROS 2 bags (sqlite3 or MCAP storage), the topics named by a map file
``ulog``     PX4 ULog files (pyulog), one per UAV, for its navigation (``vehicle_local_position``,
             ``vehicle_odometry``, NED made ENU); the map names each UAV's file and message
``csv``      CSV files with a documented header (``t, uav, kind, x, y`` ...), one row per message; no map needed
===========  ===========================================================================================

The last three are one flight's pieces: each recognises its own files, and any mix of them is read together
(:func:`swarmtrack.replay.timestamped.steps`), e.g. a ULog per UAV for navigation and a bag or a CSV of detections.
"""

from __future__ import annotations

from swarmtrack import registry
from swarmtrack.replay.formats import LogFormat

registry.register_reader(LogFormat(
    "run", "a swarmtrack run folder (its recording's navigation and detections, as handed)",
    "swarmtrack.replay.run_folder:accepts", "swarmtrack.replay.run_folder:steps", phases=True))
_STEPS = "swarmtrack.replay.timestamped:steps"

registry.register_reader(LogFormat(
    "rosbag", "ROS 1 bags and ROS 2 bags (sqlite3 or MCAP storage), read with rosbags; topics named by --map",
    "swarmtrack.replay.rosbag:accepts", _STEPS, needs_map=True, stamped="swarmtrack.replay.rosbag:stamped",
    files="a ROS bag (.bag, .mcap, .db3, a folder with metadata.yaml)", extra=("logs", "rosbags")))
registry.register_reader(LogFormat(
    "ulog", "PX4 ULog files (pyulog), one per UAV, for its navigation; files and messages named by --map",
    "swarmtrack.replay.ulog:accepts", _STEPS, needs_map=True, stamped="swarmtrack.replay.ulog:stamped",
    files="a PX4 ULog (.ulg)", extra=("logs", "pyulog")))
registry.register_reader(LogFormat(
    "csv", "CSV files, one row per message (t, uav, kind, x, y, ...: docs/replay.md); no map needed",
    "swarmtrack.replay.csv_log:accepts", _STEPS, stamped="swarmtrack.replay.csv_log:stamped",
    files="a CSV file (.csv)"))
