"""The truth oracle: an estimator stand-in that hands controllers the *true* target state.

Not onboard code: it lives beside the world and is wired to it by the builder (``controller.follow: truth``), so
that a study can separate control from estimation (flocking on perfect information) while the onboard boundary
stays honest and visible.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from swarmtrack.estimation.base import TargetView


class TruthOracle:
    probes = ()

    def __init__(self, truth: Callable[[], np.ndarray], n_uavs: int):
        self._truth, self.n = truth, n_uavs

    def share(self, t, nav, own) -> dict:
        return {}

    def fuse(self, t, own, inbox) -> None:
        pass

    def view(self) -> TargetView:
        return TargetView(np.broadcast_to(self._truth()[:4], (self.n, 4)).copy())

    def sample(self) -> dict:
        return {}
