"""What the live tests share: a peer that joins a world's Zenoh endpoint, a wait until a UAV has flown a while, and
numba's cache of the compiled kernels filled before a test starts live processes."""

from __future__ import annotations

import functools
import time
from types import SimpleNamespace

import pytest

from swarmtrack.live import wire
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
    shares: set[int] = set()  # its steps: a share is addressed to each UAV that hears it (one put each)

    def heard(key_expr, data) -> None:
        msg = wire.peek(data)
        if msg is not None:
            shares.add(msg.k)

    listener.subscribe(key(swarm, "uav", uav, "share") + "/**", heard)  # on its own key, or addressed
    deadline = time.monotonic() + 120
    while len(shares) < steps and time.monotonic() < deadline:
        time.sleep(0.05)
    listener.close()
    return len(shares)


@pytest.fixture
def peer() -> SimpleNamespace:
    """``peer.join(port)`` and ``peer.flown(port, swarm, uav, steps)``."""
    return SimpleNamespace(join=join, flown=flown)


#: The scenarios the slow live tests run (their kernels: the same with their overrides).
LIVE_SCENARIOS = ("l24-ct", "w20-switching", "w20-mpc-formation", "ib21-fleet-2")


@functools.cache
def _warmed(name: str) -> None:
    from swarmtrack.analysis.sweep import warm
    from swarmtrack.scenarios import load_scenario

    warm(load_scenario(name, ["duration=1"]))


@pytest.fixture(autouse=True)
def compiled_kernels(request) -> None:
    """Before a slow live test, the kernels its processes call are in numba's cache (compiled here once per session
    when the cache is cold, as in a fresh clone): otherwise every process compiles them at its first step, several at
    once, and on a busy machine a UAV's first answer can take longer than the world's patience (60 s: the run stops,
    naming the UAVs). What the tests judge starts after that."""
    if request.node.get_closest_marker("slow") is not None:
        for name in LIVE_SCENARIOS:
            _warmed(name)
