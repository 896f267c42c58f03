"""A ground station's request to a UAV's companion computer (``swarmtrack engage``): take the vehicle again, or hand
it back.

The request is MAVLink's ``MAV_CMD_NAV_GUIDED_ENABLE`` (param1 = 1: "hand control over to an external controller";
0: take it back), sent as a ``COMMAND_LONG`` to the UAV's system, component ``MAV_COMP_ID_ONBOARD_COMPUTER`` (191),
through the autopilot's ground-station link: PX4 forwards it to the companion computer's link when forwarding is on
(``MAV_x_FORWARD``), as the simulated vehicle does. The companion computer answers with ``COMMAND_ACK`` and says why
in a ``STATUSTEXT`` (:mod:`swarmtrack.autopilot.authority`).
"""

from __future__ import annotations

import time

from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot import px4

#: This ground station's MAVLink identity (QGroundControl's system id and component).
SYSTEM, COMPONENT = 255, mavlink.MAV_COMP_ID_MISSIONPLANNER


def request(to: str, uav: int, enable: bool = True, timeout: float = 5.0) -> tuple[int | None, list[str]]:
    """Ask UAV ``uav`` (0-based; MAVLink system ``uav + 1``)'s companion computer, through the autopilot's
    ground-station link at ``to`` (``HOST:PORT``, sent to over UDP), to engage (``enable``) or to hand the vehicle
    back. Returns the acknowledgement's ``MAV_RESULT`` (None: none came within ``timeout`` s) and what the companion
    computer said (its STATUSTEXTs)."""
    conn = px4.connect(f"udpout:{to}", source_system=SYSTEM, source_component=COMPONENT)
    try:
        conn.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE)
        conn.mav.command_long_send(uav + 1, mavlink.MAV_COMP_ID_ONBOARD_COMPUTER, mavlink.MAV_CMD_NAV_GUIDED_ENABLE, 0,
                                   1.0 if enable else 0.0, 0, 0, 0, 0, 0, 0)
        said, deadline = [], time.monotonic() + timeout
        while (left := deadline - time.monotonic()) > 0:
            msg = conn.recv_match(type=["COMMAND_ACK", "STATUSTEXT"], blocking=True, timeout=min(left, 0.1))
            if msg is None or msg.get_srcSystem() != uav + 1 or \
                    msg.get_srcComponent() != mavlink.MAV_COMP_ID_ONBOARD_COMPUTER:
                continue
            if msg.get_type() == "STATUSTEXT":  # its reason comes before its answer
                said.append(msg.text)
            elif msg.command == mavlink.MAV_CMD_NAV_GUIDED_ENABLE and msg.result != mavlink.MAV_RESULT_IN_PROGRESS:
                return msg.result, said
        return None, said
    finally:
        conn.close()
