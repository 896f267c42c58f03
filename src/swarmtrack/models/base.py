"""The motion-model role: what an estimator needs to predict a target's state.

Every model works on arrays with leading batch axes: ``f`` maps states ``(..., n)`` to ``(..., n)`` and
``jacobian`` maps them to ``(..., n, n)``. The first four states of every model are ``[x, y, vx, vy]``
(planar position and velocity), so estimators, metrics and controllers read them the same way whatever
the model.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

POSITION = slice(0, 2)
VELOCITY = slice(2, 4)


@dataclass(frozen=True)
class MotionModel:
    """A discrete-time target motion model ``x(k+1) = f(x(k)) + w(k)``, ``w ~ N(0, Q)``.

    Subclasses implement :meth:`f` and :meth:`jacobian`; ``dt`` is the estimation period in seconds.
    """

    dt: float
    Q: np.ndarray = field(repr=False)

    name: str = "base"
    state_names: tuple[str, ...] = ()
    linear: bool = False

    @property
    def dim(self) -> int:
        return len(self.state_names)

    def f(self, x: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def jacobian(self, x: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    #: Prior standard deviation of the states after ``[x, y, vx, vy]`` (turn rate, attitude, thrust...).
    #: The kinematic states start with near-zero information as in L24 Sec. 3.1; a hidden state with no
    #: information at all lets the first, poorly conditioned updates throw it into a spurious mode (a CT
    #: turn rate aliased to ~2π/T, an FS pitch past 90°), from which a filter with few measurements does
    #: not recover. The values are ours; the papers do not give them.
    hidden_prior_std: tuple[float, ...] = ()

    def initial_state(self) -> np.ndarray:
        """Mean used with the near-zero initial information (no prior knowledge of the target)."""
        return np.zeros(self.dim)

    def initial_information_diagonal(self, information: float) -> np.ndarray:
        """Diagonal of the initial information: ``information`` for the kinematic states and
        ``1/σ²`` (:attr:`hidden_prior_std`) for the hidden ones."""
        diag = np.full(self.dim, float(information))
        if self.hidden_prior_std:
            diag[4:] = 1.0 / np.square(self.hidden_prior_std)
        return diag


@dataclass(frozen=True)
class LinearMotionModel(MotionModel):
    """A linear model ``x(k+1) = F x(k)``: subclasses provide only the constant transition matrix ``F``."""

    linear: bool = True

    @property
    def F(self) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def f(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        return x @ self.F.T

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """The constant ``F``, broadcast (as a writable copy) to the batch shape of ``x``."""
        x = np.asarray(x, dtype=float)
        n = self.dim
        return np.array(np.broadcast_to(self.F, x.shape[:-1] + (n, n)))
