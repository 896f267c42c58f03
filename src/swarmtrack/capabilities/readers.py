"""The built-in log readers of ``swarmtrack replay`` (:class:`~swarmtrack.replay.formats.LogFormat`).

===========  ===========================================================================================
``run``      a swarmtrack run folder: its recorded navigation and detections, replayed as they were handed
``rosbag``   ROS 1 bags, ROS 2 bags (sqlite3 or MCAP storage), the topics named by a map file
===========  ===========================================================================================
"""

from __future__ import annotations

from swarmtrack import registry
from swarmtrack.replay.formats import LogFormat

registry.register_reader(LogFormat(
    "run", "a swarmtrack run folder (its recording's navigation and detections, as handed)",
    "swarmtrack.replay.run_folder:accepts", "swarmtrack.replay.run_folder:steps", phases=True))
registry.register_reader(LogFormat(
    "rosbag", "ROS 1 bags and ROS 2 bags (sqlite3 or MCAP storage), read with rosbags; topics named by --map",
    "swarmtrack.replay.rosbag:accepts", "swarmtrack.replay.rosbag:steps", needs_map=True))
