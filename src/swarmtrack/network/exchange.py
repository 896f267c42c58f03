"""The simulated radio as an :class:`~swarmtrack.onboard.exchange.Exchange`: the simulator's channel, and replay's
over the logged positions.

:meth:`ChannelExchange.at` gives the UAVs' positions (the world's truth, or a log's); the
estimation round draws the step's links (:meth:`~swarmtrack.network.channel.Channel.links`) and delivers the outbox
over them (with the late parts a channel with delays delivers now), the second round travels over the same links,
and a control step's beacons over the beacon links drawn at its time. A beacon sent with the share is delivered at
the control step, as it is broadcast in the simulator: the draws of the channel's streams come in one order for every
driver.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from swarmtrack.network.channel import Channel
from swarmtrack.network.faults import Liar
from swarmtrack.network.links import Links
from swarmtrack.network.messages import Inbox, Outbox
from swarmtrack.sim.streams import stream

if TYPE_CHECKING:
    from swarmtrack.scenarios.schema import Scenario


def channel_of(scenario: Scenario, dt: float) -> Channel:
    """The scenario's channel (its ``network`` section, 0-based UAVs; losses, delays and a liar's noise each from
    their own stream of its seed), stepped every ``dt`` s (the clock's estimation step)."""
    net, seed = scenario.network, scenario.seed
    liar = None if net.liar is None else Liar(net.liar.uav - 1, net.liar.mode, net.liar.offset, net.liar.sigma,
                                              net.liar.start, stream(seed, "liar"))
    return Channel(net.topology, scenario.swarm.n_uavs, net.r_comm, tuple((a - 1, b - 1) for a, b in net.edges),
                   net.loss_probability, stream(seed, "channel"),
                   outages=tuple((tuple(u - 1 for u in o.uavs), o.window) for o in net.outages),
                   delay=net.delay, delay_max=net.delay_bound(), dt=dt,
                   delay_rng=stream(seed, "channel/delay"), liar=liar)


class ChannelExchange:
    """The swarm's messages over ``channel``."""

    def __init__(self, channel: Channel):
        self.channel = channel
        self.positions: np.ndarray | None = None
        self.links: Links | None = None  # those of the last share (the second message travels over them)

    def at(self, positions: np.ndarray) -> ChannelExchange:
        """The UAVs' planar ``positions`` (N, 2) now: the radio's geometry of the next round."""
        self.positions = positions
        return self

    def share(self, t: float, outbox: Outbox, beacon: Outbox | None) -> Inbox:
        assert self.positions is not None, "at() sets the positions first"
        self.links = self.channel.links(self.positions, t)
        return self.channel.deliver(self.links, outbox, t)

    def publish(self, t: float, posteriors: Outbox) -> Inbox:
        assert self.links is not None, "share() comes first"
        return Inbox(self.links, posteriors)  # the second message travels over the links that carried the first

    def beacons(self, t: float, beacon: Outbox) -> Inbox:
        assert self.positions is not None, "at() sets the positions first"
        return Inbox(self.channel.beacon_links(self.positions, t), beacon)

    def planned(self, t: float, plans: Outbox) -> None:
        """The swarm's planner hears its UAVs' plans in the same call (IB21 Sec. 5.3): nothing travels."""
