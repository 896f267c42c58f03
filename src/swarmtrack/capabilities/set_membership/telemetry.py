"""What the truth-side check of IB21's guarantee (:func:`~swarmtrack.capabilities.set_membership.build.
guarantee_monitor`) reads of a UAV's estimator when the estimator runs in the UAV's own process (the live swarm): its
current sets (eq. 34's X_{i,j}, Xᵁ_i, X̄_i) and the time they describe. Each UAV reports its own rows with its
probes; the truth side puts them into its copy of the estimator, whose ``containing`` and ``current`` the monitor
calls as in the simulator."""

from __future__ import annotations

import numpy as np

from swarmtrack.registry import Telemetry

FIELDS = ("unexplored", "unidentified", "identified", "t")


def report(estimator) -> dict[str, np.ndarray]:
    """The estimator's current sets and their times, its own rows (R, ...)."""
    b = estimator.beliefs
    return {name: getattr(b, name) for name in FIELDS}


def mirror(estimator, reports: dict[str, np.ndarray]) -> None:
    """Put the swarm's reported sets (N, ...) into ``estimator`` (the truth side's copy, never run itself)."""
    b = estimator.beliefs
    for name in FIELDS:
        getattr(b, name)[...] = reports[name]


TELEMETRY = Telemetry(report, mirror)
