"""The animation of an IB21 run: capturing frames changes nothing in the run, frames come every ``every`` s of
simulated time, the union view holds every UAV's sets and one UAV's view is its own, the GIF has one image per
frame, and what cannot be animated is refused."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from PIL import Image

from swarmtrack.analysis import animation
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate


@pytest.fixture(scope="module")
def captured():
    """A 4 s ib21-fleet-2 run with a frame every second, and the same run without the capture."""
    scn = load_scenario("ib21-fleet-2", ["duration=4"])
    rec, capture = animation.simulate_animated(scn, every=1.0)
    return rec, capture, simulate(scn)


@pytest.mark.slow
def test_capturing_changes_nothing_in_the_run(captured):
    rec, _, plain = captured
    assert rec.meta["probes"] == plain.meta["probes"] and "animation_frames" not in rec.meta["probes"]
    assert rec.meta["n_steps"] == plain.meta["n_steps"] == 80
    for a, b in zip(rec.chunks(), plain.chunks(), strict=True):
        assert np.array_equal(a.truth, b.truth)
        for name in rec.meta["probes"]:
            if name != "solve_time":  # wall-clock: differs between any two runs
                assert np.array_equal(a.probes[name], b.probes[name]), name


@pytest.mark.slow
def test_a_frame_every_second_of_simulated_time(captured):
    _, capture, _ = captured
    assert [f.t for f in capture.frames] == pytest.approx([0.0, 1.0, 2.0, 3.0])
    assert len(capture.path) == 80 and [f.step for f in capture.frames] == [1, 21, 41, 61]
    last = capture.frames[-1]
    assert last.footprints.shape == (2,) and last.targets.shape == (3, 2) and last.decoys.shape == (3, 2)
    assert last.phi_bar < 160000.0  # the UAVs have explored something by 3 s


def test_the_union_view_holds_every_uavs_sets_and_one_uavs_view_is_its_own(captured):
    _, capture, _ = captured
    b = capture.sim.stack.estimator.beliefs
    union = animation.view_sets(b)
    for i in range(2):
        own = animation.view_sets(b, i + 1)
        assert own["unexplored"].equals(b.unexplored[i])
        for name, sets in (("unexplored", b.unexplored[i]), ("unidentified", b.unidentified[i]),
                           ("identified", shapely.union_all(b.identified[i]))):
            assert sets.difference(union[name]).area <= 1e-6
        assert union["unexplored"].area > b.unexplored[i].area  # the two UAVs saw different places
        region = shapely.union_all([own["unexplored"], own["unidentified"], own["identified"]])
        assert region.area == pytest.approx(capture.sim.stack.estimator.sample()["phi"][i], rel=1e-9)


@pytest.mark.slow
def test_the_gif_has_one_image_per_frame_and_replaces_nothing(captured, tmp_path):
    _, capture, _ = captured
    out = animation.render(capture, tmp_path / "run.gif", title="test")
    with Image.open(out) as im:
        assert im.format == "GIF" and im.n_frames == len(capture.frames) == 4
    assert [p.name for p in tmp_path.iterdir()] == ["run.gif"]  # no temporary file left
    with pytest.raises(animation.AnimationError, match="--overwrite"):
        animation.render(capture, out, title="again")


@pytest.mark.parametrize(("name", "words"), [("run.png", "must end in"), ("run.mp4", "ffmpeg")])
def test_a_destination_that_cannot_be_written_is_refused(tmp_path, monkeypatch, name, words):
    from matplotlib.animation import FFMpegWriter

    monkeypatch.setattr(FFMpegWriter, "isAvailable", classmethod(lambda cls: False))
    with pytest.raises(animation.AnimationError, match=words):
        animation.check_destination(tmp_path / name)


def test_a_run_without_sets_cannot_be_animated():
    with pytest.raises(animation.AnimationError, match="setmembership"):
        animation.simulate_animated(load_scenario("l24-cv", ["duration=1"]))
    with pytest.raises(animation.AnimationError, match="UAVs 1-2"):
        animation.simulate_animated(load_scenario("ib21-fleet-2", ["duration=1"]), uav=3)


def test_raster_sets_are_drawn_as_their_member_squares():
    """``estimator.sets: raster``: each view is the union of the member cells' squares of the UAVs' fields."""
    from swarmtrack.estimation import raster as rs

    scn = load_scenario("ib21-fleet-2", ["duration=2", "estimator.sets=raster"])
    _, capture = animation.simulate_animated(scn, every=1.0)
    b = capture.sim.stack.estimator.beliefs
    own = animation.view_sets(b, 1)
    member = rs.members(b.grid, b.unexplored[0]).sum()
    assert own["unexplored"].area == pytest.approx(member * b.grid.cell ** 2)  # whole squares, none twice
    assert rs.area(b.grid, b.unexplored[0]) <= own["unexplored"].area  # the partial edge cells drawn whole
    assert animation.view_sets(b)["unexplored"].area >= own["unexplored"].area
