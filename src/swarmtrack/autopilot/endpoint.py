"""One MAVLink link of a simulated vehicle, as a PX4 SITL instance opens its links (``ROMFS/px4fmu_common/init.d-posix/
px4-rc.mavlink``): a UDP socket bound to a local port and pymavlink's codec (:class:`pymavlink.dialects.v20.common.
MAVLink`), which writes what it encodes to the link's peer.

PX4 SITL instance ``i`` opens an onboard (offboard program) link from local port ``14580 + i`` to ``14540 + i`` and a
ground-station link from local port ``18570 + i`` to ``14550``. :func:`offboard_ports` and :func:`gcs_local_port` give
the same ports relative to a base port (the offboard program's, ``14540``), so that a test with a random base gets its
own ports.

The socket is bound *without* ``SO_REUSEADDR`` (pymavlink's ``udpin`` sets it): on Linux that option lets a second
process bind a port another one holds, and then the two share, or steal, each other's datagrams. Bound without it, a
port held by another simulated vehicle (a second ``swarmtrack world --mavlink``) or by a PX4 SITL instance is refused
at once with :class:`VehicleError`, naming the port.

A link whose peer is not configured is *claimable*: it sends nothing until someone sends to its local port, then
answers to the latest sender (how PX4 answers a ground station that connects to its UDP port). Every link also
sends to whoever else sent to it within :data:`PEER_S` s, as a MAVLink router does: QGroundControl on a configured
port and ``swarmtrack engage`` asking beside it both get their answers.
"""

from __future__ import annotations

import errno
import random
import socket
import time

from pymavlink.dialects.v20 import common as mavlink

#: PX4 SITL's ports of instance 0: its offboard program listens on 14540, its onboard link's local port is 14580,
#: its ground-station link's local port is 18570, the ground station listens on 14550.
OFFBOARD_REMOTE, OFFBOARD_LOCAL, GCS_LOCAL, GCS_REMOTE = 14540, 14580, 18570, 14550
#: Seconds a sender stays a peer of a link after its latest datagram (QGroundControl and MAVSDK send heartbeats at
#: 1 Hz).
PEER_S = 5.0


class VehicleError(Exception):
    """A simulated vehicle cannot start: one of its UDP ports is taken (the message names it and the likely cause)."""


def offboard_ports(base: int, i: int) -> tuple[int, int]:
    """(local, remote) ports of instance ``i``'s offboard link: ``(base + 40 + i, base + i)`` (14580 + i and
    14540 + i for PX4's base 14540)."""
    return base + (OFFBOARD_LOCAL - OFFBOARD_REMOTE) + i, base + i


def gcs_local_port(base: int, i: int) -> int:
    """The local port of instance ``i``'s ground-station link: ``base + 4030 + i`` (18570 + i for base 14540)."""
    return base + (GCS_LOCAL - OFFBOARD_REMOTE) + i


def free_base(n: int, host: str = "127.0.0.1", low: int = 20000, high: int = 40000) -> int:
    """A base port (between ``low`` and ``high``) whose ``n`` instances' ports are all free now: the companion
    computers' (``base + i``) and the vehicles' own, offboard and ground-station (:func:`offboard_ports`,
    :func:`gcs_local_port`); for tests and benchmarks that start vehicles beside others."""
    rng = random.Random()
    while True:
        base, socks = rng.randrange(low, high), []
        try:
            for i in range(n):
                for port in (base + i, offboard_ports(base, i)[0], gcs_local_port(base, i)):
                    socks.append(socket.socket(socket.AF_INET, socket.SOCK_DGRAM))
                    socks[-1].bind((host, port))
            return base
        except OSError:
            continue
        finally:
            for sock in socks:
                sock.close()


def check_free(host: str, port: int, what: str) -> None:
    """Bind ``host:port`` without ``SO_REUSEADDR`` and release it: :class:`VehicleError` naming it when it is taken."""
    Endpoint(host, port, None, 0, 0, what).close()


class Endpoint:
    """A link bound to ``host:port`` sending to ``remote`` (``(host, port)``; None: claimable, module docstring), as
    MAVLink system ``system``, component ``component``; ``what`` names it in errors (``"UAV 1's offboard link"``)."""

    def __init__(self, host: str, port: int, remote: tuple[str, int] | None, system: int, component: int,
                 what: str):
        if not 0 < port < 65536:
            raise VehicleError(f"{what}: local UDP port {port} is out of range (1..65535): choose a lower base port")
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind((host, port))
        except OSError as exc:
            sock.close()
            cause = ("another simulated vehicle (a second swarmtrack world --mavlink) or a PX4 SITL instance "
                     "probably holds it; stop it or choose another --mavlink-port"
                     if exc.errno == errno.EADDRINUSE else exc.strerror or str(exc))
            raise VehicleError(f"{what}: UDP port {port} on {host} is taken: {cause}") from None
        sock.setblocking(False)
        self.sock, self.what, self.remote = sock, what, remote
        self.claimable = remote is None
        self.mav = mavlink.MAVLink(self, srcSystem=system, srcComponent=component)
        self.mav.robust_parsing = True
        self.sent, self.send_errors, self.bad = 0, 0, 0
        self.peers: dict[tuple, float] = {}  # who sent to it: address → when last (monotonic s)

    @property
    def port(self) -> int:
        return self.sock.getsockname()[1]

    def fileno(self) -> int:
        return self.sock.fileno()

    def write(self, buf: bytes) -> None:
        """What the codec encoded, to the peer and to the other senders of the last :data:`PEER_S` s (nothing before
        a claimable link is claimed)."""
        if self.remote is None:
            return
        targets = [self.remote]
        if len(self.peers) > 1 or self.remote not in self.peers:
            now = time.monotonic()
            for addr, heard in list(self.peers.items()):
                if now - heard > PEER_S:
                    del self.peers[addr]
                elif addr != self.remote:
                    targets.append(addr)
        for addr in targets:
            try:
                self.sock.sendto(buf, addr)
                self.sent += 1
            except OSError:  # nobody listens (ECONNREFUSED after an ICMP), or the buffer is full: a lost datagram
                self.send_errors += 1

    def receive(self) -> list:
        """The messages that came (non-blocking); a claimable link answers to the latest sender from now."""
        out: list = []  # pymavlink messages
        while True:
            try:
                data, addr = self.sock.recvfrom(65536)
            except (BlockingIOError, InterruptedError):
                return out
            except OSError:  # an ICMP error of an earlier send, reported here: nothing more to read now
                return out
            if self.claimable:
                self.remote = addr
            self.peers[addr] = time.monotonic()
            for msg in self.mav.parse_buffer(data) or []:
                if msg.get_type() == "BAD_DATA":
                    self.bad += 1
                else:
                    out.append(msg)

    def close(self) -> None:
        self.sock.close()
