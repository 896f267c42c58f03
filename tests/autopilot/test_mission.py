"""The simulated vehicle's mission protocol, as PX4's MavlinkMissionManager answers it: requests encoded by a pymavlink
client (system 255, component 190), the replies decoded from the bytes the vehicle's MAVLink object wrote."""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import common as mavlink
from tests.autopilot import wire

from swarmtrack.autopilot.mission import CAPACITY, FENCE, MISSION, PROTOCOL_TIMEOUT, Missions

SYSTEM, COMPONENT = 2, mavlink.MAV_COMP_ID_AUTOPILOT1
WAYPOINT, TAKEOFF = mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_TAKEOFF
REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT


class Wire(wire.Wire):
    def send(self, missions: Missions, msg) -> list:
        """Hand ``msg`` (as the vehicle receives it) to ``missions``; the replies it wrote."""
        assert missions.handle(self.received(msg), self.mav)
        return self.replies()


def _item(seq: int, lat: float, lon: float, alt: float, command=WAYPOINT, frame=REL, kind=MISSION):
    return mavlink.MAVLink_mission_item_int_message(SYSTEM, COMPONENT, seq, frame, command, int(seq == 0), 1, 0.0,
                                                    2.0, 0.0, float("nan"), int(lat * 1e7), int(lon * 1e7), alt,
                                                    kind)


PLAN = [(47.3977, 8.5456, 10.0, TAKEOFF), (47.3980, 8.5460, 20.0, WAYPOINT), (47.3985, 8.5450, 15.0, WAYPOINT)]


def _upload(w: Wire, m: Missions, plan=PLAN, kind=MISSION) -> list:
    got = w.send(m, mavlink.MAVLink_mission_count_message(SYSTEM, COMPONENT, len(plan), kind))
    for seq, (lat, lon, alt, cmd) in enumerate(plan):
        (request,) = got
        assert request.get_type() == "MISSION_REQUEST_INT" and request.seq == seq and request.mission_type == kind
        assert (request.target_system, request.target_component) == (255, 190)
        got = w.send(m, _item(seq, lat, lon, alt, cmd, kind=kind))
    return got


def _download(w: Wire, m: Missions, kind=MISSION) -> list:
    (count,) = w.send(m, mavlink.MAVLink_mission_request_list_message(SYSTEM, COMPONENT, kind))
    assert count.get_type() == "MISSION_COUNT" and count.mission_type == kind
    items = []
    for seq in range(count.count):
        (item,) = w.send(m, mavlink.MAVLink_mission_request_int_message(SYSTEM, COMPONENT, seq, kind))
        assert item.get_type() == "MISSION_ITEM_INT" and item.seq == seq
        items.append(item)
    # the client acknowledges, also an empty list (MAVSDK does; PX4 waits for it before the next upload)
    assert w.send(m, mavlink.MAVLink_mission_ack_message(SYSTEM, COMPONENT, mavlink.MAV_MISSION_ACCEPTED, kind)) == []
    return items


def test_an_empty_mission_by_default():
    w, m = Wire(SYSTEM), Missions()
    (count,) = w.send(m, mavlink.MAVLink_mission_request_list_message(SYSTEM, COMPONENT, MISSION))
    assert count.count == 0 and (count.target_system, count.target_component) == (255, 190)


def test_upload_then_download_gives_the_same_items_and_stores_them_per_type():
    w, m = Wire(SYSTEM), Missions()
    (ack,) = _upload(w, m)
    assert ack.get_type() == "MISSION_ACK" and ack.type == mavlink.MAV_MISSION_ACCEPTED and ack.mission_type == MISSION
    items = _download(w, m)
    assert [(i.x, i.y, i.z, i.command, i.current) for i in items] == [
        (int(lat * 1e7), int(lon * 1e7), alt, cmd, int(seq == 0)) for seq, (lat, lon, alt, cmd) in enumerate(PLAN)]
    assert all(i.frame == REL and i.param2 == 2.0 for i in items)
    assert _download(w, m, FENCE) == []  # the fence list is its own


def test_clear_all_and_a_count_of_zero_each_empty_the_list():
    w, m = Wire(SYSTEM), Missions()
    _upload(w, m)
    (ack,) = w.send(m, mavlink.MAVLink_mission_clear_all_message(SYSTEM, COMPONENT, MISSION))
    assert ack.type == mavlink.MAV_MISSION_ACCEPTED and m.items[MISSION] == []
    _upload(w, m)
    (ack,) = w.send(m, mavlink.MAVLink_mission_count_message(SYSTEM, COMPONENT, 0, MISSION))
    assert ack.type == mavlink.MAV_MISSION_ACCEPTED and _download(w, m) == []
    _upload(w, m)
    _upload(w, m, PLAN[:1], FENCE)
    (ack,) = w.send(m, mavlink.MAVLink_mission_clear_all_message(SYSTEM, COMPONENT, mavlink.MAV_MISSION_TYPE_ALL))
    assert ack.type == mavlink.MAV_MISSION_ACCEPTED and m.items[MISSION] == [] and m.items[FENCE] == []


def test_refusals_as_px4_refuses():
    w, m = Wire(SYSTEM), Missions()
    (ack,) = w.send(m, mavlink.MAVLink_mission_count_message(SYSTEM, COMPONENT, CAPACITY[MISSION] + 1, MISSION))
    assert ack.type == mavlink.MAV_MISSION_NO_SPACE
    w.send(m, mavlink.MAVLink_mission_count_message(SYSTEM, COMPONENT, 1, MISSION))
    (ack,) = w.send(m, _item(0, 47.4, 8.5, 5.0, frame=mavlink.MAV_FRAME_LOCAL_NED))
    assert ack.type == mavlink.MAV_MISSION_UNSUPPORTED_FRAME and m.items[MISSION] == []
    w.send(m, mavlink.MAVLink_mission_count_message(SYSTEM, COMPONENT, 1, MISSION))
    (ack,) = w.send(m, _item(0, 47.4, 8.5, 5.0, command=mavlink.MAV_CMD_NAV_RALLY_POINT))
    assert ack.type == mavlink.MAV_MISSION_ERROR and m.items[MISSION] == []
    _upload(w, m)
    w.send(m, mavlink.MAVLink_mission_request_list_message(SYSTEM, COMPONENT, MISSION))
    (ack,) = w.send(m, mavlink.MAVLink_mission_request_int_message(SYSTEM, COMPONENT, 2, MISSION))  # 0 expected
    assert ack.type == mavlink.MAV_MISSION_ERROR
    assert len(_download(w, m)) == len(PLAN)  # back to idle: a new download works


def test_a_lost_request_or_item_is_recovered_as_px4_recovers_it():
    w, m = Wire(SYSTEM), Missions()
    w.send(m, mavlink.MAVLink_mission_count_message(SYSTEM, COMPONENT, 2, MISSION))
    (again,) = w.send(m, mavlink.MAVLink_mission_count_message(SYSTEM, COMPONENT, 2, MISSION))
    assert again.get_type() == "MISSION_REQUEST_INT" and again.seq == 0  # our request was lost: asked again
    (req,) = w.send(m, _item(0, *PLAN[0][:3]))
    assert req.seq == 1
    assert w.send(m, _item(0, *PLAN[0][:3])) == []  # a repeated item is ignored
    (ack,) = w.send(m, _item(1, *PLAN[1][:3]))
    assert ack.type == mavlink.MAV_MISSION_ACCEPTED and len(m.items[MISSION]) == 2


def test_a_stalled_transfer_is_abandoned_after_the_protocol_timeout():
    now = [0.0]
    w, m = Wire(SYSTEM), Missions(clock=lambda: now[0])
    w.send(m, mavlink.MAVLink_mission_count_message(SYSTEM, COMPONENT, 3, MISSION))
    w.send(m, _item(0, *PLAN[0][:3]))  # then the client goes away
    now[0] += PROTOCOL_TIMEOUT + 0.1
    (ack,) = _upload(w, m)
    assert ack.type == mavlink.MAV_MISSION_ACCEPTED and len(m.items[MISSION]) == 3


def test_the_older_float_messages():
    w, m = Wire(SYSTEM), Missions()
    w.send(m, mavlink.MAVLink_mission_count_message(SYSTEM, COMPONENT, 1, MISSION))
    (ack,) = w.send(m, mavlink.MAVLink_mission_item_message(SYSTEM, COMPONENT, 0, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                                                            WAYPOINT, 1, 1, 0, 0, 0, 0, 47.3981234, 8.5461234, 12.0,
                                                            MISSION))
    assert ack.type == mavlink.MAV_MISSION_ACCEPTED
    assert abs(m.items[MISSION][0].x - 473981234) <= 40  # a float32 latitude's resolution at 47°: 3.8e-6°
    w.send(m, mavlink.MAVLink_mission_request_list_message(SYSTEM, COMPONENT, MISSION))
    (item,) = w.send(m, mavlink.MAVLink_mission_request_message(SYSTEM, COMPONENT, 0, MISSION))
    assert item.get_type() == "MISSION_ITEM"
    assert item.x == pytest.approx(47.3981234, abs=4e-6) and item.y == pytest.approx(8.5461234, abs=1e-6)


def test_messages_for_another_vehicle_are_not_taken():
    w, m = Wire(SYSTEM), Missions()
    msg = mavlink.MAVLink_mission_request_list_message(SYSTEM + 1, COMPONENT, MISSION)
    assert not m.handle(mavlink.MAVLink(None).decode(bytearray(msg.pack(w.gcs))), w.mav)
    hb = mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3)
    assert not m.handle(mavlink.MAVLink(None).decode(bytearray(hb.pack(w.gcs))), w.mav)
    assert w.out == []
