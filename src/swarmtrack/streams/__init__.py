"""A run as it goes, for the tools of the field: each recorded step as a :class:`~swarmtrack.streams.frame.StepFrame`
handed to taps (ROS 2 topics, the Foxglove live view), which never change what is recorded."""
