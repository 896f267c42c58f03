"""What a live run adds to ``metrics.json`` (:class:`LiveReport`, under ``live``), and the timing tables a run at
wall-clock rate keeps beside its recording (:func:`timing`): the live world's, and the field monitor's."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd


@dataclass
class LiveReport:
    """What a live run adds to ``metrics.json`` (under ``live``): the UAVs lost and rejoined (1-based, simulated
    time), the messages dropped by every process's seal (by cause), the CPU time of a UAV's process per estimation
    step; in real time also the latencies, how late the steps were done and the messages that missed their
    deadlines. Percentiles are ``{median, p90, p99, max, count}``."""

    mode: str = "lockstep"
    lost: list[dict] = field(default_factory=list)
    rejoined: list[dict] = field(default_factory=list)
    rejected: dict[str, int] = field(default_factory=dict)
    interrupted: float | None = None
    """The simulated time at which Ctrl-C or SIGTERM stopped the run (the recording holds the steps before it)."""
    refused: list[dict] = field(default_factory=list)
    """Processes refused during the run (1-based UAV, its pid, simulated time, why): a second process for a UAV that
    is flown, one of another scenario, one without ``--rejoin`` for a lost UAV."""
    unsealed_stops: list[float] = field(default_factory=list)
    """Simulated times at which a stop the world did not send came on its keys (an ``--insecure`` run)."""
    cpu_per_step_ms: dict | None = None
    """A UAV's process's CPU time per estimation step (ms, over UAVs and steps; its start-up left out)."""
    received_per_step: dict | None = None
    """A UAV's process's receive work per estimation step (over UAVs and steps): the messages its subscriptions
    delivered (``messages``) and the CPU time its callbacks spent on them (``cpu_ms``)."""
    latency_ms: dict[str, dict] = field(default_factory=dict)
    """Real time: each channel's latency (ms, from the sender's wall clock to the receiver's callback)."""
    step_lateness: dict | None = None
    """Real time: how late after its time each UAV's step was done (its sample sent), in estimation periods."""
    world_lateness: dict | None = None
    """Real time: how late after its time the world sent each step's messages (its sensing is done before), in
    estimation periods."""
    late: dict[str, int] = field(default_factory=dict)
    """Real time: the messages that missed their deadline, by channel (``share_fused_late``: of the shares, those
    fused afterwards at their time stamps, within the scenario's delay bound)."""
    shares_due: int | None = None
    """Real time: the neighbours' shares the UAVs' radios named for their steps (``late.share`` counts those of them
    that missed their deadline)."""
    skipped: dict[str, int] = field(default_factory=dict)
    """In the field: the messages of the UAVs' sources they skipped, by cause and topic (summed over their
    processes)."""
    autopilot: dict[str, list[dict]] = field(default_factory=dict)
    """With autopilots: each UAV's (1-based) handovers to its operator and engagements, in order: ``t`` (simulated s,
    the step that saw it), ``event`` (``handover`` or ``engaged``), for a handover the ``mode`` the vehicle went to,
    whether it stayed ``armed`` and the believed ``cause`` (:func:`swarmtrack.autopilot.authority.cause`), for an
    engagement ``by`` whom."""

    def warnings(self) -> list[dict]:
        flown = ("its autopilot's failsafe flies its vehicle" if self.mode == "field" else
                 "it was flown safely from then (the world's safe command, or with --mavlink its autopilot's failsafe)")
        out = [{"check": "live", "message": f"UAV {e['uav']} stopped answering at t = {e['t']:.2f} s; {flown}"
                f"{self._back(e['uav'])}"} for e in self.lost]
        if self.step_lateness is not None and self.step_lateness["p99"] > 1:
            out.append({"check": "live", "message": f"real time not kept: 1 % of the UAVs' steps were done more than "
                        f"{self.step_lateness['p99']:.1f} estimation periods late (the machine is too slow for "
                        "this swarm, or too busy)"})
        if self.interrupted is not None:
            out.append({"check": "live", "message": f"interrupted at t = {self.interrupted:.2f} s: the recording "
                        "holds the steps completed before"})
        if self.skipped:
            from swarmtrack.replay.grid import skipped_lines

            out += [{"check": "live", "message": line} for line in skipped_lines(self.skipped)]
        out += [{"check": "live", "message": f"UAV {e['uav']}: process {e['pid']} refused at t = {e['t']:.2f} s: "
                 f"{e['reason']}"} for e in self.refused]
        out += [{"check": "live", "message": f"a stop the world did not send came at t = {t:.2f} s, unsealed: this run "
                 "is --insecure, so anyone on the network can stop its UAVs (those that obeyed were lost and flown "
                 "safely)"} for t in self.unsealed_stops]
        out += [{"check": "live", "message": f"UAV {uav}'s vehicle was handed to its operator at t = {e['t']:.2f} s "
                 f"({e['mode']}, cause: {e['cause']}): its controller's commands were not flown from then"
                 f"{self._engaged(uav, e['t'])} (its estimates still count)"} for uav, events in self.autopilot.items()
                for e in events if e["event"] == "handover"]
        return out

    def _engaged(self, uav: str, t: float) -> str:
        back = [e["t"] for e in self.autopilot[uav] if e["event"] == "engaged" and e["t"] >= t]
        return f" until it was engaged again at t = {back[0]:.2f} s" if back else ""

    def _back(self, uav: int) -> str:
        back = [e["t"] for e in self.rejoined if e["uav"] == uav]
        return f" (it rejoined at t = {back[0]:.2f} s)" if back else ""


def percentiles(x: np.ndarray) -> dict[str, float] | None:
    """Median, 90th and 99th percentiles and maximum of ``x`` (None: empty)."""
    if not len(x):
        return None
    p50, p90, p99 = np.percentile(x, [50, 90, 99])
    return {"median": float(p50), "p90": float(p90), "p99": float(p99), "max": float(np.max(x)), "count": len(x)}


def timing(report: LiveReport, steps: list[tuple], messages: list[tuple], dt: float) -> dict[str, pd.DataFrame]:
    """Fill ``report``'s latencies and step lateness from ``steps`` (``uav, k, done, cpu``: each UAV's estimation
    steps, ``done`` s after the step's time, ``cpu`` the CPU time its process spent on it) and ``messages``
    (``channel, sender, receiver, k, c, sent, latency``: every message received, ``sent`` s after t = 0's wall-clock
    time) of a run with estimation period ``dt``; returns them as the tables ``latency`` and ``steps``."""
    latency = pd.DataFrame(messages, columns=["channel", "sender", "receiver", "k", "c", "sent", "latency"])
    latency["channel"] = latency["channel"].astype("category")
    by_channel = {ch: percentiles(1e3 * lat.to_numpy()) for ch, lat in latency.groupby("channel", observed=True)[
        "latency"]}
    report.latency_ms = {ch: p for ch, p in by_channel.items() if p is not None}
    report.step_lateness = percentiles(np.array([s[2] for s in steps]) / dt)
    return {"latency": latency, "steps": pd.DataFrame(steps, columns=["uav", "k", "done", "cpu"])}
