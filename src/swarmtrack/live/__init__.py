"""The live swarm (issue 23): every UAV's onboard stack in its own process, talking over Eclipse Zenoh.

:mod:`~swarmtrack.live.wire` the messages and their seal, :mod:`~swarmtrack.live.transport` the middleware,
:mod:`~swarmtrack.live.agent` one UAV's process, :mod:`~swarmtrack.live.world` the truth side, and
:mod:`~swarmtrack.live.launch` the command that starts them. ``docs/live.md`` describes the key space and the
messages.
"""
