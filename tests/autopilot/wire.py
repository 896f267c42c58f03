"""What the tests of the simulated vehicle's services share: its side of a MAVLink link written into a list, and a
ground station's encoding what the vehicle receives."""

from __future__ import annotations

from pymavlink.dialects.v20 import common as mavlink


class Wire:
    """The vehicle's MAVLink object (``system``, the autopilot's component) writing into a list, and a ground station's
    (system 255, component 190) encoding requests."""

    def __init__(self, system: int):
        self.out: list[bytes] = []
        self.mav = mavlink.MAVLink(self, srcSystem=system, srcComponent=mavlink.MAV_COMP_ID_AUTOPILOT1)
        self.gcs = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)

    def write(self, data) -> None:
        self.out.append(bytes(data))

    def received(self, msg):
        """``msg`` as the vehicle receives it (packed by the ground station, parsed back)."""
        return mavlink.MAVLink(None).decode(bytearray(msg.pack(self.gcs)))

    def replies(self) -> list:
        """What the vehicle wrote since the last call, parsed."""
        parser = mavlink.MAVLink(None)
        got = [parser.decode(bytearray(b)) for b in self.out]
        self.out.clear()
        return got
