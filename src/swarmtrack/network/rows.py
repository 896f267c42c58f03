"""Which of the swarm's UAVs an onboard component serves: all of them (the simulator), or a subset (one UAV's own
process in the live runtime).

A component built for the UAVs ``uavs`` (R,) of a swarm of ``n`` holds R rows, row r being UAV ``uavs[r]``'s own
computer, and must produce for those rows exactly what the whole swarm's component produces (bit for bit: the
recorded numbers of a run do not depend on how the swarm's computers are split into processes). Arithmetic done row
by row gives that for free; one thing does not: a 2-D matrix product whose rows are UAVs. numpy hands it to BLAS,
whose kernels (``gemm`` for several rows, ``gemv`` for one) sum in an order that depends on the number of rows, so
a row's product can differ in its last bit between R and N rows. :meth:`Rows.matmul` computes such a product in the
swarm's shape (the other UAVs' rows zero: nothing of theirs is read), where BLAS takes the whole swarm's path.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@functools.lru_cache(maxsize=16)
def everyone(n: int) -> np.ndarray:
    """``0..n-1``, read-only, made once per swarm size (the receivers of a whole swarm's inbox, made every control
    step)."""
    out = np.arange(n)
    out.flags.writeable = False
    return out


def subset_of(uavs, n: int) -> np.ndarray:
    """``uavs`` as a sorted array of distinct 0-based UAVs of a swarm of ``n`` (checked)."""
    out = np.asarray(uavs, dtype=np.int64).reshape(-1)
    if out.size == 0 or (out < 0).any() or (out >= n).any() or (np.diff(out) <= 0).any():
        raise ValueError(f"uavs must be distinct 0-based UAVs of the swarm (0..{n - 1}) in increasing order; "
                         f"got {out.tolist()}")
    return out


@dataclass(frozen=True)
class Rows:
    """The UAVs ``uavs`` (R,), sorted, of a swarm of ``n`` that a component's rows are; ``worlds``: the swarm is a
    batch of that many worlds of ``n / worlds`` UAVs each (:mod:`swarmtrack.sim.batch`), whose products are taken
    as one world's (a world of one UAV multiplies its row alone)."""

    uavs: np.ndarray
    n: int
    worlds: int = 1

    @classmethod
    def of(cls, uavs, n: int) -> Rows:
        return cls(subset_of(uavs, n), int(n))

    @classmethod
    def all(cls, n: int) -> Rows:
        return cls(np.arange(n), int(n))

    @property
    def whole(self) -> bool:
        """Whether these are all the swarm's UAVs (the simulator's build)."""
        return len(self.uavs) == self.n

    def __len__(self) -> int:
        return len(self.uavs)

    def widen(self, a: np.ndarray) -> np.ndarray:
        """``a`` (R, ...) placed at its UAVs' rows of an (N, ...) array of zeros (``a`` itself for the whole swarm); a
        2-D ``a`` whose rows are not contiguous gives rows that are not either (numpy then multiplies it by its own
        loop, as the swarm's)."""
        if self.whole:
            return a
        if a.ndim == 2 and a.strides[-1] != a.itemsize:
            out = np.zeros((self.n, 2 * a.shape[1]), dtype=a.dtype)[:, ::2]
        else:
            out = np.zeros((self.n, *a.shape[1:]), dtype=a.dtype)
        out[self.uavs] = a
        return out

    def matmul(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``a @ b`` for ``a`` (R, k) whose rows are UAVs, each row bit for bit the whole swarm's (module
        docstring): computed in the swarm's shape, with ``a``'s kind of strides (which decides whether numpy calls
        BLAS; one row alone would go to ``gemv`` even where the swarm's rows do not go to BLAS at all)."""
        return self.rowwise(lambda rows: rows @ b, a)

    def rowwise(self, f: Callable[[np.ndarray], np.ndarray], a: np.ndarray) -> np.ndarray:
        """``f(a)`` of a function computed row by row that may take a 2-D product of ``a`` (R, k) (a linear motion
        model's ``x Fᵀ``), each row bit for bit the whole swarm's (as :meth:`matmul`)."""
        if a.ndim != 2:
            return f(a)
        if self.worlds > 1 and self.n == self.worlds and len(a) > 1:  # worlds of one UAV: each row is gemv's
            return np.concatenate([f(a[i:i + 1]) for i in range(len(a))])
        if self.whole:
            return f(a)
        return f(self.widen(a))[self.uavs]
