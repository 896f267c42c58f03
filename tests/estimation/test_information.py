import numpy as np
import pytest

from swarmtrack.estimation.information import (
    FilterDivergence,
    FusionCentre,
    InformationSharing,
    MeasurementSharing,
    RangeBearingUpdate,
    add_position_information,
    check_information,
    initial_information,
    predict,
    recover,
)
from swarmtrack.estimation.information import InformationEstimator as OnboardEstimators
from swarmtrack.estimation.kalman import ekf_predict, ekf_update
from swarmtrack.models import make_model
from swarmtrack.network.messages import Inbox
from swarmtrack.network.topology import adjacency
from swarmtrack.sensors.detections import Detections
from swarmtrack.sensors.range_bearing import (
    measure,
    polar_model,
    position_covariance,
    to_position,
    wrap_angle,
)

SIG = (0.08, 0.02)


def _truth_track(steps, dt, rng):
    """A turning target: [x, y, vx, vy]."""
    x = np.array([0.0, 0.0, 1.0, 0.3])
    out = []
    for k in range(steps):
        w = 0.2 * np.sin(0.05 * k)
        c, s = np.cos(w * dt), np.sin(w * dt)
        x = np.array([x[0] + dt * x[2], x[1] + dt * x[3], c * x[2] - s * x[3], s * x[2] + c * x[3]])
        out.append(x.copy())
    return np.array(out)


@pytest.mark.parametrize("mode", ["position", "polar"])
@pytest.mark.parametrize("model_name", ["cv", "ct", "fs"])
def test_information_filter_equals_covariance_ekf(mode, model_name):
    rng = np.random.default_rng(3)
    dt = 0.05
    model = make_model(model_name, dt)
    sensors = np.array([[-3.0, -4.0], [2.0, -5.0], [0.0, 6.0]])
    upd = RangeBearingUpdate(*SIG, mode=mode)
    x = model.initial_state() + np.r_[0.1, -0.2, 0.9, 0.2, np.zeros(model.dim - 4)]
    P = np.eye(model.dim) * 0.5
    Y = np.linalg.inv(P)[None]
    y = (Y[0] @ x)[None]
    xc, Pc = x.copy(), P.copy()
    for target in _truth_track(60, dt, rng):
        z = measure(target[:2], sensors, *SIG, rng)
        # information form
        xi, Pi = recover(Y, y)
        Yp, yp, xp = predict(model, xi, Pi)
        I, i = upd.contributions(xp[:, :2], sensors, z)
        Y, y = add_position_information(Yp, yp, I.sum(0, keepdims=True), i.sum(0, keepdims=True))
        # covariance form with stacked measurements, linearised at the same prediction
        xc, Pc = ekf_predict(model, xc, Pc)
        H = np.zeros((2 * len(sensors), model.dim))
        if mode == "position":
            rel = xc[:2] - sensors
            R = position_covariance(np.hypot(*rel.T), np.arctan2(rel[:, 1], rel[:, 0]), *SIG)
            H[0::2, 0] = H[1::2, 1] = 1.0
            nu = (to_position(z, sensors) - xc[:2]).ravel()
        else:
            h, Hp = polar_model(xc[:2], sensors, min_range=upd.min_range)
            R = np.broadcast_to(np.diag(np.square(SIG)), (len(sensors), 2, 2))
            for k in range(len(sensors)):
                H[2 * k:2 * k + 2, :2] = Hp[k]
            d = z - h
            d[:, 1] = wrap_angle(d[:, 1])
            nu = d.ravel()
        from scipy.linalg import block_diag
        xc, Pc = ekf_update(xc, Pc, H, block_diag(*R), nu)
        xi, Pi = recover(Y, y)
        np.testing.assert_allclose(xi[0], xc, rtol=1e-7, atol=1e-8)
        np.testing.assert_allclose(Pi[0], Pc, rtol=1e-6, atol=1e-9)


def _step_bank(bank, nav_pos, z, links, t):
    n = len(z)
    own = Detections(np.arange(n), z, nav_pos, np.zeros(n, dtype=int), n)
    outbox = bank.share(t, nav_pos, own)
    bank.fuse(t, own, Inbox(links, outbox))
    return bank.estimates()


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["position", "polar"])
@pytest.mark.parametrize("share", ["measurements", "information"])
def test_full_topology_equals_centralized_ekf(mode, share):
    rng = np.random.default_rng(7)
    dt, n = 0.05, 4
    model = make_model("ct", dt)
    upd = RangeBearingUpdate(*SIG, mode=mode)
    dec = OnboardEstimators(model, upd, n, sharing=InformationSharing() if share == "information" else
                            MeasurementSharing())
    cen = OnboardEstimators(model, upd, n, sharing=FusionCentre())
    full = adjacency("full", n)
    sensors = rng.uniform(-6, 6, size=(n, 2))
    for k, target in enumerate(_truth_track(200, dt, rng)):
        sensors = sensors + 0.02 * rng.standard_normal(sensors.shape)
        z = measure(target[:2], sensors, *SIG, rng)
        xd, Pd = _step_bank(dec, sensors, z, full, k * dt)
        xc, Pc = _step_bank(cen, sensors, z, full, k * dt)
        np.testing.assert_allclose(xd, xc, rtol=0, atol=1e-9)
        np.testing.assert_allclose(Pd, Pc, rtol=1e-8, atol=1e-10)
    assert np.linalg.norm(xc[0, :2] - target[:2]) < 0.2


def test_line_topology_middle_uav_is_most_certain():
    rng = np.random.default_rng(1)
    model = make_model("cv", 0.05)
    bank = OnboardEstimators(model, RangeBearingUpdate(*SIG), 3)
    sensors = np.array([[-4.0, -3.0], [0.0, -4.0], [4.0, -3.0]])
    for k, target in enumerate(_truth_track(100, 0.05, rng)):
        _, P = _step_bank(bank, sensors, measure(target[:2], sensors, *SIG, rng), adjacency("line", 3), k * 0.05)
    tr = np.trace(P[:, :2, :2], axis1=1, axis2=2)
    assert tr[1] < tr[0] and tr[1] < tr[2]


def test_no_topology_filters_are_independent():
    rng = np.random.default_rng(2)
    model = make_model("cv", 0.05)
    sensors = np.array([[-4.0, -3.0], [0.0, -4.0], [4.0, -3.0]])
    bank = OnboardEstimators(model, RangeBearingUpdate(*SIG), 3)
    alone = OnboardEstimators(model, RangeBearingUpdate(*SIG), 1)
    for k, target in enumerate(_truth_track(50, 0.05, rng)):
        z = measure(target[:2], sensors, *SIG, rng)
        x, _ = _step_bank(bank, sensors, z, adjacency("none", 3), k * 0.05)
        xa, _ = _step_bank(alone, sensors[1:2], z[1:2], adjacency("none", 1), k * 0.05)
    np.testing.assert_allclose(x[1], xa[0], atol=1e-12)


def test_near_zero_initial_information_is_a_vague_prior():
    model = make_model("fs", 0.05)
    Y, y = initial_information(model, 3, 1e-6)
    x, P = recover(Y, y)
    assert np.allclose(P[:, :4, :4], 1e6 * np.eye(4))
    assert np.all(np.diagonal(P, axis1=1, axis2=2)[:, 4:] < 10.0)
    assert np.allclose(x[:, 11], model.initial_state()[11])


def test_divergence_names_the_uav_and_time():
    Y = np.broadcast_to(np.eye(4), (3, 4, 4)).copy()
    y = np.zeros((3, 4))
    check_information(Y, y, 0.0)
    y[2, 1] = np.nan
    with pytest.raises(FilterDivergence, match=r"t = 1.50 s on UAV 3"):
        check_information(Y, y, 1.5)
    y[2, 1] = 0.0
    Y[0, 0, 0] = -1.0
    with pytest.raises(FilterDivergence, match="UAV 1.*not positive definite"):
        check_information(Y, y, 2.0)


def test_own_position_uncertainty_adds_to_the_measurement_covariance():
    """R + σ²I exactly in position form; the polar form agrees to first order (the UAV's own navigation error,
    issue 11)."""
    from swarmtrack.estimation.information import RangeBearingUpdate, _inv2
    from swarmtrack.sensors.range_bearing import position_covariance

    rng = np.random.default_rng(4)
    sensor = rng.uniform(-5, 5, (200, 2))
    rel = rng.uniform(-4, 4, (200, 2))
    x_pos = sensor + rel
    z = np.column_stack([np.hypot(rel[:, 0], rel[:, 1]), np.arctan2(rel[:, 1], rel[:, 0])])
    own = 0.02
    I, _ = RangeBearingUpdate(0.08, 0.02, own_sigma=own).contributions(x_pos, sensor, z)
    R = position_covariance(z[:, 0], z[:, 1], 0.08, 0.02) + own**2 * np.eye(2)
    np.testing.assert_allclose(_inv2(I), R, rtol=1e-9, atol=1e-15)
    I_polar, _ = RangeBearingUpdate(0.08, 0.02, mode="polar", own_sigma=own).contributions(x_pos, sensor, z)
    np.testing.assert_allclose(I_polar, I, rtol=1e-9)  # exact at the measured point: H Hᵀ = diag(1, 1/ρ²)
    I_plain, _ = RangeBearingUpdate(0.08, 0.02).contributions(x_pos, sensor, z)
    assert (np.linalg.eigvalsh(I_plain - I) > 0).all()  # less information than without the own error
