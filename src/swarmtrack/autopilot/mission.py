"""A simulated vehicle's mission store and MAVLink's mission protocol, as PX4 serves it.

:class:`Missions` keeps one list of items per ``MAV_MISSION_TYPE`` (mission, fence, rally; empty at start), accepts
uploads, serves downloads and clears, and never flies them (the simulated vehicle has no Mission mode). It follows
PX4's ``MavlinkMissionManager`` (``src/modules/mavlink/mavlink_mission.cpp``, PX4 main of 2025-2026):

- download: ``MISSION_REQUEST_LIST`` → ``MISSION_COUNT`` (0 for an empty list, then nothing more); each
  ``MISSION_REQUEST_INT`` (or the older ``MISSION_REQUEST``) of the expected sequence, or the previous one again,
  → ``MISSION_ITEM_INT`` (``MISSION_ITEM``); another sequence → ``MISSION_ACK`` ``MAV_MISSION_ERROR`` and back to idle;
  the client's ``MISSION_ACK`` ends it;
- upload: ``MISSION_COUNT`` → ``MISSION_REQUEST_INT`` of item 0 (``MISSION_REQUEST`` once the client has used the
  float messages); each item of the expected sequence is stored and the next requested; after the last,
  ``MISSION_ACK`` ``MAV_MISSION_ACCEPTED`` and the new list replaces the old one. A count of 0 clears the list
  (``MAV_MISSION_ACCEPTED``); more items than the type holds → ``MAV_MISSION_NO_SPACE``; an item of another sequence is
  ignored (the client repeats it); a ``MISSION_COUNT`` again before item 1 repeats the request of item 0 (a lost
  request), later → ``MAV_MISSION_ERROR``; an item in a frame PX4 does not take → ``MAV_MISSION_UNSUPPORTED_FRAME``;
  a fence or rally command in a mission → ``MAV_MISSION_ERROR``;
- ``MISSION_CLEAR_ALL`` (of one type or ``MAV_MISSION_TYPE_ALL``) while idle → cleared, ``MAV_MISSION_ACCEPTED``.

A transfer silent for :data:`PROTOCOL_TIMEOUT` s is abandoned (PX4's ``MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT``),
checked when the next message comes. PX4 also re-sends a lost request after 250 ms; here MAVSDK's own retries (it
re-sends the count or the item) cover a lost datagram. Items are kept as ``MISSION_ITEM_INT`` fields (latitude and
longitude in 1e-7 degrees for the global frames, as PX4 stores them); the ``opaque_id`` of MAVLink's newer
``MISSION_COUNT``/``MISSION_ACK`` is not in pymavlink's dialect and is not sent.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

MISSION, FENCE, RALLY = mavlink.MAV_MISSION_TYPE_MISSION, mavlink.MAV_MISSION_TYPE_FENCE, mavlink.MAV_MISSION_TYPE_RALLY
#: Items each type holds (PX4's dataman, ``src/modules/dataman/dataman.h`` on main: ``DM_KEY_FENCE_POINTS_MAX`` 64,
#: ``DM_KEY_SAFE_POINTS_MAX`` 32; missions ``CONFIG_NUM_MISSION_ITMES_SUPPORTED``, taken here as the 500 of the older
#: ``NUM_MISSIONS_SUPPORTED``).
CAPACITY = {MISSION: 500, FENCE: 64, RALLY: 32}
#: Seconds of silence after which a transfer is abandoned (PX4: 5 s).
PROTOCOL_TIMEOUT = 5.0
#: Frames whose x, y are latitude and longitude (in 1e-7 degrees in the _INT messages).
GLOBAL_FRAMES = {mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_INT,
                 mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT}
#: Frames PX4's ``parse_mavlink_mission_item`` takes: the global ones and ``MAV_FRAME_MISSION`` (commands).
FRAMES = GLOBAL_FRAMES | {mavlink.MAV_FRAME_MISSION}
#: Commands that belong to a fence or rally list, refused in a mission (PX4 hardens against them).
NOT_MISSION = {mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
               mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION,
               mavlink.MAV_CMD_NAV_RALLY_POINT}
IDLE, SENDLIST, GETLIST = "idle", "sending", "receiving"


@dataclass(frozen=True)
class Item:
    """One stored item, as ``MISSION_ITEM_INT`` carries it."""

    seq: int
    frame: int
    command: int
    current: int
    autocontinue: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int
    y: int
    z: float

    @classmethod
    def of(cls, msg) -> Item:
        """The item a ``MISSION_ITEM_INT`` or ``MISSION_ITEM`` (float latitude/longitude) carries."""
        x, y = msg.x, msg.y
        if msg.get_type() == "MISSION_ITEM":
            scale = 1e7 if msg.frame in GLOBAL_FRAMES else 1e4  # MISSION_ITEM_INT's x, y: 1e-7 deg, or 1e-4 m
            x, y = int(round(x * scale)), int(round(y * scale))
        return cls(msg.seq, msg.frame, msg.command, msg.current, msg.autocontinue, msg.param1, msg.param2,
                   msg.param3, msg.param4, int(x), int(y), msg.z)


class Missions:
    """One vehicle's stored missions and its side of the mission protocol (module docstring)."""

    def __init__(self, clock=time.monotonic):
        self.items: dict[int, list[Item]] = {MISSION: [], FENCE: [], RALLY: []}
        self._clock = clock
        self._state, self._type, self._int_mode = IDLE, MISSION, True
        self._partner = (0, 0)
        self._seq = 0  # the next item expected (upload) or the next request expected (download)
        self._count = 0
        self._incoming: list[Item] = []
        self._last = 0.0

    def handle(self, msg, mav) -> bool:
        """Answer ``msg`` if it is a mission-protocol message for this autopilot (``mav.srcSystem``,
        ``mav.srcComponent`` or ``MAV_COMP_ID_ALL``); replies go out through ``mav``. Returns whether it was one."""
        kind = msg.get_type()
        handler = {"MISSION_REQUEST_LIST": self._request_list, "MISSION_REQUEST_INT": self._request,
                   "MISSION_REQUEST": self._request, "MISSION_COUNT": self._count_in, "MISSION_ITEM_INT": self._item,
                   "MISSION_ITEM": self._item, "MISSION_ACK": self._ack, "MISSION_CLEAR_ALL": self._clear}.get(kind)
        if handler is None:
            return False
        if msg.target_system != mav.srcSystem or msg.target_component not in (mav.srcComponent,
                                                                               mavlink.MAV_COMP_ID_ALL):
            return False
        now = self._clock()
        if self._state != IDLE and now - self._last > PROTOCOL_TIMEOUT:
            self._state = IDLE  # the transfer was abandoned
        self._last = now
        handler(msg, mav)
        return True

    def _ack(self, msg, mav, result: int | None = None) -> None:
        if result is not None:  # ours, to the transfer's partner
            mav.mission_ack_send(*self._partner, result, self._type)
            return
        if (msg.get_srcSystem(), msg.get_srcComponent()) == self._partner and self._state == SENDLIST \
                and msg.mission_type == self._type:
            self._state = IDLE  # the client's acknowledgement ends a download

    def _request_list(self, msg, mav) -> None:
        if self._state == SENDLIST and self._seq == self._count:
            self._state = IDLE  # all sent, the final ack lost: a new request may start
        if self._state == GETLIST or (self._state == SENDLIST and msg.mission_type != self._type):
            return  # PX4: "Mission download request ignored, already active"
        kind = msg.mission_type if msg.mission_type in self.items else MISSION
        self._state, self._type, self._seq = SENDLIST, kind, 0
        self._count, self._partner = len(self.items[kind]), (msg.get_srcSystem(), msg.get_srcComponent())
        mav.mission_count_send(*self._partner, self._count, kind)

    def _request(self, msg, mav) -> None:
        self._int_mode = msg.get_type() == "MISSION_REQUEST_INT"
        if self._state != SENDLIST or (msg.get_srcSystem(), msg.get_srcComponent()) != self._partner \
                or msg.mission_type != self._type:
            return  # PX4 ignores a request outside a download (buggy OSDs send them)
        if msg.seq == self._seq and self._seq < self._count:
            self._seq += 1
        elif msg.seq != self._seq - 1 or msg.seq >= self._count:
            self._state = IDLE
            self._ack(msg, mav, mavlink.MAV_MISSION_ERROR)
            return
        it = self.items[self._type][msg.seq]
        if self._int_mode:
            mav.mission_item_int_send(*self._partner, it.seq, it.frame, it.command, it.current, it.autocontinue,
                                      it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, self._type)
        else:
            scale = 1e7 if it.frame in GLOBAL_FRAMES else 1e4
            mav.mission_item_send(*self._partner, it.seq, it.frame, it.command, it.current, it.autocontinue,
                                  it.param1, it.param2, it.param3, it.param4, it.x / scale, it.y / scale, it.z,
                                  self._type)

    def _send_request(self, mav) -> None:
        if self._int_mode:
            mav.mission_request_int_send(*self._partner, self._seq, self._type)
        else:
            mav.mission_request_send(*self._partner, self._seq, self._type)

    def _count_in(self, msg, mav) -> None:
        if self._state == GETLIST:
            if self._seq == 0:
                self._send_request(mav)  # our first request was lost: ask again
            else:
                self._ack(msg, mav, mavlink.MAV_MISSION_ERROR)  # busy receiving
            return
        if self._state != IDLE:
            self._ack(msg, mav, mavlink.MAV_MISSION_ERROR)
            return
        self._partner = (msg.get_srcSystem(), msg.get_srcComponent())
        self._type = msg.mission_type
        if self._type not in self.items:
            self._ack(msg, mav, mavlink.MAV_MISSION_INVALID)
            return
        if msg.count > CAPACITY[self._type]:
            self._ack(msg, mav, mavlink.MAV_MISSION_NO_SPACE)
            return
        if msg.count == 0:
            self.items[self._type] = []
            self._ack(msg, mav, mavlink.MAV_MISSION_ACCEPTED)
            return
        self._state, self._seq, self._count, self._incoming = GETLIST, 0, msg.count, []
        self._send_request(mav)

    def _item(self, msg, mav) -> None:
        self._int_mode = msg.get_type() == "MISSION_ITEM_INT"
        if msg.mission_type != self._type:
            self._ack(msg, mav, mavlink.MAV_MISSION_ERROR)
            return
        if self._state == IDLE:
            if self._seq == msg.seq + 1 and self._count and self._seq == self._count:
                self._ack(msg, mav, mavlink.MAV_MISSION_ACCEPTED)  # our final ack was lost: say it again
            else:
                self._ack(msg, mav, mavlink.MAV_MISSION_ERROR)  # no transfer
            return
        if self._state != GETLIST:
            self._ack(msg, mav, mavlink.MAV_MISSION_ERROR)  # busy
            return
        if msg.seq != self._seq:
            return  # not the expected one: ignored, the client repeats it
        item = Item.of(msg)
        if item.frame not in FRAMES:
            result = mavlink.MAV_MISSION_UNSUPPORTED_FRAME
        elif self._type == MISSION and item.command in NOT_MISSION:
            result = mavlink.MAV_MISSION_ERROR
        else:
            result = None
        if result is not None:
            self._state = IDLE
            self._ack(msg, mav, result)
            return
        self._incoming.append(item)
        self._seq += 1
        if self._seq < self._count:
            self._send_request(mav)
            return
        self.items[self._type] = self._incoming
        self._state = IDLE
        self._ack(msg, mav, mavlink.MAV_MISSION_ACCEPTED)

    def _clear(self, msg, mav) -> None:
        if self._state != IDLE:
            return  # PX4: "WPM: IGN CLEAR CMD: Busy"
        self._partner = (msg.get_srcSystem(), msg.get_srcComponent())
        self._type = msg.mission_type
        kinds = list(self.items) if self._type == mavlink.MAV_MISSION_TYPE_ALL else [self._type]
        for kind in kinds:
            if kind in self.items:
                self.items[kind] = []
        self._seq = self._count = 0
        self._ack(msg, mav, mavlink.MAV_MISSION_ACCEPTED)
