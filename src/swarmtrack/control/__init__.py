"""Swarm control laws (flocking, L24 Sec. 2 / L23 Sec. 2).

:mod:`swarmtrack.control.kernels` is the compiled (numba) fast path of :func:`flocking_control`; it is not
imported here, so using the reference does not pay for importing numba. Both take the neighbour links dense
or sparse (:mod:`swarmtrack.network.links`, CSR for large swarms) and give the same numbers either way.
"""

from swarmtrack.control.flocking import (
    VARIANTS,
    FlockingGains,
    FlockingState,
    bump,
    flocking_control,
    inter_agent_distances,
    phi,
    sigma_norm,
)

__all__ = [
    "VARIANTS",
    "FlockingGains",
    "FlockingState",
    "bump",
    "flocking_control",
    "inter_agent_distances",
    "phi",
    "sigma_norm",
]
