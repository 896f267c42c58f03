"""Random streams by purpose: adding a component does not shift the draws of the others."""

import numpy as np

from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.build import build
from swarmtrack.sim.streams import stream


def test_a_stream_depends_on_its_seed_and_purpose_only():
    alone = stream(3, "wind").standard_normal(5)
    other = stream(3, "channel")
    other.standard_normal(1000)  # using another purpose's stream first changes nothing
    assert np.array_equal(stream(3, "wind").standard_normal(5), alone)
    assert not np.array_equal(stream(3, "navigation").standard_normal(5), alone)
    assert not np.array_equal(stream(4, "wind").standard_normal(5), alone)


def test_adding_decoys_keeps_spawn_navigation_and_sensor_draws_of_the_uavs():
    base = build(load_scenario("l24-cv")).world
    more = build(load_scenario("l24-cv", ["decoys.members=[{profile: hover, start: [9, 9]}]"])).world
    assert np.array_equal(base.truth("uavs"), more.truth("uavs"))  # same spawn draws
    assert np.array_equal(base.navigation(), more.navigation())  # same navigation draws
    assert np.array_equal(base._wind[:, 0], more._wind[:, 0])  # the target's gusts are its own stream
    det_base, _ = base.sense()
    det_more, _ = more.sense()
    assert np.array_equal(det_base.of_label(0)[0], det_more.of_label(0)[0])  # and so is its sensor noise


def test_message_loss_draws_do_not_move_the_uavs_spawn_or_the_target_gusts():
    lossless = build(load_scenario("l24-cv")).world
    lossy = build(load_scenario("l24-cv", ["network.loss_probability=0.3"])).world
    assert np.array_equal(lossless.truth(), lossy.truth()) and np.array_equal(lossless._wind, lossy._wind)
