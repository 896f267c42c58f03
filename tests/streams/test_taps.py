"""Live outputs as taps on the recorder: every driver sends them what it records, and they change nothing of it."""

from __future__ import annotations

import socket

import numpy as np
from click.testing import CliRunner

from swarmtrack.cli import main
from swarmtrack.scenarios.loader import load_scenario
from swarmtrack.sim.engine import simulate
from swarmtrack.streams.foxglove import FoxgloveView
from swarmtrack.streams.frame import frames


class Keep:
    """A tap that keeps what it is sent."""

    def __init__(self):
        self.meta, self.frames, self.closed = None, [], 0

    def open(self, meta):
        self.meta = meta

    def send(self, frame):
        self.frames.append(frame)

    def close(self):
        self.closed += 1


def _equal(a, b) -> None:
    for ca, cb in zip(a.chunks(), b.chunks(), strict=True):
        np.testing.assert_array_equal(ca.truth, cb.truth)
        for name in ca.probes:
            np.testing.assert_array_equal(ca.probes[name], cb.probes[name])


def test_taps_see_every_recorded_step_and_change_nothing_of_the_recording():
    scn = load_scenario("l24-ct", ["duration=2"])
    keep, view = Keep(), FoxgloveView(port=0, rate=None)
    with_taps, without = simulate(scn, taps=[keep, view]), simulate(scn)
    _equal(with_taps, without)
    assert keep.meta["scenario"] == "l24-ct" and keep.closed == 1
    sent = list(frames(without))
    assert len(keep.frames) == len(sent) == without.meta["n_steps"]
    for got, want in zip(keep.frames, sent, strict=True):
        assert got.t == want.t
        np.testing.assert_array_equal(got.estimate, want.estimate)
        np.testing.assert_array_equal(got.uav, want.uav)
        np.testing.assert_array_equal(got.plots["nees"], want.plots["nees"])


def test_a_foxglove_port_in_use_is_refused_before_the_run(tmp_path):
    with socket.socket() as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        port = held.getsockname()[1]
        res = CliRunner().invoke(main, ["run", "l24-ct", "--set", "duration=1", "--out", str(tmp_path / "r"),
                                        "--foxglove", f"127.0.0.1:{port}"])
    assert res.exit_code == 2 and f"--foxglove 127.0.0.1:{port}: in use" in res.output, res.output
    assert not (tmp_path / "r").exists()


def test_a_run_exports_as_the_live_views_mcap(tmp_path):
    run = tmp_path / "run"
    assert CliRunner().invoke(main, ["run", "l24-ct", "--set", "duration=1", "--out", str(run),
                                     "--no-plots"]).exit_code == 0
    res = CliRunner().invoke(main, ["export", str(run), "--format", "foxglove"])
    assert res.exit_code == 0, res.output
    out = tmp_path / "run.foxglove.mcap"
    from mcap.reader import make_reader

    with out.open("rb") as f:
        summary = make_reader(f).get_summary()
    topics = {c.topic for c in summary.channels.values()}
    assert topics == {"/scene", "/plot/error", "/plot/nees", "/plot/nis"}
    assert summary.statistics.message_count == 4 * 20  # scene, error, NEES, NIS at each of 20 steps
