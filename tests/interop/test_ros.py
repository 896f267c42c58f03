"""A run exported as ROS 2 messages reads back, with the ``mcap`` library, as the run's numbers."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from mcap.reader import make_reader
from rosbags.typesys import Stores, get_typestore

import swarmtrack
from swarmtrack.cli import main


def test_an_exported_mcap_file_decodes_to_the_runs_truth_estimates_and_covariances(tmp_path):
    run = tmp_path / "run"
    ran = CliRunner().invoke(main, ["run", "l24-ct", "--set", "duration=2", "--no-plots", "--out", str(run)])
    assert ran.exit_code == 0, ran.output
    res = CliRunner().invoke(main, ["export", str(run)])
    assert res.exit_code == 0, res.output
    rec = swarmtrack.load_run(run)
    store = get_typestore(Stores.ROS2_HUMBLE)
    topics: dict[str, list] = {}
    (bag,) = (tmp_path / "run.mcap").glob("*.mcap")
    with open(bag, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            msg = store.deserialize_cdr(message.data, schema.name)
            stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            # logged at its step; a detection is stamped when it was taken (the sensor's latency earlier)
            assert message.log_time == stamp if not channel.topic.endswith("/target") else message.log_time >= stamp
            topics.setdefault(channel.topic, []).append(msg)
    steps = len(rec.t)
    assert sorted(topics) == ["/target/pose", *[f"/uav{i}/{k}" for i in (1, 2, 3)
                                                for k in ("estimate", "navigation", "pose", "target")]]
    assert all(len(v) == steps for k, v in topics.items() if not k.endswith("/target"))
    inputs = list(rec.inputs())
    for i in range(3):
        nav = np.array([[m.pose.position.x, m.pose.position.y] for m in topics[f"/uav{i + 1}/navigation"]])
        assert np.array_equal(nav, np.array([n[i, :2] for _, _, n, _ in inputs]))
        seen = topics[f"/uav{i + 1}/target"]
        rows = [(d.taken, d.z[d.owner == i][0]) for _, _, _, d in inputs if (d.owner == i).any() and d.taken >= 0]
        assert len(seen) == len(rows) > 0
        for m, (taken, (r, b)) in zip(seen, rows, strict=True):  # the range-bearing detection, as a point
            assert m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 == pytest.approx(taken, abs=1e-9)
            assert np.allclose([m.point.x, m.point.y], [r * np.cos(b), r * np.sin(b)], rtol=0, atol=1e-12)
    target = np.array([[m.pose.position.x, m.pose.position.y] for m in topics["/target/pose"]])
    assert np.array_equal(target, rec.target[:, :2])  # float64 in CDR: bit for bit
    for i in range(3):
        est = topics[f"/uav{i + 1}/estimate"]
        assert np.array_equal([[m.pose.pose.position.x, m.pose.pose.position.y] for m in est], rec.estimate[:, i, :2])
        cov = np.array([m.pose.covariance.reshape(6, 6) for m in est])
        assert np.array_equal(cov[:, :2, :2], rec.covariance[:, i, :2, :2]) and not cov[:, 2:, :].any()
        assert np.array_equal([[m.pose.position.x, m.pose.position.y] for m in topics[f"/uav{i + 1}/pose"]],
                              rec.uav[:, i, :2])
    again = CliRunner().invoke(main, ["export", str(run)])
    assert again.exit_code == 2 and "never replaces" in again.output
    missing = CliRunner().invoke(main, ["export", str(tmp_path / "nothing")])
    assert missing.exit_code == 2 and "not a swarmtrack run folder" in missing.output


@pytest.mark.slow
def test_an_exported_run_replays_to_its_own_estimates(tmp_path):
    """Export, then replay the bag with a map naming the exported topics: the run's RMSE to round-off. The run's
    sensor has no latency (the run fused each detection at its stamp, as a replay does) and its navigation no noise
    (the simulator draws the position stamped on a detection apart from the navigation solution; a replay takes it
    from the navigation topic: with L24's 2 cm the RMSE differs by 2.5 %)."""
    run = tmp_path / "run"
    ran = CliRunner().invoke(main, ["run", "l24-ct", "--set", "duration=20", "--set", "sensor.latency=0", "--set",
                                    "swarm.nav_position_std=0", "--no-plots", "--out", str(run)])
    assert ran.exit_code == 0, ran.output
    assert CliRunner().invoke(main, ["export", str(run)]).exit_code == 0
    (tmp_path / "map.yaml").write_text("uavs:\n" + "".join(
        f"  {i}: {{navigation: /uav{i}/navigation, detections: /uav{i}/target}}\n" for i in (1, 2, 3))
        + "truth: /target/pose\n")
    res = CliRunner().invoke(main, ["replay", str(tmp_path / "run.mcap"), "--scenario", str(run / "scenario.yaml"),
                                    "--map", str(tmp_path / "map.yaml"), "--no-plots", "--out", str(tmp_path / "back")])
    assert res.exit_code == 0, res.output
    a, b = (json.loads((p / "metrics.json").read_text()) for p in (run, tmp_path / "back"))
    for axis in ("x", "y"):  # the truth's velocity is the exported positions' finite difference: not compared
        assert b["rmse"]["total"][axis] == pytest.approx(a["rmse"]["total"][axis], rel=1e-9)
    back = swarmtrack.load_run(tmp_path / "back")
    assert len(back.t) == len(swarmtrack.load_run(run).t)
    assert np.abs(back.estimate - swarmtrack.load_run(run).estimate).max() < 1e-9
