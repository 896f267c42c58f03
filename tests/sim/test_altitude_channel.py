"""A 3-D world (sim/altitude_channel.py, world.py): a target climbs as its profile says, the UAVs hold their heights,
the range-bearing-elevation sensor sees the 3-D geometry, the compiled world steps the altitude as the numpy one, and
a world without an altitude channel is the planar world."""

import numpy as np
import pytest

from swarmtrack.sensors import elevation_bearing_range as ebr
from swarmtrack.sim.sensors import RangeBearingElevationSensor, RangeBearingSensor
from swarmtrack.sim.streams import stream
from swarmtrack.sim.world import Group, ProfileDriver, World
from swarmtrack.vehicles.altitude import GroupAltitude
from swarmtrack.vehicles.profile import Phase, VelocityProfile

DT = 0.01
TICKS = 3000
PROFILE = VelocityProfile((Phase("level", 10.0, c=(0.5, 0.0)),
                           Phase("climb", 10.0, c=(0.5, 0.0), vertical=(0.0, 0.4, 0.5, 0.0, 0.0)),
                           Phase("helix", 20.0, c=(0.0, 0.0), amplitude=(1.0, 1.0), omega=(0.3, 0.3),
                                 phi=(0.0, np.pi / 2), vertical=(0.1, 0.0, 0.0, 0.0, 0.0))))


def _world(compiled=False, three_d=True, latency=0.0, sigma=(1e-9, 1e-9, 1e-9)):
    quad = dict(mass=1.5, g=9.81, max_thrust=2 * 1.5 * 9.81)
    uavs = Group("uavs", "quadrotor", np.array([[-3.0, -3.0], [3.0, -3.0], [0.0, 4.0]]),
                 altitude=GroupAltitude.quadrotor([1.0, 1.5, 2.0], **quad, hold=[5.0, 6.0, 5.5]) if three_d else None)
    target = Group("targets", "quadrotor", np.zeros((1, 2)), ProfileDriver((PROFILE,), 2.0, 0.0),
                   altitude=GroupAltitude.quadrotor([2.0], **quad) if three_d else None)
    sensor = RangeBearingElevationSensor(*sigma, latency=latency) if three_d else RangeBearingSensor(1e-9, 1e-9)
    return World([uavs, target], sensor, dt=DT, ticks=TICKS, nav_std=(0.0, 0.0), streams=lambda p: stream(3, p),
                 compiled=compiled)


def test_the_target_climbs_as_its_profile_says_and_the_uavs_hold_their_heights():
    w = _world()
    for _ in range(199):
        w.advance({"uavs": np.zeros((3, 2))}, 10)
    z, vz = w.altitude("targets")[0]  # t = 19.9 s, the climb continuous since the start
    assert abs(z - PROFILE.height(w.t, 2.0)) < 0.01 and abs(vz - PROFILE.vertical_velocity(w.t)) < 0.01
    for _ in range(TICKS // 10 - 199):
        w.advance({"uavs": np.zeros((3, 2))}, 10)
    z, vz = w.altitude("targets")[0]
    assert abs(vz - PROFILE.vertical_velocity(w.t)) < 0.01
    # the helix starts with a jump of climb rate, which the driver's P loop (gain 2/s) follows Δv/gain behind
    jump = 0.1 - 0.4 * np.sin(0.5 * 10.0)
    assert abs((PROFILE.height(w.t, 2.0) - z) - jump / 2.0) < 0.01
    np.testing.assert_allclose(w.altitude("uavs")[:, 0], [5.0, 6.0, 5.5], atol=1e-3)
    assert w.three_d and not _world(three_d=False).three_d


def test_the_sensor_reports_the_3d_geometry_its_latency_late():
    w = _world(latency=0.1)
    for _ in range(120):
        w.advance({"uavs": np.zeros((3, 2))}, 10)  # 12 s: climbing
    past_truth = np.column_stack([w.truth()[:, :2], w.altitude()[:, 0]])
    w.advance({"uavs": np.zeros((3, 2))}, 10)  # the sensor's reports are 0.1 s (10 ticks) old
    det, source = w.sense()
    assert det.z.shape == (3, 3) and det.sensor_pos.shape == (3, 3) and (source == 3).all()
    np.testing.assert_allclose(ebr.to_position(det.z, det.sensor_pos), np.broadcast_to(past_truth[3], (3, 3)),
                               atol=1e-6)
    np.testing.assert_allclose(det.sensor_pos, past_truth[:3], atol=1e-12)
    assert det.z[:, 2].min() < 0.0  # the UAVs (5-6 m) look down on the target (about 3 m)


def test_the_compiled_world_steps_the_altitude_as_the_numpy_world():
    a, b = _world(compiled=False), _world(compiled=True)
    rng = np.random.default_rng(0)
    for _ in range(50):
        u = rng.normal(0, 0.5, (3, 2))
        a.advance({"uavs": u}, 10)
        b.advance({"uavs": u}, 10)
    np.testing.assert_array_equal(a.altitude(), b.altitude())
    np.testing.assert_allclose(a.truth(), b.truth(), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("compiled", [False, True])
def test_a_world_without_an_altitude_channel_is_the_planar_world(compiled):
    """The altitude channel adds draws from its own streams only: the planar truth is bit for bit the same."""
    a, b = _world(compiled, three_d=False), _world(compiled, three_d=True)
    for _ in range(30):
        a.advance({"uavs": np.ones((3, 2))}, 10)
        b.advance({"uavs": np.ones((3, 2))}, 10)
    np.testing.assert_array_equal(a.truth(), b.truth())


@pytest.mark.slow  # two 40 s runs of l24-ct
def test_a_planar_scene_run_in_3d_gives_the_planar_runs_errors():
    """l24-ct with the range-bearing-elevation sensor and CT in 3-D: target and UAVs stay at z = 0, the range and
    bearing noise is the planar sensor's (its streams), the elevation's its own. The horizontal errors and the NEES
    of [x, y, vx, vy] are the planar run's within 1 % (the noisy elevation moves the converted positions by
    about ρ ε²/2), and the altitude is estimated at the scale of the horizontal error."""
    from swarmtrack.analysis.metrics import summary
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim.engine import simulate

    planar = simulate(load_scenario("l24-ct", ["duration=40"]))
    three_d = simulate(load_scenario("l24-ct", ["duration=40", "sensor.kind=range_bearing_elevation",
                                                "estimator.model=ct3d"]))
    s2, s3 = summary(planar), summary(three_d)
    for c in ("x", "y", "vx", "vy"):
        assert s3["rmse"]["total"][c] == pytest.approx(s2["rmse"]["total"][c], rel=0.01)
    assert s3["consistency"]["total"]["nees"] == pytest.approx(s2["consistency"]["total"]["nees"], rel=0.01)
    assert three_d.meta["altitude"] and all(not c.altitude.any() for c in three_d.chunks())  # all at z = 0
    z = np.concatenate([c.probes["estimate"][..., 4] for c in three_d.chunks()])
    assert np.sqrt(np.mean(z[100:] ** 2)) < 2 * max(s2["rmse"]["total"]["x"], s2["rmse"]["total"]["y"])


@pytest.mark.slow  # one 110 s run of l24-3d-ct
def test_l24_3d_ct_tracks_a_climbing_target_with_an_altitude_error_of_the_horizontal_ones_order():
    """The target flies L24's phases with a vertical sinusoid and a helix from 2 m, the UAVs hold 5 m; the CT
    filter in 3-D (latency at its time stamps) keeps the altitude error of the order of the horizontal one (the same
    angular noise at the same ranges) and is never overconfident (no warning, 6-dof NEES under its band's top)."""
    from swarmtrack.analysis.metrics import summary
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim.engine import simulate
    from swarmtrack.vehicles.profile import l24_3d_profile

    rec = simulate(load_scenario("l24-3d-ct", ["duration=110"]))
    s = summary(rec)
    assert s["warnings"] == []
    a, r = s["altitude"]["total"], s["rmse"]["total"]
    assert 0.5 < a["z"] / max(r["x"], r["y"]) < 2.0
    assert a["nees"] <= a["band"][1] and s["consistency"]["total"]["nees"] <= s["consistency"]["total"]["band"][1]
    z_target = rec.target_altitude[:, 0]
    want = l24_3d_profile().height(rec.t, 2.0)
    assert np.abs(z_target - want).max() < 0.1 and z_target.max() > 3.5  # it climbs as its profile says
    np.testing.assert_allclose(rec.uav_altitude[-1, :, 0], 5.0, atol=0.01)
