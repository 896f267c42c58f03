"""What crosses the network: an outbox of payloads per UAV, and the inbox the channel delivers.

An outbox is a plain mapping ``name → array (N, ...)``: row ``j`` is what UAV ``j`` broadcasts this step.
The :class:`Inbox` pairs it with the links that carried it this step; UAV ``i`` reads sender ``j``'s payload only
where ``links[i, j]`` (a dense boolean array for small swarms, a sparse CSR matrix for large ones), so a
summable payload (information contributions, L24 eq. 7) is delivered as one (sparse) matrix product.

A channel with delays also delivers messages sent at earlier steps: each send step's payloads with the links that
deliver them now is one more :class:`Inbox` in ``late`` (:meth:`Inbox.parts`). Payloads carry the time their data
was taken (``taken``, per sender) where the estimator stamps them; one that ignores stamps fuses every part as if
current (:meth:`Inbox.sum`).

An inbox may be a subset's (one UAV's own process, :meth:`Inbox.restrict`): its links are the rows of its
``receivers`` (R,), the swarm's UAVs it is for, over every sender, and it keeps every sender's payloads; a receiver
reads its own row of a payload as ``payloads[name][receivers]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.network.links import Links, edge_list, neighbour_sum, neighbour_sums, rows_of
from swarmtrack.network.rows import everyone, subset_of

Outbox = dict[str, np.ndarray]


@dataclass(frozen=True)
class Inbox:
    links: Links
    payloads: Outbox
    #: Messages sent at earlier steps that arrive now, one inbox per send step (a channel with delays).
    late: tuple[Inbox, ...] = ()
    #: The swarm's UAVs the rows of ``links`` are (R,), sorted; default: every UAV (square links).
    # None: every UAV (__post_init__ replaces it, so the field is always an array after construction)
    receivers: np.ndarray = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        if self.receivers is None:
            object.__setattr__(self, "receivers", everyone(self.links.shape[0]))

    def restrict(self, uavs) -> Inbox:
        """The inbox of the swarm's UAVs ``uavs`` (sorted, distinct) of this whole swarm's inbox: their rows of the
        links (of the late parts too), every sender's payloads."""
        uavs = subset_of(uavs, self.links.shape[1])
        return Inbox(rows_of(self.links, uavs), self.payloads, tuple(part.restrict(uavs) for part in self.late),
                     uavs)

    def parts(self) -> tuple[Inbox, ...]:
        """This step's messages, then the late ones: each part's payloads come from one send step."""
        return (self, *self.late)

    def sum(self, name: str) -> np.ndarray:
        """``Σ_{j: links[i, j]} payload_j`` for every receiver i (L24 eq. 7): a (sparse) matrix product; with late
        parts, their sums too (as if current)."""
        out = neighbour_sum(self.links, self.payloads[name], self.receivers)
        for part in self.late:
            out = out + part.sum(name)
        return out

    def sums(self, first: str, second: str) -> tuple[np.ndarray, np.ndarray]:
        """``(self.sum(first), self.sum(second))``, the same numbers; an inbox without late parts sums both payloads
        in one pass over its links (:func:`~swarmtrack.network.links.neighbour_sums`)."""
        if self.late:
            return self.sum(first), self.sum(second)
        return neighbour_sums(self.links, self.payloads[first], self.payloads[second], self.receivers)

    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        """``(receivers, senders)`` of every link that carried a message, receiver-major; receivers are rows
        (0..R-1), senders the swarm's UAVs."""
        return edge_list(self.links)

    def heard(self, seen: str = "seen") -> tuple[np.ndarray, np.ndarray]:
        """``(receivers, senders)`` of every payload a UAV has this step whose flag ``seen`` is set: its own first
        (row r, sender ``receivers[r]``, as if it had sent to itself), then what its links delivered,
        receiver-major."""
        recv, send = self.edges()
        own = np.arange(len(self.receivers))
        recv, send = np.concatenate([own, recv]), np.concatenate([self.receivers, send])
        keep = self.payloads[seen][send]
        return recv[keep], send[keep]

