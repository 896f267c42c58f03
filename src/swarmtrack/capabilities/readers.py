"""The built-in log readers of ``swarmtrack replay`` (:class:`~swarmtrack.replay.formats.LogFormat`).

=========  =============================================================================================
``run``    a swarmtrack run folder: its recorded navigation and detections, replayed as they were handed
=========  =============================================================================================
"""

from __future__ import annotations

from swarmtrack import registry
from swarmtrack.replay.formats import LogFormat

registry.register_reader(LogFormat(
    "run", "a swarmtrack run folder (its recording's navigation and detections, as handed)",
    "swarmtrack.replay.run_folder:accepts", "swarmtrack.replay.run_folder:steps"))
