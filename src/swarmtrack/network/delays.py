"""How many estimation steps a delayed message waits: the channel's rounding of a delay to its steps, which the
scenario's settings read too (a filter's window of late data) without importing the channel."""

from __future__ import annotations

import numpy as np


def delay_steps(seconds, period: float):
    """The estimation steps a message waits (int, or an int array for an array of delays): it arrives at the first
    step at or after its delay ends (a delay of a whole number of steps, to round-off, takes that many)."""
    return np.ceil(np.asarray(seconds, dtype=float) / period - 1e-9).astype(int)
