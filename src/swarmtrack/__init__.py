"""swarmtrack: cooperative target estimation and tracking by UAV swarms.

Source documents are cited by short name: L24 (Lizzio et al., Drones 2024), L23 (Lizzio et al., EASN 2022),
W20 (Wolfe, M.A.Sc. thesis 2020), IB21 (Ibenthal et al., Automatica 2021).

The public API (``docs/python.md``), imported on first use so that ``import swarmtrack`` stays cheap:

- :func:`load_scenario` — a validated scenario by built-in name or file, with ``key=value`` overrides and a seed;
- :func:`simulate` — run it, giving a :class:`~swarmtrack.sim.recorder.Recording`;
- :func:`summarize` — the metrics of a recording (what ``metrics.json`` holds);
- :func:`load_run` — the recording of a ``swarmtrack run`` folder;
- :func:`replay_logs` — a scenario's estimator on recorded flights (run folders, ROS bags, ULog, CSV), as
  ``swarmtrack replay`` runs it (``docs/replay.md``);
- :func:`register` — add a kind (sensor, estimator, controller) with its settings class (subclassing
  :class:`SensorSpec`, :class:`EstimatorSpec` or :class:`ControllerSpec`) and its builder.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

__version__ = "0.5.0"

#: public name → (the module that defines it, its name there)
_PUBLIC = {
    "load_scenario": ("swarmtrack.scenarios.loader", "load_scenario"),
    "Scenario": ("swarmtrack.scenarios.schema", "Scenario"),
    "ScenarioError": ("swarmtrack.scenarios.loader", "ScenarioError"),
    "simulate": ("swarmtrack.sim.engine", "simulate"),
    "replay_logs": ("swarmtrack.replay.engine", "replay_logs"),
    "Recording": ("swarmtrack.sim.recorder", "Recording"),
    "summarize": ("swarmtrack.analysis.metrics", "summary"),
    "register": ("swarmtrack.registry", "register"),
    "SensorSpec": ("swarmtrack.scenarios.schema", "SensorSpec"),
    "EstimatorSpec": ("swarmtrack.scenarios.schema", "EstimatorSpec"),
    "ControllerSpec": ("swarmtrack.scenarios.schema", "ControllerSpec"),
    "Probe": ("swarmtrack.estimation.base", "Probe"),
    "TargetView": ("swarmtrack.estimation.base", "TargetView"),
}

__all__ = ["ControllerSpec", "EstimatorSpec", "Probe", "Recording", "Scenario", "ScenarioError", "SensorSpec",
           "TargetView", "load_run", "load_scenario", "register", "replay_logs", "simulate", "summarize"]

if TYPE_CHECKING:
    from swarmtrack.analysis.metrics import summary as summarize
    from swarmtrack.estimation.base import Probe, TargetView
    from swarmtrack.registry import register
    from swarmtrack.replay.engine import replay_logs
    from swarmtrack.scenarios.loader import ScenarioError, load_scenario
    from swarmtrack.scenarios.schema import ControllerSpec, EstimatorSpec, Scenario, SensorSpec
    from swarmtrack.sim.engine import simulate
    from swarmtrack.sim.recorder import Recording


def __getattr__(name: str):
    if name in _PUBLIC:
        import importlib

        module, attr = _PUBLIC[name]
        value = getattr(importlib.import_module(module), attr)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'swarmtrack' has no attribute {name!r}")


def load_run(path):
    """The recording of a ``swarmtrack run`` folder (or of its ``recording/`` folder): a
    :class:`~swarmtrack.sim.recorder.Recording`, whose ``frame("uavs")`` / ``frame("objects")`` are pandas views."""
    from pathlib import Path

    from swarmtrack.sim.recorder import Recording

    path = Path(path)
    return Recording.load(path / "recording" if (path / "recording").is_dir() else path)
