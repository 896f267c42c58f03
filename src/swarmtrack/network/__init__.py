"""The communication network: who hears whom (links, topologies) and what arrives (channel).

The names below are imported when first used (PEP 562), so that importing a module of this package (e.g.
:mod:`~swarmtrack.network.delays`, which the scenario's settings read) imports neither the links' sparse algebra
(scipy) nor numba.
"""

import importlib

#: The names this package gives, by the module that defines them.
_EXPORTS = {
    "Channel": "swarmtrack.network.channel",
    "adjacency": "swarmtrack.network.topology",
    **dict.fromkeys(("SPARSE_MIN_UAVS", "TOPOLOGIES", "drop", "edge_list", "is_sparse", "n_links", "neighbour_lists",
                     "neighbour_sum", "proximity_links", "static_links", "to_dense"), "swarmtrack.network.links"),
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(_EXPORTS[name]), name)
