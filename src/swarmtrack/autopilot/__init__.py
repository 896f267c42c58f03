"""Flying through an autopilot over MAVLink (pymavlink): the UAV's side (:mod:`~swarmtrack.autopilot.link`, what
``swarmtrack agent --autopilot URL`` talks to PX4 or ArduPilot with), a simulated PX4-like vehicle for tests and
demos (:mod:`~swarmtrack.autopilot.vehicle`), and the frames between the project's ENU and MAVLink's NED
(:mod:`~swarmtrack.autopilot.frames`).

Why pymavlink rather than MAVSDK-Python: the simulated vehicle must speak the autopilot's side of the protocol
(heartbeats, command acknowledgements, streams), which MAVSDK does not offer, and pymavlink is pure Python with no
server process (MAVSDK-Python drives a ``mavsdk_server`` binary over gRPC).
"""
