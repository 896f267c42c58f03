import numpy as np
import pytest

from swarmtrack.analysis.metrics import rmse_table, spacing_offset
from swarmtrack.estimation.information import FilterDivergence
from swarmtrack.scenarios import load_scenario
from swarmtrack.scenarios.loader import ScenarioError
from swarmtrack.sim.engine import simulate


@pytest.mark.slow
def test_same_seed_same_recording_and_other_seed_differs():
    a = simulate(load_scenario("l24-ct", ["duration=8"]))
    b = simulate(load_scenario("l24-ct", ["duration=8"]))
    c = simulate(load_scenario("l24-ct", ["duration=8"], seed=2))
    assert np.array_equal(a.estimate, b.estimate) and np.array_equal(a.uav, b.uav)
    assert not np.array_equal(a.estimate, c.estimate)


def test_swarm_tracks_the_estimated_target_and_keeps_spacing():
    rec = simulate(load_scenario("l24-cv", ["target.profile=l23", "duration=40", "sensor.latency=0"]))
    assert rmse_table(rec)["total"]["x"] < 0.1
    dist = np.linalg.norm(rec.uav[-1, :, :2] - rec.target[-1, :2], axis=1)
    assert dist.max() < 6.0
    assert spacing_offset(rec) < 0.3


def test_decentralized_full_with_shared_measurements_equals_centralized_in_closed_loop():
    common = ["duration=5", "network.topology=full", "sensor.update=polar"]
    dec = simulate(load_scenario("l24-ct", [*common, "estimator.share=measurements"]))
    cen = simulate(load_scenario("l24-ct", [*common, "estimator.kind=centralized"]))
    np.testing.assert_allclose(dec.estimate, cen.estimate, rtol=0, atol=1e-9)


@pytest.mark.slow
def test_fusion_reduces_error_spread():
    none = simulate(load_scenario("l23-no-fusion", ["duration=30"]))
    full = simulate(load_scenario("l23-full-fusion", ["duration=30"]))
    assert rmse_table(full)["total"]["x"] < rmse_table(none)["total"]["x"]


@pytest.mark.slow
def test_latency_delays_the_estimate_by_the_target_motion():
    fresh = simulate(load_scenario("l24-cv", ["duration=30", "sensor.latency=0"]))
    late = simulate(load_scenario("l24-cv", ["duration=30", "sensor.latency=0.2"]))
    # linear phase: target moves at 0.5 m/s in x, so a 0.2 s delay biases x by about 0.1 m
    bias = (late.estimate[200:, :, 0] - late.target[200:, None, 0]).mean()
    assert -0.13 < bias < -0.07
    assert abs((fresh.estimate[200:, :, 0] - fresh.target[200:, None, 0]).mean()) < 0.02


def test_divergence_stops_the_run_naming_uav_and_time():
    with pytest.raises(FilterDivergence, match=r"UAV \d"):
        simulate(load_scenario("l24-cv", ["duration=3", "estimator.q=[1.7e308, 1.7e308, 1.7e308, 1.7e308]"]))


@pytest.mark.slow
@pytest.mark.parametrize("name, extra", [
    ("l24-cv", []),  # compiled physics, flocking and CV filter
    ("l24-fs", []),  # compiled physics, flocking and FS filter (in covariance form)
    ("l24-cv", ["network.topology=proximity", "swarm.vehicle=double_integrator", "controller.variant=integral"]),
    ("l24-ct", ["controller.follow=truth", "rates.control=50", "controller.variant=standard"]),  # control ≠ estimation
])
def test_compiled_cv_kernels_give_the_same_run_as_numpy(name, extra):
    common = ["duration=8", *extra]
    ref = simulate(load_scenario(name, [*common, "kernels=numpy"]))
    fast = simulate(load_scenario(name, [*common, "kernels=compiled"]))
    np.testing.assert_allclose(fast.uav, ref.uav, rtol=0, atol=1e-7)
    np.testing.assert_allclose(fast.target, ref.target, rtol=0, atol=1e-7)
    np.testing.assert_allclose(fast.estimate, ref.estimate, rtol=0, atol=1e-7)
    # to rounding on the covariance's own scale, |ΔP_ij| ≤ 1e-7 √(P_ii P_jj): the first steps hold variances near 1e6
    # beside 1e-3 (near-zero initial information), where an entry-wise relative bound would test the rounding of
    # entries far below their matrix's scale (the FS kernel works in covariance form, the reference in information)
    sd = np.sqrt(np.diagonal(ref.covariance, axis1=-2, axis2=-1))
    bound = 1e-7 * sd[..., :, None] * sd[..., None, :]
    np.testing.assert_array_less(np.abs(fast.covariance - ref.covariance), bound + 1e-300)
    nis = [np.concatenate([c.probes["nis"] for c in rec.chunks()]) for rec in (ref, fast)]
    np.testing.assert_allclose(nis[1], nis[0], rtol=1e-6, atol=1e-9)  # estimation.kernels.position_nis
    assert not np.array_equal(fast.uav[-1], fast.uav[0])  # the swarm did move (chasing starts at 1 s)


def test_compiled_kernels_are_deterministic():
    a = simulate(load_scenario("l24-cv", ["duration=4", "kernels=compiled"]))
    b = simulate(load_scenario("l24-cv", ["duration=4", "kernels=compiled"]))
    assert np.array_equal(a.estimate, b.estimate) and np.array_equal(a.uav, b.uav)


@pytest.mark.slow
@pytest.mark.parametrize("model", ["cv", "ca", "ct", "fs"])
@pytest.mark.parametrize("options", [
    ["network.topology=none"],
    ["network.topology=full", "estimator.share=measurements", "sensor.update=polar"],
    ["network.topology=proximity", "network.loss_probability=0.3"],
    ["estimator.kind=centralized", "swarm.vehicle=double_integrator", "kernels=numpy"],
    ["network.topology=edges", "network.edges=[[1, 3]]", "swarm.n_uavs=4", "controller.variant=standard"],
])
def test_every_model_runs_with_every_option_and_tracks(model, options):
    rec = simulate(load_scenario("l24-cv", [f"estimator.model={model}", "duration=12", "sensor.latency=0",
                                            *options]))
    assert np.isfinite(rec.estimate).all()
    assert rmse_table(rec)["total"]["x"] < 0.5


@pytest.mark.parametrize("share", ["information", "measurements"])
def test_a_uav_out_of_sensor_range_learns_only_through_its_links(share):
    # hovering target at the origin; UAVs hold at 1, 5 and 9 m; only UAV 1 is within sensor range
    common = ["duration=6", "sensor.latency=0", "sensor.max_range=2", f"estimator.share={share}",
              "target.profile=hover", "target.wind_std=0", "controller.chase_after_steps=100000",
              "swarm.initial_positions=[[1, 0], [5, 0], [9, 0]]", "estimator.model=cv"]
    line = simulate(load_scenario("l24-cv", [*common, "network.topology=line"]))
    full = simulate(load_scenario("l24-cv", [*common, "network.topology=full"]))

    def err(rec):  # mean error over the last 2 s (one step's error is a few cm: sensor and navigation noise)
        return np.linalg.norm(rec.estimate[-40:, :, :2] - rec.target[-40:, None, :2], axis=-1).mean(axis=0)

    var = np.trace(line.covariance[-1, :, :2, :2], axis1=1, axis2=2)
    assert err(line)[0] < 0.08 and err(line)[1] < 0.08  # UAV 2 hears UAV 1
    assert var[0] < 0.01 and var[1] < 0.01
    assert var[2] > 1e5  # UAV 3 hears only UAV 2, who saw nothing: prediction only
    assert err(full).max() < 0.08  # with a link to UAV 1, UAV 3 converges too
    assert np.trace(full.covariance[-1, 2, :2, :2]) < 0.01


def test_a_duration_that_is_not_a_whole_number_of_steps_runs_to_its_last_whole_step():
    rec = simulate(load_scenario("l24-cv", ["duration=1.5", "rates.estimation=1", "rates.control=1"]))
    assert len(rec.t) == 2  # 1.5 estimation steps round to 2, and the world is sampled that long


def test_a_run_shorter_than_one_estimation_step_is_refused():
    with pytest.raises(ScenarioError, match="shorter than one estimation step"):
        load_scenario("l24-cv", ["duration=0.02"])
