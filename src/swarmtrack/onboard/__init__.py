"""The UAV's stack and nothing else: what runs on each UAV's own computer, whichever driver runs it.

* :mod:`~swarmtrack.onboard.context` — the context a builder gets (built in one place, with the clock) and the clock.
* :mod:`~swarmtrack.onboard.stack` — the stack (estimator, controller, what the controller follows) and its two
  steps, the only calls of share, fuse, publish, combine, broadcast and command.
* :mod:`~swarmtrack.onboard.exchange` — the :class:`~swarmtrack.onboard.exchange.Exchange` protocol: what a driver
  provides for each round of messages, given the stack's outbox, returning its inbox.

The drivers: the simulator (:mod:`swarmtrack.sim.engine`, with the simulated channel), replay
(:mod:`swarmtrack.replay.engine`, the channel over the logged positions) and the live agent
(:mod:`swarmtrack.live.agent`, messages over Zenoh): each provides an exchange and keeps its own part (truth, a
log, a network).
"""
