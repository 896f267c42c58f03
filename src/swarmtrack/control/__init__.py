"""Swarm control laws (flocking, L24 Sec. 2 / L23 Sec. 2)."""

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
