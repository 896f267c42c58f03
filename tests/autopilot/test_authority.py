"""Operator authority (:mod:`swarmtrack.autopilot.authority`) against a scripted PX4-like autopilot on loopback UDP:
the agent hands over on every way a vehicle can leave offboard mode, never takes it back by itself, and engages
again only when a ground station asks (or, opted in, after a loss of its own link)."""

from __future__ import annotations

import socket
import threading
import time

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot import px4
from swarmtrack.autopilot.authority import Authority, cause
from swarmtrack.autopilot.link import AutopilotLink

OFFBOARD, POSITION, HOLD, LAND = (6, 0), (3, 0), (4, 3), (4, 6)
#: The setpoint stream before offboard mode (s): this autopilot asks only for a fresh one, not PX4's second of them.
PRIME = 0.2
#: How long the tests watch for an engagement that must not come (s): an engagement takes PRIME and a round trip.
WATCH = 4 * PRIME
FORCE = 21196  # PX4's magic number for a disarm in flight


def _port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Autopilot:
    """A scripted autopilot, system 2: heartbeats every 0.1 s with :attr:`mode` and :attr:`armed`, its landed state,
    ``LOCAL_POSITION_NED``; it acknowledges arming and mode switches (offboard only while setpoints come), keeps
    every command and setpoint it received, and can go silent both ways (:attr:`cut`)."""

    def __init__(self, port: int, armed: bool = True, mode=POSITION):
        self.conn = px4.connect(f"udpout:127.0.0.1:{port}", source_system=2,
                                source_component=mavlink.MAV_COMP_ID_AUTOPILOT1)
        self.armed, self.mode, self.landed = armed, mode, mavlink.MAV_LANDED_STATE_IN_AIR
        self.commands: list[tuple[float, int, float, float]] = []  # (when, command, param1, param2)
        self.setpoints: list[float] = []  # when each came (monotonic s)
        self.acks: list = []  # COMMAND_ACKs sent to it (as a ground station behind it would get them)
        self.texts: list[str] = []
        self.cut, self._stop = False, False
        self.unanswered = 0  # offboard requests still to drop without an answer (an acknowledgement lost)
        self.refuse_offboard = False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def set(self, mode=None, armed=None, landed=None) -> None:
        self.mode = self.mode if mode is None else mode
        self.armed = self.armed if armed is None else armed
        self.landed = self.landed if landed is None else landed

    def ask(self, param1: float) -> None:
        """A ground station's NAV_GUIDED_ENABLE for the companion computer, forwarded by this autopilot."""
        self.conn.mav.command_long_send(2, mavlink.MAV_COMP_ID_ONBOARD_COMPUTER, mavlink.MAV_CMD_NAV_GUIDED_ENABLE, 0,
                                        param1, 0, 0, 0, 0, 0, 0)

    def _run(self) -> None:
        beat, t0 = -1.0, time.monotonic()
        while not self._stop:
            now = time.monotonic()
            if not self.cut and now - beat >= 0.1:
                beat = now
                base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mavlink.MAV_MODE_FLAG_SAFETY_ARMED if self.armed
                                                                    else 0)
                self.conn.mav.heartbeat_send(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, base,
                                             px4.custom_mode(*self.mode), mavlink.MAV_STATE_ACTIVE)
                self.conn.mav.extended_sys_state_send(0, self.landed)
                self.conn.mav.local_position_ned_send(int((now - t0) * 1000), 1.0, 2.0, -10.0, 0.0, 0.0, 0.0)
            msg = self.conn.recv_match(blocking=True, timeout=0.02)
            if msg is None or self.cut:
                continue
            kind = msg.get_type()
            if kind == "SET_POSITION_TARGET_LOCAL_NED":
                self.setpoints.append(time.monotonic())
            elif kind == "COMMAND_ACK":
                self.acks.append(msg)
            elif kind == "STATUSTEXT":
                self.texts.append(msg.text)
            elif kind == "COMMAND_LONG":
                self.commands.append((time.monotonic(), msg.command, msg.param1, msg.param2))
                offboard = msg.command == mavlink.MAV_CMD_DO_SET_MODE and int(msg.param2) == 6
                if offboard and self.unanswered:
                    self.unanswered -= 1
                    continue
                result = mavlink.MAV_RESULT_ACCEPTED
                if msg.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
                    self.armed = msg.param1 == 1
                elif msg.command == mavlink.MAV_CMD_DO_SET_MODE:
                    fresh = self.setpoints and time.monotonic() - self.setpoints[-1] < 0.5
                    if offboard and self.refuse_offboard:
                        result = mavlink.MAV_RESULT_DENIED
                    elif offboard and not fresh:
                        result = mavlink.MAV_RESULT_TEMPORARILY_REJECTED
                    else:
                        self.mode = (int(msg.param2), int(msg.param3))
                self.conn.mav.command_ack_send(msg.command, result, target_system=msg.get_srcSystem(),
                                               target_component=msg.get_srcComponent())
                beat = -1.0  # the new state is told at once

    def engagements(self, since: float = 0.0) -> list:
        """The offboard-mode and arming commands that came after ``since``."""
        return [c for c in self.commands if c[0] > since and (
            c[1] == mavlink.MAV_CMD_COMPONENT_ARM_DISARM or (c[1] == mavlink.MAV_CMD_DO_SET_MODE and int(c[3]) == 6))]

    def close(self) -> None:
        self._stop = True
        self.thread.join()
        self.conn.close()


@pytest.fixture
def engaged(request):
    """An autopilot and an engaged Authority over a link to it (``request.param``: Authority's keyword arguments)."""
    port = _port()
    autopilot = Autopilot(port)
    link = AutopilotLink(f"udp://127.0.0.1:{port}", 1)
    authority = Authority(link, prime=PRIME, **getattr(request, "param", {}))
    try:
        authority.engage()
        assert authority.engaged and autopilot.mode == OFFBOARD
        yield autopilot, link, authority
    finally:
        link.close()
        autopilot.close()


def _lose_link(autopilot: Autopilot) -> float:
    """Silence the link both ways for 1.5 s while the autopilot's failsafe holds the vehicle (Position); returns when
    the link came back (monotonic s)."""
    autopilot.cut = True
    time.sleep(0.2)
    autopilot.set(mode=POSITION)  # its failsafe, while nothing gets through
    time.sleep(1.3)
    autopilot.cut = False
    return time.monotonic()


def _until(condition, timeout: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.01)
    return condition()


def test_engaged_the_setpoints_stream_without_the_step_loop():
    """Setpoints keep coming at about 20 Hz between the controller's commands (PX4's offboard signal)."""
    port = _port()
    autopilot = Autopilot(port)
    link = AutopilotLink(f"udp://127.0.0.1:{port}", 1)
    try:
        Authority(link, prime=PRIME).engage()
        n = len(autopilot.setpoints)
        time.sleep(0.5)
        assert len(autopilot.setpoints) - n >= 3  # 10 expected; load may slow the thread, not stop it
    finally:
        link.close()
        autopilot.close()


@pytest.mark.parametrize("change, expected", [
    ({"mode": HOLD}, ("Hold", "operator")),
    ({"mode": POSITION}, ("Position", "operator")),
    ({"armed": False}, ("Offboard", "disarm")),
    ({"mode": LAND, "landed": mavlink.MAV_LANDED_STATE_LANDING}, ("Land", "land")),
])
def test_any_exit_from_offboard_hands_over_at_once_and_the_agent_never_takes_it_back(engaged, change, expected):
    autopilot, link, authority = engaged
    autopilot.set(**change)
    assert _until(lambda: not authority.engaged)
    handed = time.monotonic()
    events = authority.take(12.5)
    assert [(e["event"], e["mode"], e["cause"], e["t"]) for e in events] == [("handover", *expected, 12.5)]
    assert not authority.fly(np.array([1.0, 0.0]), 12.6)  # the controller's commands go nowhere
    time.sleep(WATCH)  # longer than an engagement takes
    late = [t for t in autopilot.setpoints if t > handed + 0.2]  # what was on its way when it handed over aside
    assert late == [] and autopilot.engagements(since=handed) == []
    assert not authority.engaged and authority.take(14.0) == []  # said once


@pytest.mark.parametrize("engaged", [{"reengage_after_link_loss": True}], indirect=True)
def test_the_opt_in_never_reengages_after_a_mode_change_while_the_link_was_heard(engaged):
    autopilot, link, authority = engaged
    autopilot.set(mode=HOLD)
    assert _until(lambda: not authority.engaged)
    time.sleep(WATCH)
    assert not authority.engaged and autopilot.engagements(since=0.0)[-1][0] < time.monotonic() - WATCH + 0.1


@pytest.mark.slow  # a silence longer than PX4's COM_OF_LOSS_T: 2.5 s each
@pytest.mark.parametrize("engaged, back", [({}, False), ({"reengage_after_link_loss": True}, True)],
                         indirect=["engaged"])
def test_after_a_link_loss_the_failsafe_hands_over_and_only_the_opt_in_takes_it_back(engaged, back):
    """The link goes silent both ways for 1.5 s; the autopilot's failsafe holds the vehicle (Position); when the link
    returns the handover is the failsafe's, and only ``reengage_after_link_loss`` engages again."""
    autopilot, link, authority = engaged
    cut_ended = _lose_link(autopilot)
    assert _until(lambda: authority.events and authority.events[0]["event"] == "handover")
    handover = authority.events[0]
    assert handover["cause"] == "failsafe" and handover["link_silent_s"] >= 1.0
    if back:
        assert _until(lambda: authority.engaged) and autopilot.mode == OFFBOARD
        assert [e["event"] for e in authority.events] == ["handover", "engaged"]
    else:
        time.sleep(WATCH)
        assert not authority.engaged and autopilot.engagements(since=cut_ended) == []


@pytest.mark.slow  # a silence longer than PX4's COM_OF_LOSS_T, and an unanswered request
@pytest.mark.parametrize("engaged", [{"reengage_after_link_loss": True}], indirect=True)
@pytest.mark.parametrize("answer, events", [("lost once", ["handover", "engaged"]),
                                            ("refused", ["handover", "not engaged"])])
def test_the_opt_in_asks_again_when_unanswered_and_says_why_it_gave_up(engaged, answer, events, monkeypatch):
    """After the link loss the autopilot drops the first offboard request unanswered (the opt-in asks again and
    engages), or refuses it (the opt-in gives up at once and records the refusal): it never fails silently."""
    monkeypatch.setattr("swarmtrack.autopilot.link.ACK_TIMEOUT", 0.5)
    autopilot, link, authority = engaged
    autopilot.unanswered, autopilot.refuse_offboard = (1, False) if answer == "lost once" else (0, True)
    cut_ended = _lose_link(autopilot)
    assert _until(lambda: len(authority.events) == 2, timeout=10.0), authority.events
    assert [e["event"] for e in authority.events] == events
    asked = len(autopilot.engagements(since=cut_ended))
    if answer == "lost once":
        assert authority.engaged and autopilot.mode == OFFBOARD and asked == 2
    else:
        assert not authority.engaged and asked == 1 and "refused offboard mode" in authority.events[1]["why"]


@pytest.mark.slow  # a silence longer than PX4's COM_OF_LOSS_T
@pytest.mark.parametrize("engaged", [{"reengage_after_link_loss": True}], indirect=True)
def test_the_opt_in_never_reengages_a_disarmed_vehicle(engaged):
    autopilot, link, authority = engaged
    autopilot.cut = True
    time.sleep(0.2)
    autopilot.set(armed=False, landed=mavlink.MAV_LANDED_STATE_ON_GROUND)
    time.sleep(1.3)
    cut_ended = time.monotonic()
    autopilot.cut = False
    assert _until(lambda: not authority.engaged and authority.events)
    time.sleep(WATCH)
    assert autopilot.engagements(since=cut_ended) == [] and not autopilot.armed


def test_a_ground_stations_request_engages_again_and_is_acknowledged(engaged):
    autopilot, link, authority = engaged
    autopilot.set(mode=HOLD)
    assert _until(lambda: not authority.engaged)
    asked = time.monotonic()
    autopilot.ask(1.0)
    slowest = 0.0
    while not authority.engaged and time.monotonic() - asked < 5.0:  # the step loop goes on meanwhile
        t0 = time.monotonic()
        authority.fly(np.zeros(2), 1.0)
        slowest = max(slowest, time.monotonic() - t0)
        time.sleep(0.02)
    assert authority.engaged and autopilot.mode == OFFBOARD
    assert slowest < 0.5  # never waits on the engagement (the prime and a round trip; load may move the figure)
    assert _until(lambda: autopilot.acks)
    assert autopilot.acks[-1].command == mavlink.MAV_CMD_NAV_GUIDED_ENABLE
    assert autopilot.acks[-1].result == mavlink.MAV_RESULT_ACCEPTED
    assert [e["event"] for e in authority.events] == ["handover", "engaged"]
    assert "NAV_GUIDED_ENABLE" in authority.events[-1]["by"]


@pytest.mark.parametrize("state, reason", [
    ({"armed": False, "landed": mavlink.MAV_LANDED_STATE_ON_GROUND}, "disarmed"),
    ({"mode": HOLD, "landed": mavlink.MAV_LANDED_STATE_ON_GROUND}, "not in the air"),
])
def test_a_request_on_a_disarmed_or_landed_vehicle_is_denied_with_its_reason(engaged, state, reason):
    autopilot, link, authority = engaged
    autopilot.set(**state)
    assert _until(lambda: not authority.engaged)
    asked = time.monotonic()
    autopilot.ask(1.0)
    assert _until(lambda: autopilot.acks)
    assert autopilot.acks[-1].result == mavlink.MAV_RESULT_DENIED and reason in autopilot.texts[-1]
    assert not authority.engaged and autopilot.engagements(since=asked) == []


def test_a_request_to_hand_back_puts_the_vehicle_in_hold(engaged):
    autopilot, link, authority = engaged
    autopilot.ask(0.0)
    assert _until(lambda: not authority.engaged) and autopilot.mode == HOLD
    assert _until(lambda: autopilot.acks) and autopilot.acks[-1].result == mavlink.MAV_RESULT_ACCEPTED
    assert [(e["event"], e["cause"]) for e in authority.events] == [("handover", "released")]


def test_the_cause_is_read_from_what_mavlink_tells():
    ground = mavlink.MAV_LANDED_STATE_ON_GROUND
    assert cause(False, 6, 0, None, 0.0, None) == "disarm"
    assert cause(True, 4, 6, None, 0.0, None) == "land"
    assert cause(True, 3, 0, ground, 0.0, None) == "land"
    assert cause(True, 3, 0, None, 1.2, None) == "failsafe"
    assert cause(True, 4, 3, None, 0.0, "Failsafe activated: no offboard signal") == "failsafe"
    assert cause(True, 4, 3, None, 0.4, None) == "operator"
