"""IB21 in the simulator: fixed-wing UAVs, walking targets and decoys, the footprint camera and the guaranteed sets,
end to end; the settings the guarantee depends on are checked (exit 2)."""

import numpy as np
import pytest

from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate


@pytest.fixture(scope="module")
def short():
    return simulate(load_scenario("ib21-fleet-6", ["duration=4", "controller.kind=static"]))


def test_the_set_membership_mpc_steers_and_keeps_the_guarantee():
    fr = simulate(load_scenario("ib21-fleet-6", ["duration=3"])).frame("uavs")
    assert fr["guarantee_violations"].max() == 0
    assert (fr["yaw_accel"] != 0).any() and (fr["solve_time"] > 0).any()


def test_no_true_target_ever_leaves_the_sets_of_any_uav(short):
    fr = short.frame("uavs")
    assert fr["guarantee_violations"].max() == 0
    assert fr["alarm_all_empty"].max() == 0


def test_the_uncertainty_starts_below_the_area_by_the_first_footprints_and_shrinks(short):
    fr = short.frame("uavs")
    first, last = fr[fr.t == fr.t.min()], fr[fr.t == fr.t.max()]
    side = 2 * 100 * np.tan(np.pi / 8)  # the 82.8 m footprint
    assert (first["phi_unexplored"] <= 160_000).all() and (first["phi_unexplored"] >= 160_000 - 6 * side**2).all()
    assert (last["phi"].to_numpy() < first["phi"].to_numpy()).all()  # 4 s of flight at 16.6 m/s
    assert last["phi"].mean() < first["phi"].mean() - 5_000


def test_fixed_wings_fly_at_their_speed_and_walkers_stay_in_the_area(short):
    uav = short.uav  # (K, 6, 4) [x, y, vx, vy]
    np.testing.assert_allclose(np.hypot(uav[..., 2], uav[..., 3]), 16.6)
    objs = short.chunks().__next__().truth[:, :6, :2]
    assert (objs >= 0).all() and (objs <= 400).all()


@pytest.mark.slow
def test_raster_sets_keep_the_guarantee_end_to_end_and_shrink_like_the_polygons():
    """``estimator.sets: raster``: the raster estimator and the SM-MPC on its fields, 20 s of ib21-fleet-6."""
    from swarmtrack.sim.build import build

    sim = build(load_scenario("ib21-fleet-6", ["duration=1", "estimator.sets=raster"]))
    assert type(sim.stack.estimator).__name__ == "RasterSetMembershipEstimator"
    assert sim.stack.controller.grid is not None and sim.stack.controller.grid.cell == 1.0
    raster = simulate(load_scenario("ib21-fleet-6", ["duration=20", "estimator.sets=raster"])).frame("uavs")
    assert raster["guarantee_violations"].max() == 0 and raster["alarm_all_empty"].max() == 0
    assert (raster["yaw_accel"] != 0).any()
    first, last = raster[raster.t == raster.t.min()], raster[raster.t == raster.t.max()]
    assert last["phi"].mean() < first["phi"].mean() - 20_000  # 20 s of search


def test_raster_sets_with_network_delays_replay_late_messages():
    from swarmtrack.sim.build import build

    sim = build(load_scenario("ib21-fleet-6", ["duration=1", "estimator.sets=raster", "network.delay=0.4",
                                               "estimator.delayed_data=refilter"]))
    assert type(sim.stack.estimator).__name__ == "RasterReplayingSetMembershipEstimator"
    assert sim.stack.estimator.window == 1 and sim.stack.estimator.grid.cell == 1.0


@pytest.mark.parametrize("override, words", [
    ("estimator.sets=voxels", ["estimator.sets", "polygons", "raster"]),
    ("estimator.cell=0", ["estimator.cell"]),
    ("swarm.nav_position_std=0.02", ["swarm.nav_position_std", "no bound"]),
    ("swarm.vehicle=quadrotor", ["footprint needs swarm.vehicle: fixed_wing"]),
    ("estimator.noise_bound=[0, 5]", ["estimator.noise_bound", "positive"]),
    ("sensor.noise_bound=[5, -1]", ["sensor.noise_bound"]),
    ("estimator.area=[0, 0, -1, 400]", ["estimator.area"]),
    ("estimator.period=0.52", ["estimator.period", "whole number"]),
    ("targets.vehicle=quadrotor", ["targets"]),
    ("controller.inputs=[]", ["controller.inputs"]),
    ("rates.physics=40", ["rates.estimation must equal rates.physics"]),
])
def test_settings_that_void_the_guarantee_exit_2_naming_the_field(override, words, refused_ib21):
    refused_ib21(override, words)


@pytest.fixture
def refused_ib21():
    from click.testing import CliRunner

    from swarmtrack.cli import main

    def check(override, words):
        result = CliRunner().invoke(main, ["validate", "ib21-fleet-6", "--set", override])
        assert result.exit_code == 2, result.output
        for w in words:
            assert w in result.output, result.output
        assert "Traceback" not in result.output

    return check


@pytest.mark.slow
def test_the_compiled_walker_and_fixed_wing_steps_fly_the_numpy_run_bit_for_bit():
    """``kernels: auto`` steps the walkers and the fixed wings with their compiled passes, ``numpy`` with the readable
    references: the same truth, to the last bit, and so the same sets and commands."""
    runs = [simulate(load_scenario("ib21-fleet-6", ["duration=6", f"kernels={k}"])) for k in ("numpy", "auto")]
    (ref,), (fast,) = (list(r.chunks()) for r in runs)
    np.testing.assert_array_equal(fast.truth, ref.truth)
    for name, values in ref.probes.items():
        if name != "solve_time":  # the controller's wall time
            np.testing.assert_array_equal(fast.probes[name], values, err_msg=name)
    assert not np.array_equal(ref.truth[-1], ref.truth[0])
