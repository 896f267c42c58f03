"""The truth oracle: an estimator stand-in that hands controllers the *true* target state.

Not onboard code: it lives beside the world and is wired to it by the builder (``controller.follow: truth``), so
that a study can separate control from estimation (flocking on perfect information) while the onboard boundary
stays honest and visible.

It is W20's "perfect version of the MMDEKF" (Sec. 5.4.4.3): it also knows which motion model (CV, CA or CT)
describes the target now and that model's extra states, from the profile the target flies. A UAV that is blind
(an occluder hides the target from it) keeps its last perfect estimate and model and predicts with them, as a
filter without measurements would ("only the UAV's last estimate and model chosen can be used", W20 Sec. 5.4.4.3).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from swarmtrack.estimation.base import TargetView
from swarmtrack.models.kinematic import kinematic_motion

#: Below this acceleration (m/s²) the target moves at constant velocity; an acceleration within this cosine of
#: the normal to the velocity is a turn.
_STILL, _NORMAL = 1e-9, 1e-6


def kinematic_model(velocity: np.ndarray, acceleration: np.ndarray) -> tuple[str, np.ndarray]:
    """The model that describes motion with this velocity and acceleration exactly, and its ``[ax, ay, ω]``:
    CV without acceleration; CT (``ω = (v × a)/|v|²``) with an acceleration normal to the velocity; CA otherwise."""
    speed2 = float(velocity @ velocity)
    a2 = float(acceleration @ acceleration)
    if a2 < _STILL ** 2:
        return "cv", np.zeros(3)
    if speed2 > 0 and abs(velocity @ acceleration) <= _NORMAL * np.sqrt(speed2 * a2):
        omega = (velocity[0] * acceleration[1] - velocity[1] * acceleration[0]) / speed2
        return "ct", np.array([0.0, 0.0, omega])
    return "ca", np.array([acceleration[0], acceleration[1], 0.0])


class TruthOracle:
    """``truth()``: the followed target's ``[x, y, vx, vy]``; ``kinematics()``: its commanded velocity and
    acceleration (2,) each, or None (no model knowledge); ``blind()``: (N,) the UAVs that cannot see it now, or None;
    ``now()``: the time."""

    probes = ()

    def __init__(self, truth: Callable[[], np.ndarray], n_uavs: int, *,
                 kinematics: Callable[[], tuple[np.ndarray, np.ndarray]] | None = None,
                 blind: Callable[[], np.ndarray] | None = None, now: Callable[[], float] | None = None):
        self._truth, self.n = truth, n_uavs
        self._kinematics, self._blind, self._now = kinematics, blind, now
        self._held: list | None = None  # per UAV: (t, state, model, motion) of its last sight

    def share(self, t, nav, own) -> dict:
        return {}

    def fuse(self, t, own, inbox) -> None:
        pass

    def view(self) -> TargetView:
        x = np.asarray(self._truth()[:4], dtype=float)
        known = self._kinematics is not None
        model, motion = kinematic_model(*self._kinematics()) if self._kinematics is not None else ("cv", np.zeros(3))
        state = np.broadcast_to(x, (self.n, 4)).copy()
        models = np.full(self.n, model, dtype=object)
        motions = np.broadcast_to(motion, (self.n, 3)).copy()
        t = self._now() if self._now is not None else 0.0
        blind = self._blind() if self._blind is not None else np.zeros(self.n, dtype=bool)
        if self._held is None or not blind.any():
            self._held = [(t, x, model, motion)] * self.n
        else:
            for i in range(self.n):
                if not blind[i]:
                    self._held[i] = (t, x, model, motion)
                    continue
                t0, x0, m0, mo0 = self._held[i]
                state[i], models[i], motions[i] = predict(x0, m0, mo0, t - t0), m0, mo0
        # without kinematics the oracle knows no model (a blind UAV then extrapolates at constant velocity)
        return TargetView(state, models, motions) if known else TargetView(state)

    def sample(self) -> dict:
        return {}


def predict(x: np.ndarray, model: str, motion: np.ndarray, dt: float) -> np.ndarray:
    """``[x, y, vx, vy]`` after ``dt`` s of the model's motion (closed form for any dt)."""
    return kinematic_motion(x[None], model, motion[None], np.array([max(dt, 0.0)]))[0, 0]
