"""The estimator role: what every onboard estimator offers the simulator, whatever its family.

An estimator object holds the filters of the whole swarm as arrays (row i is UAV i's computer) and is driven by the
engine's step loop (sense → share → deliver → fuse → publish → deliver → combine → record): :meth:`Estimator.share`
predicts and returns what each UAV broadcasts; the channel delivers it; :meth:`Estimator.fuse` updates row i from
UAV i's own detections and its inbox only; an estimator that fuses estimates across UAVs publishes its posteriors
and combines what arrives (a :class:`PublishingEstimator`). Controllers read :meth:`Estimator.view`; the recorder
samples the declared :attr:`Estimator.probes`. Implementations: :mod:`swarmtrack.estimation.information`
(decentralized information filter and the centralized baseline), :mod:`swarmtrack.estimation.multimodel` (W20's
multi-model distributed EKF); registered for scenarios in :mod:`swarmtrack.sim.build`.

An estimator built for R of the swarm's N UAVs (``Context.uavs``: one UAV's own process in the live runtime) holds
their R rows: its inputs are their navigation, their detections (:meth:`Detections.of_uavs`) and an inbox of their
rows of the links with every sender's payloads (:meth:`Inbox.restrict`); its outboxes, samples and view are R rows,
bit for bit the whole swarm's (``tests/sim/test_onboard_subsets.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from swarmtrack.network.messages import Inbox, Outbox
from swarmtrack.sensors.detections import Detections


@dataclass(frozen=True)
class Probe:
    """A recorded quantity: ``name`` and its shape per UAV (``()`` for a scalar)."""

    name: str
    shape: tuple[int, ...] = ()


@dataclass(frozen=True)
class TargetView:
    """What controllers read: each UAV's estimate of the target it follows, ``[x, y, vx, vy]`` (N, 4); where the
    estimate follows a motion model (W20 Ch. 4's T-test winner), that model's name per UAV (N,) and its states
    beyond ``[x, y, vx, vy]`` as ``[ax, ay, ω]`` (N, 3), zero where the model has none (what W20 eq. 5.23 propagates
    the target with); a set-valued estimator's aggregated set per UAV (IB21 eq. 43, :class:`Regions`); a
    multi-target estimator's confirmed tracks."""

    state: np.ndarray
    model: np.ndarray | None = None
    motion: np.ndarray | None = None
    region: Regions | None = None
    #: A multi-target estimator's confirmed tracks per UAV, ``[x, y, vx, vy]`` (N, K, 4), and their labels (N, K),
    #: NaN past each UAV's last (issue 40).
    tracks: np.ndarray | None = None
    track_labels: np.ndarray | None = None

    def of_rows(self, rows) -> TargetView:
        """The view of the UAVs at ``rows`` (their rows of every field)."""
        pick = [None if a is None else a[rows] for a in (self.model, self.motion, self.tracks, self.track_labels)]
        region = None if self.region is None else Regions(self.region.sets[rows], self.region.grid)
        return TargetView(self.state[rows], pick[0], pick[1], region, pick[2], pick[3])


@dataclass(frozen=True)
class Regions:
    """Each UAV's aggregated set X^A (IB21 eq. 43), ``sets`` (N,), as the run's set backend holds them
    (:mod:`swarmtrack.estimation.set_backends`): shapely geometries (``grid`` None) or raster fields on ``grid``
    (:class:`~swarmtrack.estimation.raster.Field`, :class:`~swarmtrack.estimation.raster.Grid`)."""

    sets: np.ndarray
    grid: object | None = None


class Estimator(Protocol):
    @property
    def probes(self) -> tuple[Probe, ...]:
        """What the recorder samples (read only: an implementation's tuple of any length, or a property)."""

    def share(self, t: float, nav: np.ndarray, own: Detections) -> Outbox:
        """Predict to ``t`` and return what each UAV broadcasts this step."""

    def fuse(self, t: float, own: Detections, inbox: Inbox) -> None:
        """Update every UAV's estimate from its own detections and what its links delivered."""

    def view(self) -> TargetView:
        """The estimates controllers follow."""

    def sample(self) -> dict[str, np.ndarray]:
        """The current value of every probe, (N, *shape) each."""


class PublishingEstimator(Estimator, Protocol):
    """An estimator with a second round after the update: the stack finds :meth:`publish` on the estimator (one
    without it has no second round), delivers it over the step's links and hands what arrived to :meth:`combine`."""

    def publish(self, t: float) -> Outbox:
        """A second broadcast after the update (e.g. posteriors, for fusion across models; W20 Sec. 4.3.4), or
        ``{}``; the engine delivers it over this step's links."""

    def combine(self, t: float, inbox: Inbox) -> None:
        """Fuse what :meth:`publish` delivered into each UAV's output (called only when it published)."""
