"""Swarm control laws: flocking (L24 Sec. 2 / L23 Sec. 2), W20's distributed MPC, IB21's set-membership MPC.

:mod:`swarmtrack.control.kernels` is the compiled (numba) fast path of :func:`flocking_control`. Both take the
neighbour links dense or sparse (:mod:`swarmtrack.network.links`, CSR for large swarms) and give the same numbers
either way. The flocking names below are imported when first used (PEP 562), so that importing a module of this
package (e.g. :mod:`~swarmtrack.control.gains`, which the scenario's settings read) imports no control law.
"""

import importlib

#: The names this package gives, by the module that defines them.
_EXPORTS = {
    "FlockingGains": "swarmtrack.control.gains",
    **dict.fromkeys(("VARIANTS", "FlockingState", "bump", "flocking_control", "inter_agent_distances", "phi",
                     "sigma_norm"), "swarmtrack.control.flocking"),
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(_EXPORTS[name]), name)
