"""Bad input to the field's commands: one line naming the cause, exit code 2, nothing written."""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import pytest
from click.testing import CliRunner

from swarmtrack.cli import main
from swarmtrack.field.camera import DETECTION_TYPE, TRUTH_TYPE, stamped
from swarmtrack.live.transport import ZenohTransport, free_port

pytestmark = pytest.mark.xdist_group("field")


@pytest.mark.parametrize(("args", "says"), [
    (["--detections", "udp://1.2.3.4:5"], "--detections 'udp://1.2.3.4:5' is not a source"),
    (["--detections", "zenoh://a?type=foo/msg/Bar"], "is not a ROS 2 message type"),
    (["--navigation", "ros2://uav/pose", "--detections", "zenoh://a"], "--navigation 'ros2://uav/pose': a ROS 2"),
    (["--navigation", "zenoh://nav"], "no detections"),
    (["--detections", "zenoh://a"], "no navigation"),
    (["--detections", "zenoh://a", "--navigation", "zenoh://b", "--start", "tomorrow"], "is not a start time"),
    (["--detections", "zenoh://a", "--navigation", "zenoh://b", "--start", "2026-12-06T17:00:00"], "zone"),
])
def test_a_field_agent_refuses_bad_sources_in_one_line(args, says):
    res = CliRunner().invoke(main, ["agent", "l24-ct", "--uav", "1", "--field", "--insecure", *args])
    assert res.exit_code == 2, res.output
    assert says in res.output and len(res.output.strip().splitlines()) <= 3  # click's usage line, then the error


def test_a_field_agent_refuses_a_scenario_it_cannot_place_detections_for():
    res = CliRunner().invoke(main, ["agent", "ib21-fleet-2", "--uav", "1", "--field", "--insecure", "--navigation",
                                    "zenoh://b", "--detections", "zenoh://a"])
    assert res.exit_code == 2 and "the field makes camera, position, range_bearing measurements" in res.output


def _agent(*args, timeout=60):
    return subprocess.run([sys.executable, "-m", "swarmtrack", "agent", "l24-ct", "--uav", "1", "--field",
                           "--insecure", "--start", "next:1", *args], capture_output=True, text=True, timeout=timeout)


@pytest.mark.slow
def test_a_topic_that_never_comes_is_named_and_the_agent_exits_2():
    port = free_port()
    proc = _agent("--navigation", "zenoh://test/nobody/pose?type=geometry_msgs/msg/PoseStamped", "--detections",
                  "zenoh://test/nobody/detections?type=geometry_msgs/msg/PointStamped", "--wait", "1",
                  "--listen", f"tcp/127.0.0.1:{port}")
    assert proc.returncode == 2, proc.stderr
    line = proc.stderr.strip().splitlines()[-1]
    assert "zenoh://test/nobody/pose" in line and "no message within 1 s" in line


@pytest.mark.slow
def test_a_message_type_that_does_not_match_is_named_and_the_agent_exits_2():
    port = free_port()
    peer = ZenohTransport(listen=[f"tcp/127.0.0.1:{port}"])
    stop = threading.Event()

    def publish() -> None:  # the detections' key carries poses, not the points the agent is told
        while not stop.is_set():
            now = time.time()
            peer.put_typed("test/mismatch/pose", stamped(TRUTH_TYPE, now, (0.0, 0.0)), TRUTH_TYPE)
            peer.put_typed("test/mismatch/detections", stamped(TRUTH_TYPE, now, (1.0, 0.0)), TRUTH_TYPE)
            time.sleep(0.05)

    thread = threading.Thread(target=publish)
    thread.start()
    try:
        proc = _agent("--navigation", "zenoh://test/mismatch/pose", "--detections",
                      f"zenoh://test/mismatch/detections?type={DETECTION_TYPE}", "--wait", "20",
                      "--connect", f"tcp/127.0.0.1:{port}")
    finally:
        stop.set()
        thread.join()
        peer.close()
    assert proc.returncode == 2, proc.stderr
    line = proc.stderr.strip().splitlines()[-1]
    assert "zenoh://test/mismatch/detections" in line and TRUTH_TYPE in line and DETECTION_TYPE in line


def test_an_unreachable_swarm_stops_the_monitor_before_anything_is_written(tmp_path):
    out = tmp_path / "never"
    res = CliRunner().invoke(main, ["monitor", "l24-ct", "--insecure", "--connect", f"tcp/127.0.0.1:{free_port()}",
                                    "--connect-timeout", "0.5", "--out", str(out)])
    assert res.exit_code == 2 and "cannot reach" in res.output, res.output
    assert not out.exists() and not list(tmp_path.iterdir())
