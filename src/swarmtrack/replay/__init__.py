"""Replay: the onboard stack of a scenario run on recorded navigation and detections instead of a simulated world.

A log reader (:mod:`swarmtrack.replay.readers`, one registered kind per log format) turns logs into
:class:`~swarmtrack.replay.steps.StepInputs`, one per estimation step; :func:`~swarmtrack.replay.engine.replay`
feeds them to the scenario's estimator, with the messages between UAVs computed by the scenario's channel as the
simulator computes them, and records what the simulator records (``swarmtrack replay``, ``docs/replay.md``).
"""
