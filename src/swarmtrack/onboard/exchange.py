"""What a driver provides for each round of the stack's messages: the :class:`Exchange` protocol.

The stack (:mod:`swarmtrack.onboard.stack`) hands an exchange what it sends and gets back what it receives, and
never learns how the messages travelled. Per estimation step: :meth:`~Exchange.share` (the estimator's outbox, and
the beacon of a control step that starts now, which may travel with it), then, for an estimator with a second round,
:meth:`~Exchange.publish`. Per control step: :meth:`~Exchange.beacons`, and for a controller that plans in sequence
(IB21 Sec. 5.3) :meth:`~Exchange.planned` once it has planned.

Implementations: :class:`~swarmtrack.network.exchange.ChannelExchange` (the simulator's channel, and replay's over
the logged positions), the live agent's messages (:class:`swarmtrack.live.exchange.LiveExchange`) and the warm-up's
echo (:class:`swarmtrack.onboard.warm.Echo`); :mod:`swarmtrack.conformance` has mypy check each against it.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from swarmtrack.network.messages import Inbox, Outbox


@runtime_checkable
class Exchange(Protocol):
    def share(self, t: float, outbox: Outbox, beacon: Outbox | None) -> Inbox:
        """Send the estimation step's ``outbox`` (and ``beacon``, the broadcast of the control step that starts now,
        or None); return the estimator's inbox of the step (with the late parts that arrive now)."""
        ...

    def publish(self, t: float, posteriors: Outbox) -> Inbox | None:
        """Send the step's second message (an estimator's :meth:`publish`, possibly empty); return the posteriors
        received over the links that carried the first (None allowed when ``posteriors`` is empty: the stack
        combines nothing then)."""
        ...

    def beacons(self, t: float, beacon: Outbox) -> Inbox:
        """The control step's beacons received (``beacon``: this stack's own, already sent with the share when the
        control step starts with the estimation step)."""
        ...

    def planned(self, t: float, plans: Outbox) -> None:
        """A controller that plans in sequence has planned: its plans go to the UAVs that plan after it."""
        ...
