"""The compiled 3-D CV cycle (estimation/kernels_3d.py) equals the readable reference (information.predict,
elevation.RangeBearingElevationUpdate, elevation.add_position_information, information.recover)."""

import numpy as np

from swarmtrack.estimation import information
from swarmtrack.estimation.elevation import POSITION_3D, RangeBearingElevationUpdate
from swarmtrack.estimation.information import add_position_information
from swarmtrack.estimation.kernels import POSTERIOR_NOT_PD, PREDICT_NOT_PD
from swarmtrack.estimation.kernels_3d import cv3d_cycle, cv3d_position_contributions, cv3d_predicted_position
from swarmtrack.models import make_model
from swarmtrack.sensors import elevation_bearing_range as ebr

SIG = (0.08, 0.02, 0.03)
DT = 0.05
N = 64


def _scene(seed=0):
    rng = np.random.default_rng(seed)
    target = rng.uniform(-10, 10, (N, 3))
    sensors = target + rng.uniform(-6, 6, (N, 3))
    sensors[:3] = target[:3]  # on the target, and straight above and below it: the floors
    sensors[1, 2] += 4.0
    sensors[2, 2] -= 4.0
    z = ebr.measure(target, sensors, *SIG, rng=rng)
    return rng, target, sensors, z


def test_the_compiled_contributions_equal_the_reference_floors_included():
    rng, target, sensors, z = _scene()
    x_pred = target + rng.normal(0, 0.3, target.shape)
    x_pred[0] = sensors[0]  # the prediction on the sensor
    for own in (0.0, 0.02**2):
        want = RangeBearingElevationUpdate(*SIG, min_range=0.05, own_sigma=np.sqrt(own)).contributions(
            x_pred, sensors, z)
        got = cv3d_position_contributions(x_pred, sensors, z, *SIG, 0.05, own)
        np.testing.assert_allclose(got[0], want[0], rtol=1e-12, atol=1e-12 * np.abs(want[0]).max())
        np.testing.assert_allclose(got[1], want[1], rtol=1e-11, atol=1e-10)


def test_the_compiled_cycle_equals_the_information_form_reference_over_many_cycles():
    """From the near-zero initial information (P = 1e6) the first covariance-form update cancels about six digits,
    and a filter forgets such a difference slowly: the first cycle is compared at 1e-6, then both continue from the
    reference's state at round-off."""
    rng, target, sensors, z = _scene(1)
    model = make_model("cv3d", DT)
    q = np.ascontiguousarray(np.diag(model.Q))
    xr, Pr = information.recover(*information.initial_information(model, N))
    upd = RangeBearingElevationUpdate(*SIG, min_range=0.05)
    for k in range(40):
        z = ebr.measure(target, sensors, *SIG, rng=rng)
        if k in (0, 3):
            x, P = xr.copy(), Pr.copy()
        Yp, yp, xp = information.predict(model, xr, Pr)
        I, i = upd.contributions(xp[:, [0, 1, 4]], sensors, z)
        xr, Pr = information.recover(*add_position_information(Yp, yp, I, i, POSITION_3D))

        Ik, ik = cv3d_position_contributions(cv3d_predicted_position(x, DT), sensors, z, *SIG, 0.05)
        assert not cv3d_cycle(x, P, DT, q, Ik, ik).any()
        if k == 0 or k >= 3:
            # the three agents on the floors (on the sensor, straight above and below it) hold about 1e6 times more
            # information across the line of sight than along it: their round-off is that much larger
            for agents, tol in ((slice(3, None), 1e-10), (slice(0, 3), 1e-7)):
                tol = 1e-6 if k == 0 else tol
                np.testing.assert_allclose(x[agents], xr[agents], rtol=tol, atol=tol)
                np.testing.assert_allclose(P[agents], Pr[agents], rtol=tol, atol=tol * np.abs(Pr[agents]).max())
    assert np.abs(x[3:, [0, 1, 4]] - target[3:]).max() < 0.5


def test_a_covariance_that_is_not_positive_definite_is_flagged_and_left_nan():
    x = np.zeros((2, 6))
    P = np.broadcast_to(np.eye(6), (2, 6, 6)).copy()
    P[0, 5, 5] = -1.0
    I = np.broadcast_to(np.eye(3), (2, 3, 3)).copy()
    I[1] = -5.0 * np.eye(3)  # information that makes the posterior indefinite
    flags = cv3d_cycle(x, P, DT, np.full(6, 1e-4), I, np.zeros((2, 3)))
    assert flags[0] == PREDICT_NOT_PD and flags[1] == POSTERIOR_NOT_PD
    assert np.isnan(x).all() and np.isnan(P).all()


def test_an_information_estimator_in_3d_runs_the_compiled_cycle_with_the_numpy_cycles_numbers():
    """Three UAVs sharing information on a line, a climbing target: the compiled cycle (covariance form) and the
    numpy reference give the same estimates. From a prior of 1e-2 (not the near-zero one, whose first covariance-form
    update cancels digits) they agree to 1e-9."""
    from swarmtrack.estimation.information import InformationEstimator
    from swarmtrack.estimation.information_compiled import CompiledCycle, compiled_cycle
    from swarmtrack.network.messages import Inbox
    from swarmtrack.network.topology import adjacency
    from swarmtrack.sensors.detections import Detections

    model = make_model("cv3d", DT)
    upd = RangeBearingElevationUpdate(*SIG)
    est_c = InformationEstimator(model, upd, 3, initial_info=1e-2)
    est_c.cycle = compiled_cycle(model, upd, est_c.sharing)
    assert isinstance(est_c.cycle, CompiledCycle)
    est_n = InformationEstimator(model, upd, 3, initial_info=1e-2)
    rng = np.random.default_rng(4)
    sensors = np.array([[-4.0, -3.0, 5.0], [0.0, -4.0, 6.0], [4.0, -3.0, 5.5]])
    links = adjacency("line", 3)
    target = np.array([0.0, 0.0, 1.0, 0.3, 1.0, 0.4])
    for k in range(60):
        target = model.f(target)
        z = ebr.measure(np.broadcast_to(target[[0, 1, 4]], (3, 3)), sensors, *SIG, rng=rng)
        own = Detections(np.arange(3), z, sensors, np.zeros(3, dtype=int), 3)
        for est in (est_c, est_n):
            est.fuse(k * DT, own, Inbox(links, est.share(k * DT, sensors, own)))
        np.testing.assert_allclose(est_c.x, est_n.x, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(est_c.P, est_n.P, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(est_c.nis, est_n.nis, rtol=1e-8)
    assert np.abs(est_c.x[:, [0, 1, 4]] - target[[0, 1, 4]]).max() < 0.3
