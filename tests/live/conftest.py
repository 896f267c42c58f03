"""What the live tests share: a peer that joins a world's Zenoh endpoint, and a wait until a UAV has flown a while."""

from __future__ import annotations

import time
from types import SimpleNamespace

import pytest

from swarmtrack.live.transport import ZenohTransport, key


def join(port: int) -> ZenohTransport:
    """A Zenoh peer joined to the world listening on ``port`` (once its scenario is built, within 60 s)."""
    deadline = time.monotonic() + 60
    while True:
        try:
            return ZenohTransport(connect=[f"tcp/127.0.0.1:{port}"], timeout=1.0)
        except Exception:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)


def flown(port: int, swarm: str, uav: int, steps: int) -> int:
    """Wait (up to 120 s) until UAV ``uav`` (0-based) of the world on ``port`` has shared ``steps`` estimation steps;
    returns how many it had."""
    listener = join(port)
    shares = []
    listener.subscribe(key(swarm, "uav", uav, "share"), lambda k, data: shares.append(data))
    deadline = time.monotonic() + 120
    while len(shares) < steps and time.monotonic() < deadline:
        time.sleep(0.05)
    listener.close()
    return len(shares)


@pytest.fixture
def peer() -> SimpleNamespace:
    """``peer.join(port)`` and ``peer.flown(port, swarm, uav, steps)``."""
    return SimpleNamespace(join=join, flown=flown)
