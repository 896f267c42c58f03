"""The range-bearing-elevation update in information form (estimation/elevation.py): it is the EKF's update, a
target level with its sensors gives the planar update with the altitude decoupled, and a decentralized-style
information filter over CV in 3-D gives the planar filter's numbers for a planar target."""

import numpy as np
import pytest

from swarmtrack.estimation import information
from swarmtrack.estimation.elevation import POSITION_3D, RangeBearingElevationUpdate
from swarmtrack.estimation.information import add_position_information
from swarmtrack.estimation.kalman import ekf_update
from swarmtrack.models import make_model
from swarmtrack.sensors import elevation_bearing_range as ebr

SIG = (0.08, 0.02, 0.02)


@pytest.mark.parametrize("mode", ["position", "spherical"])
def test_the_information_update_equals_the_ekf_update(mode):
    rng = np.random.default_rng(0)
    model = make_model("ct3d", 0.05)
    ix = list(POSITION_3D)
    x = rng.normal(0, 2, model.dim)
    A = rng.normal(0, 0.3, (model.dim, model.dim))
    P = A @ A.T + 0.05 * np.eye(model.dim)
    sensors = rng.uniform(-6, 6, (3, 3))
    truth = x[ix] + rng.normal(0, 0.2, 3)
    z = ebr.measure(np.broadcast_to(truth, (3, 3)), sensors, *SIG, rng=rng)
    upd = RangeBearingElevationUpdate(*SIG, mode=mode, own_sigma=0.02)
    I, i = upd.contributions(np.broadcast_to(x[ix], (3, 3)), sensors, z)
    Y, y = np.linalg.inv(P), np.linalg.solve(P, x)
    Y, y = add_position_information(Y, y, I.sum(0), i.sum(0), POSITION_3D)
    got_x, got_P = information.recover(Y, y)

    H = np.zeros((9, model.dim))
    if mode == "position":  # a linear measurement of the converted positions
        R = np.zeros((9, 9))
        for k in range(3):
            H[3 * k:3 * k + 3, ix] = np.eye(3)
            R[3 * k:3 * k + 3, 3 * k:3 * k + 3] = np.linalg.inv(I[k])
        nu = (ebr.to_position(z, sensors) - x[ix]).ravel()
    else:
        h, Hp = ebr.spherical_model(np.broadcast_to(x[ix], (3, 3)), sensors)
        own = 0.02**2
        rel = x[ix] - sensors
        R = np.diag(np.concatenate([[SIG[0]**2 + own, SIG[1]**2 + own / np.sum(r[:2]**2), SIG[2]**2 + own / (r @ r)]
                                    for r in rel]))
        for k in range(3):
            H[3 * k:3 * k + 3, ix] = Hp[k]
        nu = z - h
        nu[:, 1] = (nu[:, 1] + np.pi) % (2 * np.pi) - np.pi
        nu = nu.ravel()
    want_x, want_P = ekf_update(x, P, H, R, nu)
    np.testing.assert_allclose(got_x, want_x, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(got_P, want_P, rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("mode", ["position", "spherical"])
def test_a_target_level_with_its_sensors_gives_the_planar_update_and_a_decoupled_altitude(mode):
    rng = np.random.default_rng(1)
    sensors = rng.uniform(-6, 6, (20, 3))
    x_pos = rng.uniform(-6, 6, (20, 3))
    x_pos[:, 2] = sensors[:, 2] = 4.0
    z = ebr.measure(x_pos + rng.normal(0, 0.1, (20, 3)) * [1, 1, 0], sensors, *SIG, rng=rng)
    z[:, 2] = 0.0  # a level measurement
    I, i = RangeBearingElevationUpdate(*SIG, mode=mode, own_sigma=0.02).contributions(x_pos, sensors, z)
    planar = information.RangeBearingUpdate(*SIG[:2], mode="position" if mode == "position" else "polar",
                                            own_sigma=0.02)
    I2, i2 = planar.contributions(x_pos[:, :2], sensors[:, :2], z[:, :2])
    np.testing.assert_allclose(I[:, :2, :2], I2, rtol=1e-12)
    np.testing.assert_allclose(i[:, :2], i2, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(I[:, :2, 2], 0.0, atol=1e-12 * np.abs(I).max())
    np.testing.assert_allclose(i[:, 2] / I[:, 2, 2], 4.0, rtol=1e-12)  # the altitude it implies


def test_an_information_filter_in_3d_gives_the_planar_filters_numbers_for_a_level_target():
    """CV in 3-D, three sensors at the target's altitude: every step's horizontal estimate and covariance equal the
    planar CV filter's on the same measurements to 1e-9 (the altitude decoupled)."""
    rng = np.random.default_rng(2)
    cv3, cv2 = make_model("cv3d", 0.1), make_model("cv", 0.1)
    truth = np.array([0.0, 0.0, 0.5, 0.2, 3.0, 0.0])
    Y3, _ = information.initial_information(cv3, 1)
    y3 = Y3 @ (truth * [0, 0, 0, 0, 1, 0])  # the prior knows the altitude (the target is planar), nothing else
    Y2, y2 = information.initial_information(cv2, 1)
    sensors = np.array([[-4.0, 1.0, 3.0], [2.0, -5.0, 3.0], [5.0, 4.0, 3.0]])
    upd3 = RangeBearingElevationUpdate(*SIG)
    upd2 = information.RangeBearingUpdate(*SIG[:2])
    for k in range(60):
        truth = cv3.f(truth)
        z = ebr.measure(np.broadcast_to(truth[[0, 1, 4]], (3, 3)), sensors, *SIG, rng=rng)
        z[:, 2] = 0.0
        if k:
            x3, P3 = information.recover(Y3, y3)
            x2, P2 = information.recover(Y2, y2)
            Y3, y3, xp3 = information.predict(cv3, x3, P3)
            Y2, y2, xp2 = information.predict(cv2, x2, P2)
        else:
            xp3 = np.broadcast_to(truth + [0.5, 0.5, 0.5, 0.5, 0, 0], (1, 6))
            xp2 = xp3[:, :4]
        I3, i3 = upd3.contributions(np.broadcast_to(xp3[0, [0, 1, 4]], (3, 3)), sensors, z)
        I2, i2 = upd2.contributions(np.broadcast_to(xp2[0, :2], (3, 2)), sensors[:, :2], z[:, :2])
        Y3, y3 = add_position_information(Y3, y3, I3.sum(0), i3.sum(0), POSITION_3D)
        Y2, y2 = information.add_position_information(Y2, y2, I2.sum(0), i2.sum(0))
        x3, P3 = information.recover(Y3, y3)
        x2, P2 = information.recover(Y2, y2)
        np.testing.assert_allclose(x3[0, :4], x2[0], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(P3[0, :4, :4], P2[0], rtol=1e-9, atol=1e-12)
    assert abs(x3[0, 4] - 3.0) < 0.05  # the altitude is estimated too


# --- the estimators in 3-D: a level target gives the planar numbers -----------------------------------------------


def _level_run(est3, est2, steps=40, seed=3):
    """Three UAVs on a line topology at the target's altitude (3 m); returns the two estimators after ``steps``,
    comparing their horizontal outputs at every step."""
    from swarmtrack.network.messages import Inbox
    from swarmtrack.network.topology import adjacency
    from swarmtrack.sensors.detections import Detections

    rng = np.random.default_rng(seed)
    sensors = np.array([[-4.0, -3.0, 3.0], [0.0, -4.0, 3.0], [4.0, -3.0, 3.0]])
    links = adjacency("line", 3)
    target = np.array([0.0, 0.0, 1.0, 0.3, 3.0, 0.0])
    cv3 = make_model("cv3d", 0.05)
    for k in range(steps):
        target = cv3.f(target)
        z = ebr.measure(np.broadcast_to(target[[0, 1, 4]], (3, 3)), sensors, *SIG, rng=rng)
        z[:, 2] = 0.0  # level
        if k % 7 == 3:
            z[0] = np.nan  # UAV 1 misses one now and then
        seen = ~np.isnan(z[:, 0])
        for est, d in ((est3, 3), (est2, 2)):
            own = Detections(np.flatnonzero(seen), z[seen][:, :d], sensors[seen][:, :d],
                             np.zeros(seen.sum(), dtype=int), 3)
            est.fuse(k * 0.05, own, Inbox(links, est.share(k * 0.05, sensors[:, :d], own)))
        yield est3.sample(), est2.sample()


def _known_altitude(est, z=3.0):
    """Give every member's prior the target's altitude (the target is planar; nothing else known)."""
    for x in ([est.x] if not isinstance(est.x, list) else est.x):
        x[:, 4] = z


def test_an_information_filter_in_3d_is_the_planar_one_for_a_level_target():
    from swarmtrack.estimation.information import InformationEstimator, RangeBearingUpdate

    est3 = InformationEstimator(make_model("cv3d", 0.05), RangeBearingElevationUpdate(*SIG), 3)
    est2 = InformationEstimator(make_model("cv", 0.05), RangeBearingUpdate(*SIG[:2]), 3)
    _known_altitude(est3)
    for s3, s2 in _level_run(est3, est2):
        np.testing.assert_allclose(s3["estimate"][:, :4], s2["estimate"], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(s3["covariance"][:, :4, :4], s2["covariance"], rtol=1e-9, atol=1e-12)
    assert np.abs(s3["estimate"][:, 4] - 3.0).max() < 1e-9


def test_an_imm_in_3d_is_the_planar_imm_for_a_level_target():
    """CV and CT in 3-D share the altitude's model: the altitude adds the same likelihood to both, so the mode
    probabilities, the mixing and the horizontal output are the planar IMM's."""
    from swarmtrack.estimation.imm import IMMInformationEstimator
    from swarmtrack.estimation.information import RangeBearingUpdate

    est3 = IMMInformationEstimator([make_model("cv3d", 0.05), make_model("ct3d", 0.05)],
                                   RangeBearingElevationUpdate(*SIG), 3)
    est2 = IMMInformationEstimator([make_model("cv", 0.05), make_model("ct", 0.05)], RangeBearingUpdate(*SIG[:2]), 3)
    _known_altitude(est3)
    for s3, s2 in _level_run(est3, est2):
        np.testing.assert_allclose(s3["probability"], s2["probability"], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(s3["estimate"][:, :4], s2["estimate"], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(s3["covariance"][:, :4, :4], s2["covariance"], rtol=1e-9, atol=1e-12)
    assert s3["estimate"].shape == (3, 6) and np.isfinite(s3["nis"]).all()
