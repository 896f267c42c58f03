"""The communication network: who hears whom (links, topologies) and what arrives (channel)."""

from swarmtrack.network.channel import Channel
from swarmtrack.network.links import (
    SPARSE_MIN_UAVS,
    TOPOLOGIES,
    drop,
    edge_list,
    is_sparse,
    n_links,
    neighbour_lists,
    neighbour_sum,
    proximity_links,
    static_links,
    to_dense,
)
from swarmtrack.network.topology import adjacency

__all__ = [
    "Channel",
    "SPARSE_MIN_UAVS",
    "TOPOLOGIES",
    "adjacency",
    "drop",
    "edge_list",
    "is_sparse",
    "n_links",
    "neighbour_lists",
    "neighbour_sum",
    "proximity_links",
    "static_links",
    "to_dense",
]
