"""Flying through an autopilot over MAVLink (pymavlink): the UAV's side (:mod:`~swarmtrack.autopilot.link`, what
``swarmtrack agent --autopilot URL`` talks to PX4 or ArduPilot with, and :mod:`~swarmtrack.autopilot.authority`: the
operator always wins), a simulated vehicle that answers as PX4 SITL does (:mod:`~swarmtrack.autopilot.vehicle`, with
its commander, flight loops, links, parameters, missions and telemetry streams; :mod:`~swarmtrack.autopilot.solo`
flies one without a world), and the frames between the project's ENU and MAVLink's NED
(:mod:`~swarmtrack.autopilot.frames`).

Why pymavlink: the simulated vehicle must answer each message as PX4's own modules do (heartbeats, acknowledgements,
streams, the parameter and mission protocols), which needs MAVLink's codec and nothing above it; pymavlink is pure
Python with no native component. MAVSDK-Python (4.x, a native binding of MAVSDK's C++ library) is the client the
tests drive the vehicle with (docs/autopilot.md).
"""
