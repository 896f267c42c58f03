"""A faulty or hostile member: one UAV whose estimation broadcasts lie (its own filter stays honest).

The liar's information contribution (L24 eq. 6, ``I_j, i_j``) claims the target at its measured position plus
``offset`` (``bias``), or plus a fresh ``N(0, sigma² I)`` displacement each step (``random``), with the confidence
``I_j`` of a true measurement: ``i_j ← i_j + I_j δ``. The channel applies it to what the liar sends, from ``t0`` on.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.network.messages import Outbox


@dataclass(frozen=True)
class Liar:
    uav: int
    mode: str
    offset: tuple[float, float] = (0.0, 0.0)
    sigma: float = 0.0
    t0: float = 0.0
    rng: np.random.Generator | None = None

    def corrupt(self, outbox: Outbox, t: float) -> Outbox:
        """The outbox with the liar's contribution shifted (a copy; the sender's own arrays are not touched)."""
        if t < self.t0 or "info_vector" not in outbox:
            return outbox
        if self.mode == "bias":
            shift = np.asarray(self.offset, dtype=float)
        else:
            assert self.rng is not None, "a noisy liar draws from rng"
            shift = self.sigma * self.rng.standard_normal(2)
        info = outbox["info_vector"].copy()
        info[self.uav] += outbox["info_matrix"][self.uav] @ shift
        return {**outbox, "info_vector": info}
