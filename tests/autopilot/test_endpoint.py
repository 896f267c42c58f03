"""The simulated vehicle's UDP links (autopilot/endpoint.py): PX4 SITL's ports, a taken port refused at once, a
ground-station link silent until claimed."""

from __future__ import annotations

import socket
import time

import pytest
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot.endpoint import Endpoint, VehicleError, gcs_local_port, offboard_ports


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_px4_sitls_ports():
    assert offboard_ports(14540, 0) == (14580, 14540) and offboard_ports(14540, 3) == (14583, 14543)
    assert gcs_local_port(14540, 0) == 18570 and gcs_local_port(14540, 2) == 18572


def test_a_port_another_process_holds_is_refused_at_once_naming_it():
    port = _free_port()
    holder = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    holder.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as pymavlink's udpin binds (a PX4 SITL too)
    holder.bind(("127.0.0.1", port))
    try:
        started = time.monotonic()
        with pytest.raises(VehicleError, match=f"UAV 1's link: UDP port {port} on 127.0.0.1 is taken: another "
                                               "simulated vehicle"):
            Endpoint("127.0.0.1", port, None, 1, 1, "UAV 1's link")
        assert time.monotonic() - started < 0.5
        first = Endpoint("127.0.0.1", _free_port(), None, 1, 1, "first")
        try:
            with pytest.raises(VehicleError):  # and a second vehicle on the first one's port
                Endpoint("127.0.0.1", first.port, None, 1, 1, "second")
        finally:
            first.close()
    finally:
        holder.close()


def test_a_port_out_of_range_is_refused():
    with pytest.raises(VehicleError, match="out of range"):
        Endpoint("127.0.0.1", 70000, None, 1, 1, "link")


def test_a_claimable_link_is_silent_until_someone_sends_then_answers_the_latest_sender():
    link = Endpoint("127.0.0.1", _free_port(), None, 1, 1, "gcs")
    a, b = (socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(2))
    try:
        for s in (a, b):
            s.bind(("127.0.0.1", 0))
            s.settimeout(0.3)
        link.mav.heartbeat_send(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, 0, 0, 0)
        assert link.sent == 0 and link.remote is None
        ground = mavlink.MAVLink(None, 255, 190)
        a.sendto(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(ground), ("127.0.0.1", link.port))
        deadline = time.monotonic() + 2
        while not link.receive() and time.monotonic() < deadline:
            time.sleep(0.01)
        assert link.remote == a.getsockname()
        link.mav.heartbeat_send(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, 0, 0, 0)
        msgs = mavlink.MAVLink(None).parse_buffer(bytearray(a.recv(1024)))
        assert [m.get_type() for m in msgs] == ["HEARTBEAT"] and msgs[0].autopilot == mavlink.MAV_AUTOPILOT_PX4
        b.sendto(b"\xfd garbage", ("127.0.0.1", link.port))  # a stranger's bytes: counted, and it is the sender
        deadline = time.monotonic() + 2
        while link.remote != b.getsockname() and time.monotonic() < deadline:
            link.receive()
            time.sleep(0.01)
        assert link.remote == b.getsockname()
    finally:
        link.close()
        a.close()
        b.close()


def test_a_configured_link_sends_at_once():
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver.bind(("127.0.0.1", 0))
    receiver.settimeout(1.0)
    link = Endpoint("127.0.0.1", _free_port(), receiver.getsockname(), 3, 1, "gcs")
    try:
        link.mav.statustext_send(mavlink.MAV_SEVERITY_INFO, b"hello")
        msg = mavlink.MAVLink(None).parse_buffer(bytearray(receiver.recv(1024)))[0]
        assert msg.text == "hello" and msg.get_srcSystem() == 3
    finally:
        link.close()
        receiver.close()


def test_a_sender_beside_the_peer_gets_the_answers_too_until_it_falls_silent(monkeypatch):
    """QGroundControl on a configured port and ``swarmtrack engage`` asking beside it: both get what the link sends,
    the latter until it has been silent for PEER_S."""
    from swarmtrack.autopilot import endpoint

    monkeypatch.setattr(endpoint, "PEER_S", 0.5)
    qgc, engage = (socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(2))
    try:
        for s in (qgc, engage):
            s.bind(("127.0.0.1", 0))
            s.settimeout(0.3)
        link = Endpoint("127.0.0.1", _free_port(), qgc.getsockname(), 3, 1, "gcs")
        ground = mavlink.MAVLink(None, 255, 190)
        engage.sendto(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(ground), ("127.0.0.1", link.port))
        deadline = time.monotonic() + 2
        while not link.receive() and time.monotonic() < deadline:
            time.sleep(0.01)
        link.mav.statustext_send(mavlink.MAV_SEVERITY_INFO, b"both")
        for s in (qgc, engage):
            assert mavlink.MAVLink(None).parse_buffer(bytearray(s.recv(1024)))[0].text == "both"
        time.sleep(0.6)
        link.mav.statustext_send(mavlink.MAV_SEVERITY_INFO, b"qgc")
        assert mavlink.MAVLink(None).parse_buffer(bytearray(qgc.recv(1024)))[0].text == "qgc"
        with pytest.raises(TimeoutError):
            engage.recv(1024)
        assert link.remote == qgc.getsockname()  # a configured peer stays the peer
    finally:
        link.close()
        qgc.close()
        engage.close()
