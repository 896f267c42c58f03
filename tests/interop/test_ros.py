"""A run exported as ROS 2 messages reads back, with the ``mcap`` library, as the run's numbers."""

from __future__ import annotations

import numpy as np
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
            assert message.log_time == msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            topics.setdefault(channel.topic, []).append(msg)
    steps = len(rec.t)
    assert sorted(topics) == ["/target/pose", *[f"/uav{i}/{k}" for i in (1, 2, 3) for k in ("estimate", "pose")]]
    assert all(len(v) == steps for v in topics.values())
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
