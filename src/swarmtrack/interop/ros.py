"""A swarmtrack run as standard ROS 2 messages (``swarmtrack export RUN --format mcap|rosbag2``), so that Foxglove,
PlotJuggler or RViz show it.

Written with ``rosbags`` (pure Python, no ROS installation): an MCAP file, or a ROS 2 bag (sqlite3 storage), one
message per recorded estimation step on each topic, stamped with the run's simulated time (s → ns):

==========================  ==========================================  ==============================================
topic                       type                                        content
==========================  ==========================================  ==============================================
``/target/pose``            ``geometry_msgs/msg/PoseStamped``           the tracked target's true position
``/uav<i>/pose``            ``geometry_msgs/msg/PoseStamped``           UAV i's true position (1-based)
``/uav<i>/estimate``        ``geometry_msgs/msg/PoseWithCovarianceStamped``  UAV i's estimate of the target, its
                                                                        position covariance in the 6×6 matrix's x-y
                                                                        block (the rest 0)
``/uav<i>/navigation``      ``geometry_msgs/msg/PoseStamped``           UAV i's own navigation solution (what its
                                                                        onboard code was handed)
``/uav<i>/target``          ``geometry_msgs/msg/PointStamped``          UAV i's detection of the tracked target: its
                                                                        position relative to the UAV along the map
                                                                        frame's axes, stamped when it was taken
==========================  ==========================================  ==============================================

The last two are written for a run that kept its inputs (every ``swarmtrack run``) and whose sensor's measurements
map back to a relative position (range-bearing, camera; :class:`swarmtrack.registry.Measurement`): the exported
bag then replays with ``swarmtrack replay`` and a map naming them.

The frame is ``map``: the project's ENU world frame is ROS's convention for it (REP 103), so no axis changes; z is 0
(the world is planar) and orientations are the identity. Estimates are written for the runs whose estimator records a
Gaussian estimate (``estimate`` and ``covariance`` probes); a UAV's step without one (NaN: lost, or late in real time)
is not written. The recording is read chunk by chunk, so memory stays bounded by a chunk.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: ``--format`` choices written by :func:`export_ros`, and their ``rosbags`` storage plugin.
STORAGE = {"mcap": "MCAP", "rosbag2": "SQLITE3"}


def export_ros(rec, out: Path, fmt: str) -> dict[str, int]:
    """Write the recording ``rec`` to the new bag ``out`` (a folder ``rosbags`` creates) in ``fmt`` (:data:`STORAGE`);
    returns the messages written per topic."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    msg = store.types
    n_uavs = rec.uav_slice.stop - rec.uav_slice.start
    counts: dict[str, int] = {}
    with Writer(out, version=8, storage_plugin=getattr(StoragePlugin, STORAGE[fmt])) as writer:
        def connection(topic: str, kind: str):
            counts[topic] = 0
            return writer.add_connection(topic, kind, typestore=store)

        def write(conn, ns: int, message, kind: str) -> None:
            writer.write(conn, ns, store.serialize_cdr(message, kind))
            counts[conn.topic] += 1

        pose, cov = "geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/PoseWithCovarianceStamped"
        point = "geometry_msgs/msg/PointStamped"
        target = connection("/target/pose", pose) if rec.tracked is not None else None
        uavs = [connection(f"/uav{i + 1}/pose", pose) for i in range(n_uavs)]
        estimates = None
        inputs, to_relative = _inputs(rec)
        if inputs is not None:
            navs = [connection(f"/uav{i + 1}/navigation", pose) for i in range(n_uavs)]
            seen = [connection(f"/uav{i + 1}/target", point) for i in range(n_uavs)]
        for chunk in rec.chunks():
            if estimates is None and "estimate" in chunk.probes and "covariance" in chunk.probes:
                estimates = [connection(f"/uav{i + 1}/estimate", cov) for i in range(n_uavs)]
            for s, t in enumerate(chunk.t):
                ns = int(round(float(t) * 1e9))
                header = msg["std_msgs/msg/Header"](stamp=msg["builtin_interfaces/msg/Time"](
                    sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id="map")

                truth = chunk.truth[s]
                if inputs is not None:
                    _k, _t, nav, det = next(inputs)
                    for i, conn in enumerate(navs):
                        write(conn, ns, msg[pose](header=header, pose=_pose(msg, nav[i])), pose)
                    taken = ns if det.taken is None else int(round(det.taken * 1e9))
                    if taken >= 0:  # a sensor's latency buffer at the start holds nothing
                        at = msg["std_msgs/msg/Header"](stamp=msg["builtin_interfaces/msg/Time"](
                            sec=taken // 1_000_000_000, nanosec=taken % 1_000_000_000), frame_id="map")
                        pick = det.label == rec.meta["tracked_label"]
                        for owner, rel in zip(det.owner[pick], to_relative(det)[pick], strict=True):
                            write(seen[owner], ns, msg[point](header=at, point=msg["geometry_msgs/msg/Point"](
                                x=float(rel[0]), y=float(rel[1]), z=0.0)), point)
                if target is not None:
                    write(target, ns, msg[pose](header=header, pose=_pose(msg, truth[rec.tracked])), pose)
                for i, conn in enumerate(uavs):
                    write(conn, ns, msg[pose](header=header, pose=_pose(msg, truth[rec.uav_slice][i])), pose)
                if estimates is None:
                    continue
                est, P = chunk.probes["estimate"][s], chunk.probes["covariance"][s]
                for i, conn in enumerate(estimates):
                    if not np.isfinite(est[i, :2]).all():
                        continue
                    covariance = np.zeros((6, 6))
                    covariance[:2, :2] = P[i, :2, :2]
                    write(conn, ns, msg[cov](header=header, pose=msg["geometry_msgs/msg/PoseWithCovariance"](
                        pose=_pose(msg, est[i]), covariance=covariance.ravel())), cov)
    return counts


def _inputs(rec):
    """The recording's inputs step by step and how its sensor's detections map back to relative positions, or
    ``(None, None)`` when it kept no inputs or its sensor's measurements do not map back."""
    from swarmtrack import registry

    kind = registry.kinds("sensor").get((rec.meta.get("sensor") or {}).get("kind"))
    if "inputs" not in rec.meta or kind is None or kind.measurement is None or rec.meta.get("tracked_label") is None:
        return None, None
    return rec.inputs(), registry.resolve(kind.measurement.relative_of)


def _pose(msg, state: np.ndarray):
    """A ``geometry_msgs/msg/Pose`` at ``state[:2]`` (z 0, identity orientation)."""
    return msg["geometry_msgs/msg/Pose"](
        position=msg["geometry_msgs/msg/Point"](x=float(state[0]), y=float(state[1]), z=0.0),
        orientation=msg["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))
