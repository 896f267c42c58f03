"""Per-neighbour delivery (issue 41): the world's radio names each UAV's receivers, the UAV addresses its messages to
them alone (``.../uav/<i>/<channel>/<j>``, sealed per key), and a UAV takes only what is addressed to it. In one
process, with transports that keep what is put; that a live run still records what ``swarmtrack run`` records bit for
bit is ``test_lockstep.py``'s."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from swarmtrack.live import wire
from swarmtrack.live.exchange import LiveExchange
from swarmtrack.live.node import Node
from swarmtrack.live.transport import key, parse
from swarmtrack.live.world import LockstepWorld
from swarmtrack.network.channel import Channel

from .test_realtime import Held

KEY = bytes(range(32))
RUN = b"r" * 16


def _node(me: int, n: int = 4) -> Node:
    return Node(Held(), wire.Seal(KEY, n, run=RUN), "s", me)


@pytest.mark.parametrize("topology", ["line", "ring", "full", "proximity"])
def test_each_uavs_receivers_are_the_uavs_whose_radio_names_it(topology):
    """The world's ``to`` is the transpose of the radio's ``heard`` (the senders each UAV hears), losses and lost UAVs
    included; with all-to-all delivery there is none."""
    n, rng = 6, np.random.default_rng(3)
    channel = Channel(topology, n, r_comm=4.8, loss_probability=0.3, rng=rng)
    positions = rng.uniform(-5, 5, (n, 2))
    world = SimpleNamespace(n=n, alive={0, 1, 2, 4, 5}, all_to_all=False)  # UAV 3 lost
    heard = LockstepWorld._heard(world, channel.links(positions))
    to = LockstepWorld._receivers(world, heard)
    assert all(3 not in senders for senders in heard)
    for i in range(n):
        assert to[i] == [j for j in range(n) if i in heard[j]]
        assert i not in to[i]
    assert LockstepWorld._receivers(SimpleNamespace(n=n, all_to_all=True), heard) is None
    assert LockstepWorld._receivers(world, None) is None


def test_a_uav_addresses_each_message_to_the_uavs_that_hear_it():
    """Its share goes to the receivers of its estimation message and of its beacon (the beacon travels with it), its
    second broadcast to the former, its plans to the higher-indexed of the latter, a beacon between estimation steps
    to the latter: one put per receiver, one body, a tag per key. Without ``to`` (the field, all-to-all), on its own
    key."""
    node = _node(1)
    exchange = LiveExchange(node, 1, 4, 0)
    radio = wire.Radio(parts=[(0, [])], links=[], beacons=[], to=[2], beacon_to=[0, 3])
    exchange.at(0, 0, radio, None, 0.05, None)
    outbox = {"info_vector": np.ones((1, 2))}
    exchange.share(0.0, outbox, {"position": np.zeros((1, 2))})
    exchange.publish(0.0, {})
    exchange.planned(0.0, {"plan": np.zeros((1, 3))})
    exchange.at(0, 1, wire.Radio(beacon_to=[2]), None, 0.05, None)
    exchange.beacons(0.01, {"position": np.zeros((1, 2))})
    sent = node.transport.sent
    assert [k for k, _ in sent] == [key("s", "uav", 1, "share", 0), key("s", "uav", 1, "share", 2),
                                    key("s", "uav", 1, "share", 3), key("s", "uav", 1, "publish", 2),
                                    key("s", "uav", 1, "plan", 3), key("s", "uav", 1, "beacon", 2)]
    shares = [data for k, data in sent if "/share/" in k]
    assert len({data[wire.TAG_BYTES:] for data in shares}) == 1  # one body
    assert len({data[:wire.TAG_BYTES] for data in shares}) == 3  # a tag per key
    assert parse("s", sent[0][0]) == ("uav", "1", "share", "0")

    node.transport.sent.clear()
    exchange.at(1, 0, wire.Radio(parts=[(1, [])]), None, 0.05, None)  # no receivers named: whoever listens
    exchange.share(0.05, outbox, None)
    assert [k for k, _ in node.transport.sent] == [key("s", "uav", 1, "share")]
    node.transport.sent.clear()
    exchange.at(2, 0, wire.Radio(parts=[(2, [])], to=[], beacon_to=[]), None, 0.05, None)  # nobody hears it
    exchange.share(0.1, outbox, {"position": np.zeros((1, 2))})
    assert node.transport.sent == []


def test_a_uav_takes_what_is_addressed_to_it_alone_and_a_message_moved_to_another_key_is_forged():
    sender = _node(1)
    sender.send(1, wire.Share(k=0, payloads={}), [2])
    (to_2, data), = sender.transport.sent
    receiver, other = _node(2), _node(0)
    receiver._arrive(to_2, data)
    assert receiver.peek("share", 1, 0) is not None and not receiver.seal.rejected
    other._arrive(to_2, data)  # not its key (a subscription wider than its own): not taken, not counted
    assert other.peek("share", 1, 0) is None and not other.seal.rejected
    other._arrive(key("s", "uav", 1, "share", 0), data)  # moved to UAV 0's key: the tag covers the receiver
    assert other.peek("share", 1, 0) is None and other.seal.rejected == {"forged": 1}
    receiver._arrive(to_2, data)  # again: a replay
    assert receiver.seal.rejected == {"replayed": 1}
