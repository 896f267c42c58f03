"""The onboard stack of the swarm: estimator, controller, and what the controller follows; and its two steps.

Row i of every array in an onboard component belongs to UAV i's own computer. Its inputs are only: UAV i's own
navigation solution, UAV i's own detections, and the messages an :class:`~swarmtrack.onboard.exchange.Exchange`
delivered to UAV i. The same components built for one UAV (``Context.uavs``) give its row alone, bit for bit: what
the live runtime runs in each UAV's process. This package and the components it holds (``swarmtrack.estimation``,
``swarmtrack.control``, ``swarmtrack.models``, ``swarmtrack.sensors.detections``) never import
:mod:`swarmtrack.sim.world`; a test checks it in a fresh interpreter.

:meth:`OnboardStack.estimation_step` and :meth:`OnboardStack.control_step` are the only places where share, fuse,
publish, combine, broadcast and command are called, for every driver, in one order: share → broadcast → exchange →
fuse → (publish → exchange → combine); then per control step: (broadcast) → exchange → command. The broadcast of a
control step that starts with the estimation step comes before the fuse: it reads only the navigation and the
controller's own state (a test checks it reads no estimator state), and it may travel with the share.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np

from swarmtrack.control.base import Controller
from swarmtrack.estimation.base import Estimator, PublishingEstimator, TargetView
from swarmtrack.network.messages import Outbox
from swarmtrack.onboard.exchange import Exchange


@dataclass
class OnboardStack:
    """``estimator`` is run and recorded; ``controller`` None: none is run (replay: its commands would fly nothing);
    ``guide`` is what the controller follows: the estimator itself, or an oracle the builder wired to the truth
    (``controller.follow: truth``, a study aid, never onboard)."""

    estimator: Estimator
    controller: Controller | None
    guide: Estimator

    @property
    def components(self) -> tuple:
        return (self.estimator,) if self.controller is None else (self.estimator, self.controller)

    @property
    def probes(self) -> dict[str, tuple[int, ...]]:
        return {p.name: p.shape for c in self.components for p in c.probes}

    def sample(self) -> dict:
        own = self.estimator.sample()
        return own if self.controller is None else {**own, **self.controller.sample()}

    def estimation_step(self, t: float, nav: np.ndarray, detections, exchange: Exchange,
                        control: float | None = None) -> Outbox | None:
        """Estimation step at ``t`` on the UAVs' own navigation ``nav`` and ``detections``: share → (broadcast of
        the control step that starts now, at time ``control``) → ``exchange.share`` → fuse → (publish →
        ``exchange.publish`` → combine). Returns the beacon broadcast (None: no control step starts now)."""
        est = self.estimator
        with np.errstate(over="ignore", invalid="ignore"):  # a diverging filter is reported by fuse()
            outbox = est.share(t, nav, detections)
            beacon = None
            if control is not None:
                assert self.controller is not None, "a control step needs a controller"
                beacon = self.controller.broadcast(control, nav)
            est.fuse(t, detections, exchange.share(t, outbox, beacon))
            publish = getattr(est, "publish", None)  # the optional second round (PublishingEstimator.publish)
            if publish is not None:
                posteriors = publish(t)
                received = exchange.publish(t, posteriors)
                if posteriors:
                    assert received is not None, "an exchange returns the posteriors received when some were sent"
                    cast(PublishingEstimator, est).combine(t, received)
        return beacon

    def control_step(self, t: float, nav: np.ndarray, view: TargetView, exchange: Exchange, dt: float,
                     beacon: Outbox | None = None) -> np.ndarray:
        """Control step at ``t``: broadcast (unless ``beacon``, broadcast with the estimation step, is given) →
        ``exchange.beacons`` → command, following ``view``; a controller that plans in sequence then hands its plans
        to ``exchange.planned``. Returns the command."""
        ctl = self.controller
        assert ctl is not None, "a control step needs a controller"
        if beacon is None:
            beacon = ctl.broadcast(t, nav)
        u = ctl.command(t, nav, view, exchange.beacons(t, beacon), dt)
        plans = getattr(ctl, "plans", None)  # a SequentialPlanner (an isinstance check of a Protocol: 25 µs)
        if plans is not None:
            exchange.planned(t, plans())
        return u
