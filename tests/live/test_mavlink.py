"""The live swarm flying through MAVLink autopilots (``swarmtrack live --mavlink``, ``agent --autopilot``): the
numbers of ``swarmtrack run`` to float32's precision, the vehicles' failsafe, refusals and bad links."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import threading
import time
import uuid
from types import SimpleNamespace

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

import swarmtrack
from swarmtrack.analysis.metrics import summary
from swarmtrack.autopilot.endpoint import free_base
from swarmtrack.autopilot.vehicle import MavlinkVehicle
from swarmtrack.live.commands import swarm_processes
from swarmtrack.live.transport import ZenohTransport, free_port

pytestmark = pytest.mark.xdist_group("live-2")


def _udp_ports(n: int) -> int:
    """A base whose ``n`` UAVs' ports are free now: the agents' (``base + i``) and their simulated vehicles' own."""
    return free_base(n)


def _live(tmp_path, *extra, duration=8):
    """``swarmtrack live l24-ct --mavlink`` started: the process, its swarm's name and its Zenoh port."""
    port, zenoh_port, swarm = _udp_ports(3), free_port(), f"test-{uuid.uuid4().hex[:8]}"
    proc = subprocess.Popen([sys.executable, "-m", "swarmtrack", "live", "l24-ct", "--mavlink", "--mavlink-port",
                             str(port), "--insecure", "--no-plots", "--out", str(tmp_path / "live"), "--swarm", swarm,
                             "--listen", f"tcp/127.0.0.1:{zenoh_port}", "--set", f"duration={duration}", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return proc, swarm, zenoh_port


@pytest.mark.slow
def test_a_mavlink_live_run_equals_run_to_float32(tmp_path):
    """Navigation and setpoints travel as MAVLink's float32: the UAVs fly what ``swarmtrack run`` flies to within
    10 µm (about ten float32 steps at these distances), and the RMSE agrees to 1e-7 relative (10 s measured: 0.39 µm,
    estimates 5.6e-9 m, RMSE 1.4e-9 relative; 60 s: 2.7 µm and 1e-9)."""
    proc, _, _ = _live(tmp_path, duration=10)
    out, err = proc.communicate(timeout=240)
    assert proc.returncode == 0, err[-3000:]
    live = swarmtrack.load_run(tmp_path / "live")
    ran = swarmtrack.simulate(swarmtrack.load_scenario("l24-ct", ["duration=10"]))
    assert np.max(np.abs(live.uav - ran.uav)) < 1e-5 and np.max(np.abs(live.estimate - ran.estimate)) < 1e-6
    assert not np.array_equal(live.uav, ran.uav)  # it did go through float32
    rmse = json.loads((tmp_path / "live" / "metrics.json").read_text())["rmse"]["total"]
    ran_rmse = summary(ran)["rmse"]["total"]
    assert all(abs(rmse[k] - ran_rmse[k]) <= 1e-7 * ran_rmse[k] for k in rmse)


@pytest.mark.slow
def test_a_mavlink_run_in_real_time_tracks_as_run_does(tmp_path):
    """At wall-clock rate the position error's RMSE stays within 10 % of the simulator's (the issue's goal), over the
    samples that came in time (how many came is the machine's load: a busy machine records late ones as NaN; each
    UAV's error is its own sensing's in l24-ct: the simulator without any link gives the same RMSE to 1 %, so the
    shares a load makes late do not move it). Measured on 10 s with a core busy elsewhere: 0.5 %, 99.5 % of the
    samples in time."""
    proc, _, _ = _live(tmp_path, "--realtime", duration=10)
    out, err = proc.communicate(timeout=240)
    assert proc.returncode == 0, err[-3000:]
    assert json.loads((tmp_path / "live" / "metrics.json").read_text())["live"]["lost"] == []
    live = swarmtrack.load_run(tmp_path / "live")
    ran = swarmtrack.simulate(swarmtrack.load_scenario("l24-ct", ["duration=10"]))

    def position_error(rec):
        return np.linalg.norm(rec.estimate[:, :, :2] - rec.target[:, None, :2], axis=2)

    came = np.isfinite(position_error(live))
    assert came.any(axis=0).all(), came.mean(axis=0)  # some of each UAV's samples came
    rmse = [float(np.sqrt(np.mean(position_error(rec)[came] ** 2))) for rec in (live, ran)]
    assert abs(rmse[0] / rmse[1] - 1) < 0.10, rmse


@pytest.mark.slow
def test_a_killed_agent_is_held_by_its_vehicles_failsafe(tmp_path, peer):
    proc, swarm, zenoh_port = _live(tmp_path, duration=20)
    try:
        peer.flown(zenoh_port, swarm, 1, 100)  # 5 s flown
        lines = swarm_processes(swarm)
        victim = [ln.split()[0] for ln in lines if "agent --uav 2 " in ln]
        assert len(victim) == 1, lines
        os.kill(int(victim[0]), 9)
        out, err = proc.communicate(timeout=240)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err[-3000:]
    lost = json.loads((tmp_path / "live" / "metrics.json").read_text())["live"]["lost"]
    assert [e["uav"] for e in lost] == [2] and "UAV 2 stopped answering" in err
    rec = swarmtrack.load_run(tmp_path / "live")
    held = rec.t > lost[0]["t"] + 6.0  # its vehicle's failsafe has held it for a few seconds
    speed = np.linalg.norm(rec.uav[:, 1, 2:4], axis=1)
    assert held.any() and speed[held][-1] < 0.05 < speed[~held].max()


class _Refusing:
    def __init__(self, port: int):
        self.vehicle = MavlinkVehicle(0, port, refuse={"arm": mavlink.MAV_RESULT_DENIED})
        self._stop = False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self._stop:
            self.vehicle.poll(0.0)
            time.sleep(0.01)

    def close(self) -> None:
        self._stop = True
        self.thread.join()
        self.vehicle.close()


@pytest.mark.slow
def test_an_agent_whose_autopilot_refuses_to_arm_exits_3_naming_it_and_one_without_an_autopilot_exits_2():
    zenoh_port = free_port()
    listener = ZenohTransport(listen=[f"tcp/127.0.0.1:{zenoh_port}"])
    port = _udp_ports(1)
    refusing = _Refusing(port)
    base = [sys.executable, "-m", "swarmtrack", "agent", "l24-ct", "--uav", "1", "--insecure", "--connect",
            f"tcp/127.0.0.1:{zenoh_port}", "--swarm", f"test-{uuid.uuid4().hex[:8]}"]
    try:
        procs = [subprocess.Popen(base + ["--autopilot", f"udp://127.0.0.1:{to}"], stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True) for to in (port, _udp_ports(1))]  # side by side
        try:
            refused, silent = [SimpleNamespace(stderr=p.communicate(timeout=60)[1], returncode=p.returncode)
                               for p in procs]
        finally:
            for p in procs:
                if p.poll() is None:
                    p.kill()
                    p.wait()
    finally:
        refusing.close()
        listener.close()
    assert refused.returncode == 3, refused.stderr[-2000:]
    assert "UAV 1's autopilot refused to arm: MAV_RESULT_DENIED; no setpoint was flown" in refused.stderr
    assert not refusing.vehicle.armed and refusing.vehicle.setpoint is None
    assert silent.returncode == 2 and "UAV 1: no heartbeat from the autopilot" in silent.stderr, silent.stderr
    assert "Traceback" not in refused.stderr + silent.stderr


class _Cable:
    """A UDP link between a vehicle (sending to ``vehicle_port``) and an agent listening on ``agent_port``, that can
    be cut (:attr:`cut`: everything dropped both ways)."""

    def __init__(self, vehicle_port: int, agent_port: int):
        self.vehicle_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.vehicle_side.bind(("127.0.0.1", vehicle_port))
        self.agent_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.agent_side.bind(("127.0.0.1", 0))
        self.agent, self.vehicle, self.cut, self._stop = ("127.0.0.1", agent_port), None, False, False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        import select

        while not self._stop:
            ready, _, _ = select.select([self.vehicle_side, self.agent_side], [], [], 0.05)
            for s in ready:
                data, addr = s.recvfrom(65536)
                if s is self.vehicle_side:
                    self.vehicle = addr
                    if not self.cut:
                        self.agent_side.sendto(data, self.agent)
                elif not self.cut and self.vehicle is not None:
                    self.vehicle_side.sendto(data, self.vehicle)

    def close(self) -> None:
        self._stop = True
        self.thread.join()
        self.vehicle_side.close()
        self.agent_side.close()


@pytest.mark.slow
def test_a_link_that_drops_for_2_s_trips_the_failsafe_and_only_the_opt_in_takes_the_vehicle_back(tmp_path, peer):
    """Real time; UAV 2's and UAV 3's MAVLink links are cut for 2 s mid-run: their vehicles' offboard-loss failsafe
    takes them (setpoints older than COM_OF_LOSS_T, 1 s). When the links return, UAV 3's agent hands over for good;
    UAV 2's, run with --reengage-after-link-loss, engages again, and within 10 s its error is under twice the swarm's
    median again. metrics.json records both handovers as the failsafe's."""
    vehicle_port, cable_ports, zenoh_port = _udp_ports(3), [_udp_ports(1), _udp_ports(1)], free_port()
    swarm = f"test-{uuid.uuid4().hex[:8]}"
    base = [sys.executable, "-m", "swarmtrack"]
    common = ["l24-ct", "--insecure", "--swarm", swarm, "--set", "duration=30"]
    world = subprocess.Popen(base + ["world", *common, "--realtime", "--mavlink", "--mavlink-port", str(vehicle_port),
                                     "--listen", f"tcp/127.0.0.1:{zenoh_port}", "--no-plots", "--out",
                                     str(tmp_path / "live")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    cables = [_Cable(vehicle_port + 1 + j, cable_ports[j]) for j in range(2)]
    ports = [vehicle_port, *cable_ports]  # UAVs 2 and 3 listen behind the cables
    opt_in = {1: ["--reengage-after-link-loss"]}
    agents = [subprocess.Popen(base + ["agent", *common, "--uav", str(i + 1), "--connect",
                                       f"tcp/127.0.0.1:{zenoh_port}", "--autopilot", f"udp://127.0.0.1:{ports[i]}",
                                       *opt_in.get(i, [])],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for i in range(3)]
    try:
        peer.flown(zenoh_port, swarm, 1, 160)  # 8 s flown
        for cable in cables:
            cable.cut = True
        time.sleep(2.0)
        for cable in cables:
            cable.cut = False
        out, err = world.communicate(timeout=240)
        agent_errs = [a.communicate(timeout=60)[1] for a in agents]
    finally:
        for p in (world, *agents):
            if p.poll() is None:
                p.kill()
        for cable in cables:
            cable.close()
    assert world.returncode == 0, err[-3000:]
    report = json.loads((tmp_path / "live" / "metrics.json").read_text())["live"]["autopilot"]
    events = {uav: [(e["event"], e.get("cause")) for e in report.get(uav, [])] for uav in "123"}
    # a busy machine may stall a process for a second more (its vehicle's failsafe then takes it too): what each mode
    # promises is judged, not the count
    assert events["2"][:2] == [("handover", "failsafe"), ("engaged", None)], (report, agent_errs[1][-3000:])
    assert events["3"][:1] == [("handover", "failsafe")] and ("engaged", None) not in events["3"], report
    assert ("engaged", None) not in events["1"], report
    assert "engaged again" in agent_errs[1] and "engaged again" not in agent_errs[2], agent_errs[1][-2000:]
    back = report["2"][1]["t"]
    rec = swarmtrack.load_run(tmp_path / "live")
    error = np.linalg.norm(rec.estimate[:, :, :2] - rec.target[:, None, :2], axis=2)
    after = (rec.t >= back + 5) & (rec.t < back + 10)
    assert after.any() and np.nanmean(error[after, 1]) < 2 * np.nanmedian(error[after])
