"""Random streams by purpose: one generator per purpose, derived by *name* from the scenario seed.

``stream(seed, "wind")`` is the same generator whatever other streams a scenario uses, so adding a sensor or a
vehicle group later does not shift the draws of the others (a single generator drawn in call order would).
Purposes used by the simulator: ``spawn`` (initial positions), ``wind/<group>/<member>`` (the gusts on each driven
vehicle), ``navigation`` (each UAV's own navigation error; ``navigation/altitude`` its height's, in a 3-D world),
``sensor/<kind>/<group>/<member>`` (the noise of the detections of each sensed object), ``channel`` (message loss).
"""

from __future__ import annotations

import zlib

import numpy as np


def stream(seed: int, purpose: str) -> np.random.Generator:
    """The generator of ``purpose`` for ``seed``: a :class:`numpy.random.SeedSequence` of the seed whose spawn
    key is the CRC-32 of the purpose's name (stable across Python runs, unlike ``hash``)."""
    key = zlib.crc32(purpose.encode("utf-8"))
    return np.random.default_rng(np.random.SeedSequence(entropy=seed, spawn_key=(key,)))
