"""The live swarm's messages: payloads cross the wire bit for bit, and a sealed message from outside the swarm,
replayed, from a sender the swarm does not have, or that does not decode is dropped and counted, never raised."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from swarmtrack.estimation.raster_field import Field
from swarmtrack.live import wire


def test_payloads_cross_the_wire_bit_for_bit():
    rng = np.random.default_rng(3)
    sets = np.empty(3, dtype=object)
    sets[:] = [shapely.buffer(shapely.Point(rng.random(2)), 1.0 + rng.random()), shapely.Polygon(), None]
    field = Field(3, -2, rng.random((4, 5)), (4, -1, 6, 2))
    payload = {"info": rng.standard_normal((1, 4, 4)), "seen": np.array([True]), "ids": np.arange(3),
               "sets": sets, "field": field, "nested": [1.5, None, {"a": np.float32(2.5)}]}
    back = wire.unpack(wire.pack(payload))
    assert np.array_equal(back["info"], payload["info"]) and back["info"].dtype == np.float64
    assert back["seen"].dtype == bool and back["ids"].dtype == payload["ids"].dtype
    assert bool(shapely.equals_identical(back["sets"][0], sets[0])) and back["sets"][1].is_empty
    assert back["sets"][2] is None
    assert (back["field"].i0, back["field"].j0, back["field"].core) == (3, -2, (4, -1, 6, 2))
    assert np.array_equal(back["field"].data, field.data)
    assert back["nested"][2]["a"] == 2.5


def _sealed(seal: wire.Seal, key_expr: str, sender: int, k: int = 0) -> bytes:
    return seal.seal(key_expr, wire.Share(sender=sender, k=k, payloads={"x": wire.pack(np.ones((1, 2)))}))


def test_only_the_swarms_fresh_messages_are_accepted():
    key, other = wire.keygen(), wire.keygen()
    sender, receiver = wire.Seal(key, 3), wire.Seal(key, 3)
    k = "swarmtrack/s/uav/1/share"
    first = _sealed(sender, k, 1)
    assert receiver.open(k, first).sender == 1
    rejected = {
        "replayed": first,  # the same message again
        "forged": _sealed(wire.Seal(other, 3), k, 1),  # another swarm's key
        "unknown_sender": _sealed(wire.Seal(key, 9), k, 7),  # a UAV the swarm does not have
        "undecodable": sender._tag(k, b"\x93garbage") + b"\x93garbage",
    }
    for cause, data in rejected.items():
        with pytest.raises(wire.Rejected) as exc:
            receiver.open(k, data)
        assert exc.value.cause == cause
    tampered = bytearray(_sealed(sender, k, 1))
    tampered[-1] ^= 1
    with pytest.raises(wire.Rejected, match="forged"):
        receiver.open(k, bytes(tampered))
    assert receiver.open(k, _sealed(sender, k, 1, k=2)).k == 2  # a fresh one still passes
    assert receiver.rejected == {"replayed": 1, "forged": 2, "unknown_sender": 1, "undecodable": 1}


def test_a_message_sealed_for_one_key_expression_does_not_open_on_another():
    key = wire.keygen()
    data = _sealed(wire.Seal(key, 3), "swarmtrack/s/uav/1/share", 1)
    with pytest.raises(wire.Rejected, match="forged"):
        wire.Seal(key, 3).open("swarmtrack/s/uav/2/share", data)
