"""What crosses the network: an outbox of payloads per UAV, and the inbox the channel delivers.

An outbox is a plain mapping ``name → array (N, ...)``: row ``j`` is what UAV ``j`` broadcasts this step.
The :class:`Inbox` pairs it with the links that carried it this step; UAV ``i`` reads sender ``j``'s payload only
where ``links[i, j]`` (a dense boolean array for small swarms, a sparse CSR matrix for large ones), so a
summable payload (information contributions, L24 eq. 7) is delivered as one (sparse) matrix product.

A channel with delays also delivers messages sent at earlier steps: each send step's payloads with the links that
deliver them now is one more :class:`Inbox` in ``late`` (:meth:`Inbox.parts`). Payloads carry the time their data
was taken (``taken``, per sender) where the estimator stamps them; one that ignores stamps fuses every part as if
current (:meth:`Inbox.sum`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmtrack.network.links import Links, edge_list, neighbour_sum

Outbox = dict[str, np.ndarray]


@dataclass(frozen=True)
class Inbox:
    links: Links
    payloads: Outbox
    #: Messages sent at earlier steps that arrive now, one inbox per send step (a channel with delays).
    late: tuple[Inbox, ...] = ()

    def parts(self) -> tuple[Inbox, ...]:
        """This step's messages, then the late ones: each part's payloads come from one send step."""
        return (self, *self.late)

    def sum(self, name: str) -> np.ndarray:
        """``Σ_{j: links[i, j]} payload_j`` for every receiver i (L24 eq. 7): a (sparse) matrix product; with late
        parts, their sums too (as if current)."""
        out = neighbour_sum(self.links, self.payloads[name])
        for part in self.late:
            out = out + part.sum(name)
        return out

    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        """``(receivers, senders)`` of every link that carried a message, receiver-major."""
        return edge_list(self.links)

    def heard(self, seen: str = "seen") -> tuple[np.ndarray, np.ndarray]:
        """``(receivers, senders)`` of every payload a UAV has this step whose flag ``seen`` is set: its own first
        (``i, i`` for every UAV, as if it had sent to itself), then what its links delivered, receiver-major."""
        recv, send = self.edges()
        own = np.arange(len(self.payloads[seen]))
        recv, send = np.concatenate([own, recv]), np.concatenate([own, send])
        keep = self.payloads[seen][send]
        return recv[keep], send[keep]
