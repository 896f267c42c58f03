import numpy as np
import pytest
import scipy.sparse as sp

from swarmtrack.estimation.information import FilterDivergence
from swarmtrack.estimation.kalman import ekf_update
from swarmtrack.estimation.measurements import CameraFrameMeasurement, RangeBearingMeasurement
from swarmtrack.estimation.multimodel import MultiModelEstimator
from swarmtrack.models import make_model
from swarmtrack.network.messages import Inbox
from swarmtrack.network.rows import Rows
from swarmtrack.sensors import camera
from swarmtrack.sensors.detections import Detections

DT = 1 / 30
R = 1e-3
CAMS = np.array([[-1.2, -1.2], [1.2, -1.2], [0.0, 1.3]])


def _estimator(models=("cv", "ca", "ct"), fusion="ttest", solo=0, window=10, occlusion="last", q=5e-6, **kw):
    ms = [make_model(m, DT, [q] * make_model(m, DT).dim) for m in models]
    P0 = {m: np.eye(make_model(m, DT).dim) * 5e-5 for m in models}
    hidden = {"cv": [0.0, 0.0], "ca": [0.0] * 4, "ct": [0.0, 0.0, 1e-5]}
    return MultiModelEstimator(ms, CameraFrameMeasurement(R), fusion_rule=fusion, occlusion=occlusion,
                               window=window, solo_steps=solo, P0=P0,
                               x0_hidden={m: np.asarray(hidden[m]) for m in models}, **kw)


def _detections(target, seen=(True, True, True), rng=None, aim=None):
    """Camera detections of the target by each UAV that sees it (label 0)."""
    aim = np.broadcast_to(target, (3, 2)) if aim is None else aim
    noise = np.zeros((3, 1, 2)) if rng is None else rng.standard_normal((3, 1, 2))
    hidden = ~np.asarray(seen)[:, None]
    det, _ = camera.sense(np.asarray(target, dtype=float)[None], CAMS, CAMS, 1.5, aim, (10.0, 10.0), np.sqrt(R),
                          noise, hidden)
    return det


def _step(est, det, links, t=0.0):
    out = est.share(t, None, det)
    est.fuse(t, det, Inbox(links, out))
    post = est.publish(t)
    if post:
        est.combine(t, Inbox(links, post))


FULL = ~np.eye(3, dtype=bool)


def test_filters_start_from_their_first_measurement():
    """W20 Table 4.1: x̂0 = [h⁻¹(z0); 0] with CT's ω0 = 1e-5, P = P0."""
    est = _estimator()
    _step(est, _detections([0.3, -0.2]), FULL)
    for bank in est._banks:
        np.testing.assert_allclose(bank.x[:, :2], [[0.3, -0.2]], atol=1e-12)
        tail = {"cv": [0, 0], "ca": [0, 0, 0, 0], "ct": [0, 0, 1e-5]}[bank.model.name]
        np.testing.assert_allclose(bank.x[0, 2:], tail)
        np.testing.assert_allclose(bank.P[0], np.eye(bank.model.dim) * 5e-5)
    assert est.initialised.all()


def test_stacked_update_equals_the_block_diagonal_ekf_and_its_likelihood():
    """The position-statistic update equals W20 eqs. 4.10-4.13 on the stacked z with block-diagonal R, and the
    likelihood equals eq. 4.31 on the stacked innovation (m = 6)."""
    rng = np.random.default_rng(1)
    est = _estimator(models=("ct", "ct", "ct"))
    _step(est, _detections([0.0, 0.0], rng=rng), FULL)
    bank = est._banks[0]
    bank.x[:] = [0.05, -0.03, 0.2, 0.1, 0.3]
    bank.P[:] = np.diag([1e-3, 2e-3, 1e-2, 1e-2, 0.1]) + 1e-4
    x0, P0 = bank.x[0].copy(), bank.P[0].copy()
    model = bank.model
    det = _detections([0.1, 0.02], rng=rng)
    out = est.share(0.0, None, det)
    xp, Pp = model.f(x0), model.jacobian(x0) @ P0 @ model.jacobian(x0).T + model.Q
    est.fuse(0.0, det, Inbox(FULL, out))
    # reference: stacked measurements of UAV 1 (own first, then 2 and 3)
    frames = det.frame
    H = np.zeros((6, 5))
    for k in range(3):
        H[2 * k:2 * k + 2, :2] = frames[k, :, :2]
    h = np.concatenate([frames[k, :, :2] @ xp[:2] + frames[k, :, 2] for k in range(3)])
    nu = det.z.reshape(-1) - h
    x_ref, P_ref = ekf_update(xp, Pp, H, R * np.eye(6), nu)
    np.testing.assert_allclose(bank.x[0], x_ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(bank.P[0], P_ref, rtol=1e-8, atol=1e-14)
    S = H @ Pp @ H.T + R * np.eye(6)
    ll = -0.5 * nu @ np.linalg.solve(S, nu) - 0.5 * np.linalg.slogdet(2 * np.pi * S)[1]
    assert est._loglik[0] == pytest.approx(ll, rel=1e-9)
    post = det.z.reshape(-1) - np.concatenate([frames[k, :, :2] @ x_ref[:2] + frames[k, :, 2] for k in range(3)])
    assert est._windows[0, -1] == pytest.approx(post @ post / R / 3, rel=1e-8)  # per measurement, R-weighted


def test_range_bearing_measurements_work_too():
    meas = RangeBearingMeasurement(0.08, 0.02)
    ms = [make_model(m, 0.05) for m in ("cv", "ct")]
    est = MultiModelEstimator(ms, meas, solo_steps=0, P0={"cv": np.eye(4), "ct": np.eye(5)})
    rng = np.random.default_rng(0)
    for k in range(40):
        target = np.array([1.0 + 0.05 * k, 2.0])
        pos = np.array([[0.0, 0.0], [3.0, -1.0]])
        rel = target - pos
        z = np.stack([np.hypot(*rel.T), np.arctan2(rel[:, 1], rel[:, 0])], 1) + rng.normal(0, [0.08, 0.02], (2, 2))
        det = Detections(np.arange(2), z, pos, np.zeros(2, int), 2)
        _step(est, det, ~np.eye(2, dtype=bool), t=k * 0.05)
    assert np.linalg.norm(est.out_x[:, :2] - target, axis=1).max() < 0.1


def test_nobody_shares_during_the_solo_steps():
    """W20 Fig. 4.11: the first samples initialise each filter alone; its neighbours' measurements come later."""
    rng = np.random.default_rng(2)
    together, alone = _estimator(solo=5), _estimator(solo=5)
    for k in range(5):
        det = _detections([0.01 * k, 0.0], rng=rng)
        _step(together, det, FULL)
        _step(alone, det, np.zeros((3, 3), dtype=bool))
    np.testing.assert_array_equal(together.out_x, alone.out_x)
    det = _detections([0.05, 0.0], rng=rng)
    _step(together, det, FULL)
    _step(alone, det, np.zeros((3, 3), dtype=bool))
    assert not np.allclose(together.sample()["own_estimate"], alone.sample()["own_estimate"])


def test_ttest_outputs_the_lowest_residual_and_keeps_each_posterior():
    est = _estimator()
    rng = np.random.default_rng(3)
    _step(est, _detections([0.0, 0.0], rng=rng), FULL)
    est._windows[:] = np.array([[3.0], [1.0], [2.0]])  # UAV 2 (CA) has the smallest mean squared residual
    _step(est, _detections([0.001, 0.0], rng=rng), FULL)
    assert est._winner.tolist() == [1, 1, 1]
    s = est.sample()
    np.testing.assert_array_equal(s["estimate"], np.broadcast_to(s["own_estimate"][1], (3, 4)))
    assert not np.allclose(s["own_estimate"][0], s["own_estimate"][1])  # each UAV keeps its own posterior


@pytest.mark.parametrize("policy", ["last", "trace", "eigenvalue"])
def test_occlusion_predicts_only_and_follows_the_policy(policy):
    """W20 Sec. 4.5: when nobody sees the target, every filter only predicts; the output model follows the policy."""
    est = _estimator(occlusion=policy)
    rng = np.random.default_rng(4)
    for k in range(30):
        _step(est, _detections([0.01 * k, 0.0], rng=rng), FULL, t=k * DT)
    last = est._winner.copy()
    before = [bank.x.copy() for bank in est._banks]
    _step(est, _detections([0.3, 0.0], seen=(False, False, False)), FULL, t=1.0)
    for bank, x in zip(est._banks, before, strict=True):
        np.testing.assert_allclose(bank.x, bank.model.f(x))  # prediction only
    assert not est.sample()["measured"].any()
    P = est._common()[1][:, :2, :2]
    expect = {"last": last, "trace": np.full(3, np.argmin(np.trace(P, axis1=1, axis2=2))),
              "eigenvalue": np.full(3, np.argmin(np.linalg.eigvalsh(P)[:, -1]))}[policy]
    np.testing.assert_array_equal(est._winner, expect)


def test_a_uav_without_measurement_or_neighbours_carries_on():
    """A UAV that sees nothing fuses its neighbours'; a UAV whose neighbours stop sending uses its own alone."""
    est = _estimator()
    rng = np.random.default_rng(5)
    for k in range(20):
        _step(est, _detections([0.01 * k, 0.0], seen=(k % 2 == 0, True, True), rng=rng), FULL, t=k * DT)
    silent = FULL.copy()
    silent[0] = False  # UAV 1 hears nobody
    for k in range(20, 40):
        _step(est, _detections([0.01 * k, 0.0], rng=rng), silent, t=k * DT)
    assert np.isfinite(est.out_x).all()
    assert est._winner[0] == 0  # its only candidate is itself


@pytest.mark.slow
@pytest.mark.parametrize("fusion", ["imm-thesis", "imm", "ml"])
def test_every_fusion_tracks_and_keeps_probabilities_and_covariances_valid(fusion):
    est = _estimator(fusion=fusion)
    rng = np.random.default_rng(6)
    for k in range(90):
        target = [0.5 * np.sin(0.3 * k * DT), 0.15 * k * DT]
        _step(est, _detections(target, rng=rng), FULL, t=k * DT)
    assert np.linalg.norm(est.out_x[:, :2] - target, axis=1).max() < 0.05
    np.linalg.cholesky(est.out_P)
    for bank in est._banks:
        np.linalg.cholesky(bank.P)
    if fusion != "ml":
        np.testing.assert_allclose(est._mu.sum(axis=1), 1.0)
        assert (est._mu >= 0).all()


def test_divergence_names_the_uav_its_model_and_the_time():
    est = _estimator()
    _step(est, _detections([0.0, 0.0]), FULL)
    est._banks[1].P[0] = -np.eye(6)
    with pytest.raises(FilterDivergence, match=r"t = 2\.00 s on UAV 2: the CA filter"):
        _step(est, _detections([0.0, 0.0]), FULL, t=2.0)


def _close(a, b, rtol: float = 1e-12) -> None:
    """Equal to ``rtol`` of the reference's largest finite magnitude, NaN where the reference has NaN (bit for bit
    for what is not a float)."""
    a, b = np.asarray(a), np.asarray(b)
    if b.dtype.kind != "f":
        np.testing.assert_array_equal(a, b)
        return
    finite = np.isfinite(b)
    scale = np.abs(b[finite]).max() if finite.any() else 1.0
    np.testing.assert_allclose(a, b, rtol=rtol, atol=rtol * scale, equal_nan=True)


def _team(worlds: int, fusion: str, occlusion: str = "last", sensor: str = "camera", compiled: bool = False):
    """The W20 team (CV, CA, CT) in each of ``worlds`` worlds of a batch (world b's target labelled b)."""
    models = ("cv", "ca", "ct")
    ms = [make_model(m, DT, [5e-6] * make_model(m, DT).dim) for m in models * worlds]
    P0 = {m: np.eye(make_model(m, DT).dim) * 5e-5 for m in models}
    hidden = {"cv": [0.0, 0.0], "ca": [0.0] * 4, "ct": [0.0, 0.0, 1e-5]}
    meas = CameraFrameMeasurement(R) if sensor == "camera" else RangeBearingMeasurement(0.05, 0.02)
    return MultiModelEstimator(ms, meas, label=np.repeat(np.arange(worlds), 3), fusion_rule=fusion,
                               occlusion=occlusion, solo_steps=3, P0=P0,
                               x0_hidden={m: np.asarray(hidden[m]) for m in models}, compiled=compiled,
                               team=(list(models), Rows(np.arange(3 * worlds), 3 * worlds, worlds)))


def _worlds_detections(targets, seen, rng, sensor: str = "camera") -> Detections:
    """Each world's three UAVs' detections of its own target (UAVs 3b..3b+2, label b), noisy; ``seen`` (B, 3)."""
    parts = []
    for b, (target, s) in enumerate(zip(targets, seen, strict=True)):
        if sensor == "camera":
            det = _detections(target, seen=s, rng=rng)
        else:
            rel = np.asarray(target) - CAMS
            z = np.column_stack([np.hypot(*rel.T), np.arctan2(rel[:, 1], rel[:, 0])]) + rng.normal(0, [0.05, 0.02],
                                                                                                    (3, 2))
            keep = np.flatnonzero(s)
            det = Detections(keep, z[keep], CAMS[keep], np.zeros(len(keep), dtype=int), 3)
        parts.append(Detections(det.owner + 3 * b, det.z, det.sensor_pos, np.full(len(det), b), 3 * len(targets),
                                frame=det.frame))
    frames = [p.frame for p in parts]
    return Detections(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("owner", "z", "sensor_pos", "label")),
                      3 * len(targets), frame=None if frames[0] is None else np.concatenate(frames))


@pytest.mark.parametrize(("fusion", "occlusion", "worlds", "sensor"), [
    ("ttest", "last", 1, "camera"), ("ttest", "trace", 3, "camera"), ("ttest", "eigenvalue", 2, "camera"),
    ("none", "last", 2, "camera"), ("imm", "last", 2, "camera"), ("imm-thesis", "last", 1, "camera"),
    ("ml", "last", 2, "camera"), ("ttest", "last", 2, "range-bearing")])
def test_the_compiled_step_equals_the_numpy_reference(fusion, occlusion, worlds, sensor):
    """The compiled step (multimodel_compiled) records, publishes and shows what the numpy reference does, step by
    step: payloads, misses and starts, the T-test's winners and switches bit for bit, the numbers to 1e-12 of their
    scale; in a batch of worlds, with missed detections, steps where nobody sees the target (the occlusion policy)
    and lossy links in both rounds, dense or in CSR form. (The update inverts the 2 x 2 innovation covariance in
    closed form where the reference solves; the range-bearing sensor's bearing is libm's atan2, numpy's may differ
    in the last bit.)"""
    rng = np.random.default_rng(8)
    ref, fast = _team(worlds, fusion, occlusion, sensor), _team(worlds, fusion, occlusion, sensor, compiled=True)
    assert fast.compiled and not ref.compiled
    block = np.kron(np.eye(worlds, dtype=bool), np.ones((3, 3), dtype=bool))  # a self-loop carries nothing
    for k in range(40):
        t = k * DT
        targets = [[0.3 * np.sin(0.5 * t + b), 0.2 * t - 0.1 * b] for b in range(worlds)]
        seen = rng.random((worlds, 3)) > 0.25
        if k in (12, 13, 14, 20):
            seen[:] = False  # nobody sees the target: the occlusion policy
        det = _worlds_detections(targets, seen, rng, sensor)
        links = [block & (rng.random(block.shape) > 0.3) for _ in range(2)]  # each round's losses
        if worlds == 3:
            links = [sp.csr_array(a) for a in links]  # a large swarm's form
        sent = [est.share(t, None, det) for est in (ref, fast)]
        for a, b in zip(sent[1].values(), sent[0].values(), strict=True):
            np.testing.assert_array_equal(a, b)
        for est, out in zip((ref, fast), sent, strict=True):
            est.fuse(t, det, Inbox(links[0], out))
        posts = [est.publish(t) for est in (ref, fast)]
        assert posts[0].keys() == posts[1].keys()
        for name in posts[0]:
            _close(posts[1][name], posts[0][name])
        if posts[0]:
            for est, post in zip((ref, fast), posts, strict=True):
                est.combine(t, Inbox(links[1], post))
        for name, value in ref.sample().items():
            _close(fast.sample()[name], value)
        views = [est.view() for est in (ref, fast)]
        assert views[1].model.tolist() == views[0].model.tolist()
        _close(views[1].state, views[0].state)
        _close(views[1].motion, views[0].motion)
        for a, b in zip(fast._banks, ref._banks, strict=True):
            _close(a.x, b.x)
            _close(a.P, b.P)
    assert fast.initialised.all() and (fast._winner >= 0).all()


def test_the_compiled_update_names_a_diverged_filter_too():
    est = _estimator(compiled=True)
    _step(est, _detections([0.0, 0.0]), FULL)
    est._banks[2].P[0] = -np.eye(5)
    with pytest.raises(FilterDivergence, match=r"UAV 3: the CT filter"):
        _step(est, _detections([0.0, 0.0]), FULL, t=1.0)
