"""The compiled physics (vehicles/kernels.py, World.advance) against the numpy reference (quadrotor.step,
double_integrator.step, velocity_tracking_accel, World.step)."""

import numpy as np
import pytest

from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.build import build
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
    QuadrotorParams(max_roll_pitch=np.radians(5.0)),  # W20 Sec. 5.4.2: roll and pitch setpoints saturated at 5°
    "rows",  # the driven quadrotor at the defaults, the commanded ones at 5°: a parameter set per row
])
@pytest.mark.parametrize("vehicle", ["quadrotor", "double_integrator"])
def test_advance_equals_reference_steps(params, vehicle):
    # one driven quadrotor (a target flying a profile) and n commanded vehicles of the given kind, plus one
    # driven double integrator (a decoy) when the commanded ones are double integrators
    rng = np.random.default_rng(3)
    n, ticks, lag = 7, 300, 4
    quad = vehicle == "quadrotor"
    quads = _random_quads(rng, 1 + n if quad else 1)
    if params == "rows":
        params = quadrotor.per_row([None] + [QuadrotorParams(max_roll_pitch=np.radians(5.0))] * (len(quads) - 1))
        assert isinstance(params, quadrotor.RowParams) == quad
    points = np.ascontiguousarray(rng.normal(0, 3, (0 if quad else n + 1, 4)))
    drivers = 1 if quad else 2
    v_cmd, a_ff, wind = (rng.normal(0, s, (ticks + 5, drivers, 2)) for s in (2.0, 0.5, 0.3))
    gains = np.array([1.5, 0.8][:drivers])
    quad_driver = np.array([0] + [-1] * (n if quad else 0))
    point_driver = np.array([] if quad else [-1] * n + [1], dtype=np.int64)
    quad_obj = np.arange(len(quads))
    point_obj = len(quads) + np.arange(len(points))
    history = np.zeros((lag, len(quads) + len(points), 2))
    consts = kernels.params_tuple(params)
    ref_q, ref_p = quads.copy(order="F"), points.copy()
    ref_hist = history.copy()
    tick, reached = 0, 0.0
    while tick < ticks:
        cmd = rng.normal(0, 8, (n, 2))  # up to well beyond g·tan(max_tilt): the tilt clip
        quad_cmd = np.zeros((len(quads), 2))
        point_cmd = np.zeros((len(points), 2))
        if quad:
            quad_cmd[1:] = cmd
        else:
            point_cmd[:n] = cmd
        run = int(rng.integers(1, 6))
        kernels.advance((quads, quad_cmd, quad_driver, quad_obj), (points, point_cmd, point_driver, point_obj),
                        (v_cmd, a_ff, wind, gains), tick, run, DT, consts, history)
        for k in range(tick, tick + run):
            a = velocity_tracking_accel(v_cmd[k, 0], ref_q[0, 2:4], a_ff[k, 0], gains[0]) + wind[k, 0]
            accel = np.concatenate([a[None], cmd]) if quad else a[None]
            ref_q = quadrotor.step(ref_q, accel, params, DT)
            if not quad:
                a = velocity_tracking_accel(v_cmd[k, 1], ref_p[n, 2:4], a_ff[k, 1], gains[1]) + wind[k, 1]
                ref_p = double_integrator.step(ref_p, np.concatenate([cmd, a[None]]), DT)
            slot = ref_hist[(k + 1) % lag]
            slot[:len(quads)] = ref_q[:, :2]
            slot[len(quads):] = ref_p[:, :2]
        tick += run
        np.testing.assert_allclose(quads, ref_q, rtol=TOL, atol=TOL)
        np.testing.assert_allclose(points, ref_p, rtol=TOL, atol=TOL)
        np.testing.assert_allclose(history, ref_hist, rtol=TOL, atol=TOL)
        reached = max(reached, np.abs(quads[1:, 4:6]).max() if quad else 0.0)
    if quad:  # the UAVs did reach large tilts, or their per-axis limit
        limit = params.sets[1].max_roll_pitch if isinstance(params, quadrotor.RowParams) else params.max_roll_pitch
        assert reached > (0.3 if limit is None else 0.99 * limit)


def test_advance_refuses_ticks_beyond_the_sampled_profile():
    quads, hist = np.zeros((1, 8), order="F"), np.zeros((1, 1, 2))
    profile = np.zeros((10, 1, 2))
    none = np.zeros(0, dtype=np.int64)
    with pytest.raises(IndexError):
        kernels.advance((quads, np.zeros((1, 2)), np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64)),
                        (np.empty((0, 4)), np.zeros((0, 2)), none, none), (profile, profile, profile, np.ones(1)), 8,
                        3, DT, kernels.params_tuple(QuadrotorParams()), hist)


def _world(overrides, kernels_kind):
    return build(load_scenario("l24-cv", [*overrides, f"kernels={kernels_kind}"])).world


@pytest.mark.slow
@pytest.mark.parametrize("vehicle", ["quadrotor", "double_integrator"])
def test_world_advance_equals_world_steps(vehicle):
    common = [f"swarm.vehicle={vehicle}", "sensor.latency=0.15", "swarm.n_uavs=5", "target.wind_std=0.5",
              "decoys.members=[{profile: l23, start: [3, 3]}]", "decoys.vehicle=double_integrator"]
    ref, fast = _world(common, "numpy"), _world(common, "compiled")
    rng = np.random.default_rng(2)
    for _ in range(300):
        cmd = rng.normal(0, 3, (5, 2))
        for _ in range(5):
            ref.advance({"uavs": cmd}, 1)
        fast.advance({"uavs": cmd}, 5)
        np.testing.assert_allclose(fast.truth(), ref.truth(), rtol=TOL, atol=TOL)
    assert fast.t == ref.t and fast._tick == ref._tick == 1500
    np.testing.assert_allclose(fast._history, ref._history, rtol=TOL, atol=TOL)
    # the delayed measurements read the same ring buffer slot
    det_ref, src_ref = ref.sense()
    det_fast, src_fast = fast.sense()
    np.testing.assert_allclose(det_fast.z, det_ref.z, rtol=TOL, atol=TOL)
    np.testing.assert_allclose(det_fast.sensor_pos, det_ref.sensor_pos, rtol=TOL, atol=TOL)
    assert np.array_equal(src_ref, src_fast) and len(det_ref) == 5 * 2  # every UAV sees the target and the decoy


def test_numpy_world_advance_is_the_reference_loop():
    a, b = _world(["swarm.n_uavs=2"], "numpy"), _world(["swarm.n_uavs=2"], "numpy")
    cmd = np.array([[1.0, -0.5], [0.2, 0.3]])
    a.advance({"uavs": cmd}, 7)
    for _ in range(7):
        b.advance({"uavs": cmd}, 1)
    assert np.array_equal(a.truth(), b.truth()) and a.t == b.t
