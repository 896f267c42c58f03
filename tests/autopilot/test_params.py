"""The simulated vehicle's parameter protocol, as PX4's MavlinkParametersManager answers it: requests encoded by a
pymavlink client, the replies decoded from the bytes the vehicle's MAVLink object wrote."""

from __future__ import annotations

import struct

import pytest
from pymavlink.dialects.v20 import common as mavlink
from tests.autopilot.wire import Wire

from swarmtrack.autopilot.params import HASH_CHECK, INT32, REAL32, TABLE, UINT32, Parameters, decode, encode

SYSTEM, COMPONENT = 2, mavlink.MAV_COMP_ID_AUTOPILOT1


@pytest.fixture
def wire():
    return Wire(SYSTEM)


def _name(v) -> str:
    return v.param_id if isinstance(v.param_id, str) else v.param_id.decode()


def test_defaults_and_types_as_px4_declares_them():
    p = Parameters()
    assert p.get("COM_OF_LOSS_T") == 1.0 and isinstance(p.get("COM_OF_LOSS_T"), float)
    assert p.get("COM_OBL_RC_ACT") == 0 and isinstance(p.get("COM_OBL_RC_ACT"), int)
    assert p.get("MPC_XY_VEL_MAX") == 12.0 and p.get("MIS_TAKEOFF_ALT") == 2.5
    assert p.get("MPC_XY_P") == pytest.approx(0.95, rel=1e-7)  # held as float32, as PX4 holds it
    assert p.get("MPC_XY_P") != 0.95
    types = {q.name: q.type for q in TABLE}
    assert types["COM_OBL_RC_ACT"] == INT32 and types["BAT1_N_CELLS"] == INT32 and types["RTL_RETURN_ALT"] == REAL32
    assert Parameters({"COM_OF_LOSS_T": 0.5}).get("COM_OF_LOSS_T") == 0.5
    with pytest.raises(KeyError):
        p.get("NOT_A_PARAM")


def test_int_values_travel_bytewise():
    assert decode(encode(4, INT32), INT32) == 4
    assert encode(4, INT32) != 4.0  # the bits of int 4 read as a float: a denormal
    assert struct.pack("<f", encode(-7, INT32)) == struct.pack("<i", -7)
    assert decode(encode(0xDEADBEEF, UINT32), UINT32) == 0xDEADBEEF
    assert encode(1.5, REAL32) == 1.5


def test_list_sends_the_hash_then_every_parameter_in_order(wire):
    p = Parameters()
    assert p.handle(wire.received(mavlink.MAVLink_param_request_list_message(SYSTEM, COMPONENT)), wire.mav)
    got = wire.replies()
    assert [m.get_type() for m in got] == ["PARAM_VALUE"] * (len(TABLE) + 1)
    first = got[0]
    assert _name(first) == HASH_CHECK and first.param_index == 65535 and first.param_type == UINT32
    assert decode(first.param_value, UINT32) == p.hash()
    values = got[1:]
    assert [v.param_index for v in values] == list(range(len(TABLE)))
    assert all(v.param_count == len(TABLE) for v in got)
    names = [_name(v) for v in values]
    assert names == sorted(q.name for q in TABLE)
    for v in values:
        assert decode(v.param_value, v.param_type) == pytest.approx(p.get(_name(v)))
    assert all(m.get_srcSystem() == SYSTEM and m.get_srcComponent() == COMPONENT for m in got)


def test_read_by_name_by_index_and_the_unknown_unanswered(wire):
    p = Parameters()
    p.handle(wire.received(mavlink.MAVLink_param_request_read_message(SYSTEM, COMPONENT, b"COM_OBL_RC_ACT", -1)),
             wire.mav)
    (v,) = wire.replies()
    assert _name(v) == "COM_OBL_RC_ACT" and v.param_type == INT32 and decode(v.param_value, INT32) == 0
    p.handle(wire.received(mavlink.MAVLink_param_request_read_message(SYSTEM, COMPONENT, b"", 0)), wire.mav)
    (v,) = wire.replies()
    assert v.param_index == 0 and _name(v) == sorted(q.name for q in TABLE)[0]
    assert p.handle(wire.received(mavlink.MAVLink_param_request_read_message(SYSTEM, COMPONENT, b"NO_SUCH", -1)),
                    wire.mav)
    assert p.handle(wire.received(mavlink.MAVLink_param_request_read_message(SYSTEM, COMPONENT, b"", 999)), wire.mav)
    assert wire.replies() == []  # PX4 answers neither
    p.handle(wire.received(mavlink.MAVLink_param_request_read_message(SYSTEM, COMPONENT, HASH_CHECK.encode(), -1)),
             wire.mav)
    (h,) = wire.replies()
    assert decode(h.param_value, UINT32) == p.hash()


def test_set_a_float_and_an_int_echoes_and_changes_the_value_and_hash(wire):
    p = Parameters()
    before = p.hash()
    p.handle(wire.received(mavlink.MAVLink_param_set_message(SYSTEM, COMPONENT, b"COM_OF_LOSS_T", 2.5, REAL32)),
             wire.mav)
    (v,) = wire.replies()
    assert _name(v) == "COM_OF_LOSS_T" and v.param_value == 2.5 and p.get("COM_OF_LOSS_T") == 2.5
    p.handle(wire.received(mavlink.MAVLink_param_set_message(SYSTEM, mavlink.MAV_COMP_ID_ALL, b"COM_OBL_RC_ACT",
                                                             encode(5, INT32), INT32)), wire.mav)
    (v,) = wire.replies()
    assert decode(v.param_value, INT32) == 5 and p.get("COM_OBL_RC_ACT") == 5
    assert p.hash() != before


def test_set_of_an_unknown_name_or_another_type_is_not_answered_nor_applied(wire):
    p = Parameters()
    assert p.handle(wire.received(mavlink.MAVLink_param_set_message(SYSTEM, COMPONENT, b"COM_OBL_RC_ACT", 5.0,
                                                                    REAL32)), wire.mav)
    assert p.handle(wire.received(mavlink.MAVLink_param_set_message(SYSTEM, COMPONENT, b"MPC_XY_P",
                                                                    encode(3, INT32), INT32)), wire.mav)
    assert p.handle(wire.received(mavlink.MAVLink_param_set_message(SYSTEM, COMPONENT, b"NO_SUCH", 1.0, REAL32)),
                    wire.mav)
    assert p.handle(wire.received(mavlink.MAVLink_param_set_message(SYSTEM, COMPONENT, HASH_CHECK.encode(), 0.0,
                                                                    UINT32)), wire.mav)
    assert wire.replies() == []
    assert p.get("COM_OBL_RC_ACT") == 0 and p.get("MPC_XY_P") == pytest.approx(0.95, rel=1e-7)


def test_messages_for_another_vehicle_or_of_another_kind_are_not_taken(wire):
    p = Parameters()
    assert not p.handle(wire.received(mavlink.MAVLink_param_request_list_message(SYSTEM + 1, COMPONENT)), wire.mav)
    assert not p.handle(wire.received(mavlink.MAVLink_param_request_list_message(SYSTEM, 191)), wire.mav)
    assert not p.handle(wire.received(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3)), wire.mav)
    assert wire.replies() == []


def test_a_changed_value_is_also_told_on_the_other_links(wire):
    p, gcs_link = Parameters(), Wire(SYSTEM)
    p.handle(wire.received(mavlink.MAVLink_param_set_message(SYSTEM, COMPONENT, b"RTL_RETURN_ALT", 30.0, REAL32)),
             wire.mav, others=(gcs_link.mav,))
    (here,), (there,) = wire.replies(), gcs_link.replies()
    assert _name(here) == _name(there) == "RTL_RETURN_ALT" and here.param_value == there.param_value == 30.0
    p.handle(wire.received(mavlink.MAVLink_param_set_message(SYSTEM, COMPONENT, b"NO_SUCH", 1.0, REAL32)), wire.mav,
             others=(gcs_link.mav,))
    assert wire.replies() == [] and gcs_link.replies() == []
