"""The compiled physics (vehicles/kernels.py, World.advance) against the numpy reference (quadrotor.step,
double_integrator.step, velocity_tracking_accel, World.step)."""

import numpy as np
import pytest

from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.world import World
from swarmtrack.vehicles import QuadrotorParams, double_integrator, kernels, quadrotor, velocity_tracking_accel

DT = 0.01
TOL = 1e-9  # the kernel repeats the reference's operations; only sin/cos/atan/hypot come from another libm


def _random_quads(rng, m):
    state = np.zeros((m, 8), order="F")
    state[:, 0:2] = rng.uniform(-20, 20, (m, 2))
    state[:, 2:4] = rng.normal(0, 2, (m, 2))
    state[:, 4:6] = rng.normal(0, 0.3, (m, 2))  # tilted, spinning: exercises the moment clip
    state[:, 6:8] = rng.normal(0, 2, (m, 2))
    return state


@pytest.mark.parametrize("params", [
    QuadrotorParams(),
    QuadrotorParams(max_thrust=1.2 * 1.5 * 9.81, max_tilt=0.9, max_moment=0.5),  # thrust and moment clips
    QuadrotorParams(Ixx=0.02, Iyy=0.04, max_moment=0.2),  # unequal inertias: per-axis moment limit
])
@pytest.mark.parametrize("vehicle", ["quadrotor", "double_integrator"])
def test_advance_equals_reference_steps(params, vehicle):
    rng = np.random.default_rng(3)
    n, ticks, lag = 7, 300, 4
    quads = _random_quads(rng, 1 + n if vehicle == "quadrotor" else 1)
    points = np.ascontiguousarray(rng.normal(0, 3, (n, 4))) if vehicle == "double_integrator" else np.empty((0, 4))
    v_cmd, a_ff, wind = (rng.normal(0, s, (ticks + 5, 2)) for s in (2.0, 0.5, 0.3))
    gain = 1.5
    history = np.zeros((lag, 1 + n, 2))
    consts = kernels.params_tuple(params)
    ref_q, ref_p = quads.copy(order="F"), points.copy()
    ref_hist = history.copy()
    tick = 0
    while tick < ticks:
        cmd = rng.normal(0, 8, (n, 2))  # up to well beyond g·tan(max_tilt): the tilt clip
        run = int(rng.integers(1, 6))
        kernels.advance(quads, points, cmd, v_cmd, a_ff, wind, tick, run, gain, DT, consts, history)
        for k in range(tick, tick + run):
            a = velocity_tracking_accel(v_cmd[k], ref_q[0, 2:4], a_ff[k], gain) + wind[k]
            accel = np.concatenate([a[None], cmd]) if vehicle == "quadrotor" else a[None]
            ref_q = quadrotor.step(ref_q, accel, params, DT)
            if vehicle == "double_integrator":
                ref_p = double_integrator.step(ref_p, cmd, DT)
            slot = ref_hist[(k + 1) % lag]
            slot[0] = ref_q[0, :2]
            slot[1:] = ref_q[1:, :2] if vehicle == "quadrotor" else ref_p[:, :2]
        tick += run
        np.testing.assert_allclose(quads, ref_q, rtol=TOL, atol=TOL)
        np.testing.assert_allclose(points, ref_p, rtol=TOL, atol=TOL)
        np.testing.assert_allclose(history, ref_hist, rtol=TOL, atol=TOL)
    if vehicle == "quadrotor":
        assert np.abs(quads[1:, 4:6]).max() > 0.3  # the UAVs did reach large tilts


def test_advance_refuses_ticks_beyond_the_sampled_profile():
    quads, hist = np.zeros((1, 8), order="F"), np.zeros((1, 1, 2))
    profile = np.zeros((10, 2))
    with pytest.raises(IndexError):
        kernels.advance(quads, np.empty((0, 4)), np.zeros((0, 2)), profile, profile, profile, 8, 3, 1.0, DT,
                        kernels.params_tuple(QuadrotorParams()), hist)


@pytest.mark.parametrize("vehicle", ["quadrotor", "double_integrator"])
def test_world_advance_equals_world_steps(vehicle):
    scn = load_scenario("l24-cv", [f"swarm.vehicle={vehicle}", "sensor.latency=0.15", "swarm.n_uavs=5",
                                   "target.wind_std=0.5"])
    ref = World(scn, np.random.default_rng(1), DT, 20.0)
    fast = World(scn, np.random.default_rng(1), DT, 20.0, compiled=True)
    rng = np.random.default_rng(2)
    for _ in range(300):
        cmd = rng.normal(0, 3, (5, 2))
        for _ in range(5):
            ref.step(cmd)
        fast.advance(cmd, 5)
        np.testing.assert_allclose(fast.uavs, ref.uavs, rtol=TOL, atol=TOL)
        np.testing.assert_allclose(fast.target, ref.target, rtol=TOL, atol=TOL)
    assert fast.t == ref.t and fast._tick == ref._tick == 1500
    np.testing.assert_allclose(fast._history, ref._history, rtol=TOL, atol=TOL)
    # the delayed measurements read the same ring buffer slot
    z_ref, pose_ref, _ = ref.measure_target()
    z_fast, pose_fast, _ = fast.measure_target()
    np.testing.assert_allclose(z_fast, z_ref, rtol=TOL, atol=TOL)
    np.testing.assert_allclose(pose_fast, pose_ref, rtol=TOL, atol=TOL)


def test_numpy_world_advance_is_the_reference_loop():
    scn = load_scenario("l24-cv", ["swarm.n_uavs=2"])
    a = World(scn, np.random.default_rng(0), DT, 5.0)
    b = World(scn, np.random.default_rng(0), DT, 5.0)
    cmd = np.array([[1.0, -0.5], [0.2, 0.3]])
    a.advance(cmd, 7)
    for _ in range(7):
        b.step(cmd)
    assert np.array_equal(a.uavs, b.uavs) and np.array_equal(a.target, b.target) and a.t == b.t
