"""The live swarm at wall-clock rate (``--realtime``): late messages, the logs of latency and lateness, a run.

The deadline logic is checked in one process, deterministically: a UAV's agent is handed its messages by the test
(an in-memory transport; every deadline already passed), so which share comes "late" is the test's choice, and the
agent's estimates are compared with the simulator's, whose channel delays the same messages by the same steps.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

import swarmtrack
from swarmtrack.live import wire
from swarmtrack.live.agent import Agent
from swarmtrack.live.node import Node
from swarmtrack.live.world import FIELDS
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.build import build
from swarmtrack.sim.engine import step_loop
from swarmtrack.sim.recorder import Recorder

pytestmark = pytest.mark.xdist_group("live-2")


class Held:
    """A transport that keeps what is put; the test hands it over (``Node._arrive``) when it chooses."""

    def __init__(self):
        self.sent: list[tuple[str, bytes]] = []

    def put(self, key: str, data: bytes) -> None:
        self.sent.append((key, data))

    def subscribe(self, key_expr, callback):
        return None

    def close(self) -> None:
        pass


def _simulated(scenario):
    """The simulator's run of ``scenario``: its recording, and per step UAV 1's navigation and detections and the
    swarm's outbox."""
    sim = build(scenario)
    inputs, share = [], sim.stack.estimator.share

    def logged(t, nav, own):
        out = share(t, nav, own)
        inputs.append((t, nav.copy(), own.of_uavs([0]), {k: np.array(v) for k, v in out.items()}))
        return out

    sim.stack.estimator.share = logged
    recorder = Recorder(sim.meta, sim.world.n_objects, scenario.swarm.n_uavs, sim.stack.probes)
    return step_loop(sim, recorder), inputs


def _agent_run(scenario, inputs, lag: int | None) -> tuple[np.ndarray, dict]:
    """UAV 1's agent in real time, fed ``inputs``; UAV 2's share of step k is handed to it before its step
    ``k + lag`` (never with None). Returns its estimates per step and its counts of late messages."""
    n = scenario.swarm.n_uavs
    agent_wire, world, neighbour = Held(), Node(Held(), wire.Seal(None, n), "t", wire.WORLD), \
        Node(Held(), wire.Seal(None, n), "t", 1)
    agent = Agent(scenario, 0, Node(agent_wire, wire.Seal(None, n), "t", 0))
    agent.build({"targets": [0], "decoys": []})
    agent.node.heard = []
    estimates = []
    for k, (t, nav, own, _outbox) in enumerate(inputs):
        if lag is not None and k >= lag:  # the neighbour's share of step k - lag comes now
            neighbour.send(1, wire.Share(k=k - lag, taken=inputs[k - lag][0],
                                         payloads={name: wire.pack(v[1:2]) for name, v in inputs[k - lag][3].items()}))
        world.send(0, wire.Navigation(k=k, taken=t, nav=wire.pack(nav[0:1]), radio=wire.Radio(
            links=[1], parts=[(k, [1])]), detections={f: wire.pack(getattr(own, f)) for f in FIELDS},
            due=time.time() - 60.0))  # every deadline of the step has passed
        for node in (world, neighbour):
            for key_expr, data in node.transport.sent:
                agent.node._arrive(key_expr, data)
            node.transport.sent.clear()
        agent.step(k)
        samples = [wire.Seal(None, n).open(key_expr, data) for key_expr, data in agent_wire.sent
                   if key_expr.endswith("/sample")]
        estimates.append(wire.unpack(samples[-1].probes["estimate"])[0])
        agent_wire.sent.clear()
    return np.array(estimates), dict(agent.exchange.late)


@pytest.fixture(scope="module")
def delayed():
    scenario = load_scenario("l24-ct", ["swarm.n_uavs=2", "duration=3", "network.delay=0.05",
                                        "estimator.delayed_data=refilter"])
    return scenario, *_simulated(scenario)


def test_a_share_that_misses_its_deadline_is_fused_at_its_time_stamp_as_a_delay_of_the_simulated_channel(delayed):
    scenario, recording, inputs = delayed
    estimates, late = _agent_run(scenario, inputs, lag=1)
    # the simulator's channel delays every message one step (network.delay = one period): the same fusion
    assert np.array_equal(estimates[:, :4], recording.estimate[:, 0])
    steps = len(inputs)
    assert late == {"share": steps, "share_fused_late": steps - 1}  # the last one never came


def test_a_share_later_than_the_delay_bound_is_dropped_and_counted(delayed):
    scenario, recording, inputs = delayed
    too_late, late = _agent_run(scenario, inputs, lag=2)  # two steps late; the bound is one
    never, _ = _agent_run(scenario, inputs, lag=None)
    assert np.array_equal(too_late, never)  # none of them was fused
    assert late == {"share": len(inputs)}
    assert not np.array_equal(never[:, :4], recording.estimate[:, 0])  # the neighbour's shares matter


def came_and_error(rec) -> tuple[np.ndarray, np.ndarray]:
    """Which UAVs' samples came at each step (the recording's present mask; with no mask, those that are not NaN)
    and each UAV's position error (m), (K, N) each."""
    chunks = list(rec.chunks())
    truth = np.concatenate([c.truth for c in chunks])[:, rec.meta["tracked"], :2]
    error = np.linalg.norm(np.concatenate([c.probes["estimate"] for c in chunks])[:, :, :2] - truth[:, None], axis=2)
    if all(getattr(c, "present", None) is not None for c in chunks):
        came = np.concatenate([c.present for c in chunks]).astype(bool)
    else:
        came = np.isfinite(error)
    return came, error


@pytest.mark.slow
def test_a_realtime_run_logs_every_message_and_step_and_tracks(tmp_path):
    """Judged by what real time promises, whatever the machine's load: every sample that came is logged once with its
    navigation, every other one is recorded absent (NaN); the samples that came track. How many came is the load's
    (a sample later than 0.8 of a period is absent by design), so only that some came is asked."""
    out = tmp_path / "live"
    proc = subprocess.run([sys.executable, "-m", "swarmtrack", "live", "l24-ct", "--realtime", "--insecure",
                           "--no-plots", "--out", str(out), "--set", "duration=4"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    live = json.loads((out / "metrics.json").read_text())["live"]
    assert live["mode"] == "realtime" and live["lost"] == []
    steps_n, uavs = 80, 3
    steps = pd.read_parquet(out / "live" / "steps.parquet")
    # each UAV's step logged at most once, with its CPU time; the CPU figure counts the same steps
    assert not steps.duplicated(["uav", "k"]).any() and steps["k"].between(0, steps_n - 1).all()
    assert (steps["cpu"] > 0).all() and live["cpu_per_step_ms"]["count"] == len(steps)
    # each step's receive work is counted, and the shares missed are of those named
    # (its navigation and, at the median step, a neighbour's message)
    assert live["received_per_step"]["messages"]["count"] == len(steps) and live["received_per_step"]["messages"][
        "median"] >= 2
    assert 0 < live["shares_due"] <= steps_n * 2 * (uavs - 1) and live["late"].get("share", 0) <= live["shares_due"]
    latency = pd.read_parquet(out / "live" / "latency.parquet")
    assert (latency["latency"] >= 0).all() and (latency["sender"] != latency["receiver"]).all()
    assert live["latency_ms"]["share"]["count"] == (latency["channel"] == "share").sum()
    navigation = latency[latency["channel"] == "navigation"]
    assert not navigation.duplicated(["receiver", "k"]).any() and (navigation["sender"] == wire.WORLD).all()
    # a UAV's step whose sample came had its navigation (logged with that sample)
    logged = set(zip(steps["uav"], steps["k"], strict=True))
    assert logged <= set(zip(navigation["receiver"], navigation["k"], strict=True))
    rec = swarmtrack.load_run(out)
    came, error = came_and_error(rec)
    assert came.shape == (steps_n, uavs) and came.any(axis=0).all()  # some of each UAV's samples came
    assert np.isnan(error[~came]).all() and np.isfinite(error[came]).all()  # absent: NaN; present: a number
    # every sample recorded present was logged as a step (a sample that came late is logged, not recorded)
    assert {(i, k) for k, i in zip(*np.nonzero(came), strict=True)} <= logged
    settled = came[40:]  # the last 2 s
    assert settled.any() and np.median(error[40:][settled]) < 0.5  # it tracks (m), over the samples that came
