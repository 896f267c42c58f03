"""``swarmtrack run SCENARIO --animate FILE``: a GIF with one image per ``--animate-every`` of simulated time beside
the run's folder; what cannot be animated exits with code 2 before anything runs or is written."""

from __future__ import annotations

import pytest
from click.testing import CliRunner
from PIL import Image

from swarmtrack.cli import main

SHORT = ["ib21-fleet-2", "--set", "duration=5", "--no-plots"]


@pytest.mark.slow
def test_run_writes_the_animation_beside_the_run(tmp_path):
    gif = tmp_path / "run.gif"
    res = CliRunner().invoke(main, ["run", *SHORT, "--out", str(tmp_path / "run"), "--animate", str(gif),
                                    "--animate-every", "2"])
    assert res.exit_code == 0, res.output
    assert "animation: 3 frames written to" in res.output  # t = 0, 2, 4 s
    with Image.open(gif) as im:
        assert im.format == "GIF" and im.n_frames == 3
    assert (tmp_path / "run" / "metrics.json").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run", "run.gif"]  # no temporary file left


def test_an_existing_file_is_replaced_only_with_overwrite(tmp_path):
    gif = tmp_path / "mine.gif"
    gif.write_bytes(b"not ours")
    res = CliRunner().invoke(main, ["run", *SHORT, "--out", str(tmp_path / "run"), "--animate", str(gif)])
    assert res.exit_code == 2 and "--overwrite" in res.output, res.output
    assert gif.read_bytes() == b"not ours" and not (tmp_path / "run").exists()  # refused before running
    res = CliRunner().invoke(main, ["run", *SHORT, "--set", "duration=1", "--out", str(tmp_path / "run"),
                                    "--animate", str(gif), "--overwrite"])
    assert res.exit_code == 0, res.output
    with Image.open(gif) as im:
        assert im.n_frames == 1


@pytest.mark.parametrize(("args", "words"), [
    (["l24-cv", "--animate", "{d}/a.gif"], "set-membership"),
    ([*SHORT, "--animate", "{d}/a.png"], "must end in .gif or .mp4"),
    ([*SHORT, "--animate", "{d}/a.mp4"], "ffmpeg"),
    ([*SHORT, "--animate", "{d}/nowhere/a.gif"], "no folder"),
    ([*SHORT, "--animate-every", "2"], "need --animate"),
    ([*SHORT, "--animate", "{d}/a.gif", "--animate-uav", "3"], "has 2 UAVs"),
    ([*SHORT, "--animate", "{d}/a.gif", "--animate-every", "0"], "--animate-every"),
])
def test_what_cannot_be_animated_exits_2_before_running(tmp_path, monkeypatch, args, words):
    from matplotlib.animation import FFMpegWriter

    monkeypatch.setattr(FFMpegWriter, "isAvailable", classmethod(lambda cls: False))  # as on a machine without it
    res = CliRunner().invoke(main, ["run", *[a.format(d=tmp_path) for a in args], "--out", str(tmp_path / "run")])
    assert res.exit_code == 2 and words in res.output, res.output
    assert not any(tmp_path.iterdir())
