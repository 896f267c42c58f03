"""The world of the field stand-in (``swarmtrack stand-in``): what a Gazebo or PX4 SITL set-up gives a real
deployment, and nothing else.

It runs the scenario's truth side (:func:`~swarmtrack.sim.build.truth_side`: targets, physics, sensors) at the wall
clock's pace from the swarm's epoch, with each UAV's vehicle a simulated autopilot over MAVLink
(:class:`~swarmtrack.autopilot.fleet.Fleet`: the UAV's navigation from it, its setpoints flown by it), and plays
every UAV's camera as a sensor plugin would: each estimation step (a little ahead of its time: :data:`AHEAD`), the
UAV's detections of the followed target are
published on its own Zenoh key as ``geometry_msgs/msg/PointStamped`` (the target relative to the UAV along the map
frame's axes, stamped when the frame was taken), and the target's truth as ``geometry_msgs/msg/PoseStamped`` (for
the monitor, as motion capture would give it). It plays no radio: the agents hear each other over Zenoh directly. A
gimballed camera (W20's) points where the UAV's agent last said in its sample (what it would command its gimbal).
"""

from __future__ import annotations

import math
import time
from typing import cast

import numpy as np

from swarmtrack import registry
from swarmtrack.autopilot.fleet import Fleet
from swarmtrack.field.sources import typestore
from swarmtrack.live import wire
from swarmtrack.live.node import Node
from swarmtrack.live.realtime import RECORD_BY
from swarmtrack.live.transport import ZenohTransport
from swarmtrack.sim.build import truth_side

DETECTION_TYPE, TRUTH_TYPE = "geometry_msgs/msg/PointStamped", "geometry_msgs/msg/PoseStamped"
#: How far ahead of a step's time (a fraction of the period) its navigation and camera frame go out: as soon as the
#: vehicles' setpoints of the step before are in (:data:`~swarmtrack.live.realtime.RECORD_BY`), so that a busy
#: machine's scheduling does not push a frame past its agent's step (a frame is stamped when it was taken, which
#: the agent fuses it at; a camera's latency of more than this is the scenario's ``sensor.latency``).
AHEAD = 1.0 - RECORD_BY


def detections_key(prefix: str, uav: int) -> str:
    """UAV ``uav``'s (1-based) camera key."""
    return f"{prefix}/uav_{uav}/detections"


def truth_key(prefix: str) -> str:
    return f"{prefix}/target/truth"


def stamped(msgtype: str, stamp: float, xy) -> bytes:
    """A ``PointStamped`` or ``PoseStamped`` at planar ``xy`` stamped ``stamp`` (s since the Unix epoch), frame
    ``map``, as CDR."""
    ts = typestore()
    sec = math.floor(stamp)
    header = ts.types["std_msgs/msg/Header"](
        stamp=ts.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=min(int(round((stamp - sec) * 1e9)),
                                                                          999_999_999)), frame_id="map")
    point = ts.types["geometry_msgs/msg/Point"](x=float(xy[0]), y=float(xy[1]), z=0.0)
    if msgtype == DETECTION_TYPE:
        msg = ts.types[msgtype](header=header, point=point)
    else:
        pose = ts.types["geometry_msgs/msg/Pose"](
            position=point, orientation=ts.types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))
        msg = ts.types[msgtype](header=header, pose=pose)
    return bytes(ts.serialize_cdr(msg, msgtype))


class CameraWorld:
    """``scenario``'s truth side at the wall clock's pace from ``epoch``, publishing on ``node``'s transport under
    ``prefix``; its vehicles' MAVLink ports from ``base_port`` on ``host`` (as ``world --mavlink``)."""

    def __init__(self, scenario, node: Node, epoch: float, prefix: str, base_port: int, host: str = "127.0.0.1"):
        self.scenario, self.node, self.epoch, self.prefix = scenario, node, epoch, prefix
        self.transport = cast(ZenohTransport, node.transport)  # it puts typed samples (their encoding says so)
        self.truth = truth_side(scenario)
        self.n = scenario.swarm.n_uavs
        self._boot = time.monotonic()
        self.fleet = Fleet(self.n, self._now, base_port, host)
        self.relative_of = registry.resolve(registry.get("sensor", scenario.sensor.kind).measurement.relative_of)
        self.label = self.truth.meta["tracked_label"]
        self.aim = np.full((self.n, 2), np.nan)  # a gimbal's aim: none until its agent says
        self.stop = False
        self.published: dict[tuple[int, int], float] = {}  # when (wall clock) each UAV's detection of a step went out

    def _now(self) -> float:
        """The vehicles' clock: monotonic from the stand-in's start."""
        return time.monotonic() - self._boot

    def run(self) -> None:
        """Every step to the scenario's end (or :attr:`stop`)."""
        self.node.listen(("uav", "*", "sample"))
        self.node.heard = []  # every sample's arrival is logged (end_to_end)
        world, clock = self.truth.world, self.truth.clock
        u = np.zeros((self.n, 2))  # what the vehicles fly until their first control step
        tracked = self.truth.meta["tracked"]
        for k in range(clock.steps):
            t = k * clock.dt_estimation
            if not self._sleep_until(t - AHEAD * clock.dt_estimation):
                return
            truth, nav = world.truth(), world.navigation()
            self.fleet.publish(t, nav, range(self.n))
            for sample in self.node.older("sample", k):  # the gimbals' latest aims
                if isinstance(sample, wire.Sample) and sample.aim is not None:
                    self.aim[sample.sender] = wire.unpack(sample.aim)[0]
            detections, _ = world.sense(aim=self.aim if world.aims else None)
            taken = t if detections.taken is None else detections.taken
            for i, mine in enumerate(detections.of_each_uav()):
                ours = mine.label == self.label
                for rel in self.relative_of(mine)[ours]:
                    self.transport.put_typed(detections_key(self.prefix, i + 1),
                                             stamped(DETECTION_TYPE, self.epoch + taken, rel), DETECTION_TYPE)
                    self.published[(i, k)] = time.time()
            if tracked is not None:
                self.transport.put_typed(truth_key(self.prefix),
                                         stamped(TRUTH_TYPE, self.epoch + t, truth[tracked, :2]), TRUTH_TYPE)
            offset = 0
            for control_now, ticks in clock.control_segments(k):
                if control_now:
                    tc = world.t
                    if offset:
                        if not self._sleep_until(tc - AHEAD * clock.dt_control):
                            return
                        nav = world.navigation()
                        self.fleet.publish(tc, nav, range(self.n))
                    period = clock.dt_control
                    until = time.monotonic() + (self.epoch + tc + RECORD_BY * period - time.time())
                    self.fleet.setpoints(tc, range(self.n), until, lambda: self.stop)
                    u = self.fleet.commands(nav, self._now())
                world.advance({"uavs": u}, ticks)
                offset += ticks

    def end_to_end(self) -> np.ndarray:
        """Seconds from each detection's publication to the sample of the step that fused it heard on the network
        (its agent's estimate, as the monitor hears it), over UAVs and steps: what a detection costs end to end."""
        return np.array([sent + latency - self.published[(s, k)] for channel, s, k, _, sent, latency in
                         self.node.log() if channel == "sample" and (s, k) in self.published])

    def _sleep_until(self, t: float) -> bool:
        """Wait for run time ``t`` on the wall clock; False when stopped meanwhile."""
        while not self.stop:
            left = self.epoch + t - time.time()
            if left <= 0:
                return True
            time.sleep(min(left, 0.1))
        return False

    def close(self) -> None:
        self.fleet.close()
