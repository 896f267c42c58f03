"""A stranger doing everything at once (issue 36): in one sealed lockstep run, an outsider puts garbage and unsealed
messages on every hello and world key, replays an earlier run's start, stop and navigation, subscribes to everything
and then freezes, and a second process claims UAV 1 once it flies. The run ends by itself (exit 0), refuses the
duplicate naming it, loses no UAV, counts what it dropped by cause, and records what ``swarmtrack run`` records,
bit for bit.

The test starts processes (two runs, the frozen stranger, the duplicate agent), bounds them in time and ends only
those, by their ids.
"""

from __future__ import annotations

import importlib.util
import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import numpy as np
import pytest

import swarmtrack
from swarmtrack.live import wire
from swarmtrack.live.transport import free_port, key


def _sibling(name: str):
    spec = importlib.util.spec_from_file_location(f"_all_{name}", Path(__file__).with_name(f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_identity, _faults = _sibling("test_identity"), _sibling("test_transport_faults")

pytestmark = pytest.mark.xdist_group("live")


def _earlier_run(tmp_path, peer, key_file, swarm: str) -> list[tuple[str, bytes]]:
    """What an earlier run of the swarm's world sent (seed 1, same key and name): its start, stop and navigation."""
    port, captured, listener = free_port(), [], None
    first = _identity._live(tmp_path, "first", key_file, swarm, port, ["duration=2"], "--seed", "1")
    try:
        listener = peer.join(port)
        listener.subscribe(key(swarm, "world", "*", "*"), lambda k, data: captured.append((str(k), data)))
        _, err = first.communicate(timeout=240)
    finally:
        _identity._end(first)
        if listener is not None:
            listener.close()
    assert first.returncode == 0, err[-3000:]
    return [(k, d) for k, d in captured if k.rsplit("/", 1)[1] in ("navigation", "start", "stop")]


@pytest.mark.slow
def test_a_stranger_doing_everything_at_once_changes_no_number_and_is_counted(tmp_path, peer):
    key_file, swarm = _identity._keyfile(tmp_path), f"test-{uuid.uuid4().hex[:8]}"
    old = _earlier_run(tmp_path, peer, key_file, swarm)
    stops = [(k, d) for k, d in old if not k.endswith("/navigation")]
    navigation = [(k, d) for k, d in old if k.endswith("/navigation")]
    assert stops and navigation
    overrides, port, tally = ["duration=60"], free_port(), tmp_path / "tally"
    frozen = subprocess.Popen([sys.executable, "-c", _faults.STRANGER, str(port), str(tally)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # the second process for UAV 1, its modules loaded now: it says hello at once when told, once UAV 1 flies (on a
    # busy machine, started only then, it could come after the run's end, or its hello before UAV 1's own)
    duplicate = _identity._held_agent(1, port, swarm, key_file, overrides)
    run = _identity._live(tmp_path, "live", key_file, swarm, port, overrides)
    stranger, stopped, flying, told = None, False, [], False
    try:
        stranger = peer.join(port)
        stranger.subscribe(key(swarm, "uav", 0, "sample"), lambda k, data: flying.append(data))  # UAV 1's own
        outsider, rng, i = wire.Seal(wire.keygen(), 3), np.random.default_rng(), 0
        keys = [key(swarm, "uav", u, "hello") for u in range(3)]
        keys += [key(swarm, "world", to, ch) for to in ("all", 0, 1, 2) for ch in ("alive", "start", "stop",
                                                                                    "navigation", "roster")]
        deadline = time.monotonic() + 240  # a bound against a hang, not a figure judged
        while run.poll() is None and time.monotonic() < deadline:
            for k in keys:  # garbage, and unsealed messages that decode, each with an identity of its own
                stranger.put(k, os.urandom(int(rng.integers(1, 300))))
                what = k.rsplit("/", 1)[1]
                msg = (wire.Hello(sender=int(k.split("/")[3]), pid=4242, started=1, scenario="x") if what == "hello"
                       else wire.Stop() if what == "stop" else wire.Alive(pid=4242))
                outsider.proc = int(rng.integers(1, 2**62))
                stranger.put(k, outsider.seal(k, msg))
            for k, d in stops + navigation[i:i + 12]:  # the earlier run's messages, genuine but of another run
                stranger.put(k, d)
            i = (i + 12) % len(navigation)
            if not stopped and _faults._count(tally) > 0:
                frozen.send_signal(signal.SIGSTOP)  # it has heard the run: it reads nothing from now on
                stopped = True
            if not told and flying:
                _identity._go(duplicate)  # UAV 1 flies: a second process claims it
                told = True
            time.sleep(0.05)
        _, err = run.communicate(timeout=240)
        _, duplicate_err = duplicate.communicate(timeout=120) if told else ("", "")
    finally:
        if stopped:
            frozen.send_signal(signal.SIGCONT)
        _identity._end(run, duplicate, frozen)
        if stranger is not None:
            stranger.close()
    assert stopped and told, "the run ended before the stranger froze, or before UAV 1 flew"
    assert run.returncode == 0, err[-3000:]
    assert "Traceback" not in err and "fail the swarm key" not in err, err[-3000:]
    assert duplicate.returncode == 2 and "UAV 1 is flown by process" in duplicate_err, duplicate_err[-2000:]
    live = _identity._metrics(tmp_path / "live")["live"]
    assert [e["pid"] for e in live["refused"]] == [duplicate.pid] and not live["lost"], live
    rejected = live["rejected"]
    assert rejected.get("forged", 0) > 0 and rejected.get("other_run", 0) > 0, rejected
    assert not _faults._processes_of(swarm), "UAV processes left behind"
    _identity.assert_same_recording(swarmtrack.load_run(tmp_path / "live"),
                                    swarmtrack.simulate(swarmtrack.load_scenario("l24-ct", overrides)))
