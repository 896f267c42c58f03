"""The communication network: who hears whom (topologies) and what arrives (channel)."""

from swarmtrack.network.channel import Channel
from swarmtrack.network.topology import TOPOLOGIES, adjacency

__all__ = ["Channel", "TOPOLOGIES", "adjacency"]
