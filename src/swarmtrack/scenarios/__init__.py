"""Scenarios: the validated schema, the built-in files and the loader."""

from swarmtrack.scenarios.loader import ScenarioError, builtin_names, load_scenario
from swarmtrack.scenarios.schema import Scenario

__all__ = ["Scenario", "ScenarioError", "builtin_names", "load_scenario"]
