"""swarmtrack beside the field's tools: a run as standard ROS 2 messages (:mod:`~swarmtrack.interop.ros`)."""
