import numpy as np
import pytest

from swarmtrack.estimation.imm import IMMInformationEstimator
from swarmtrack.estimation.information import (
    FilterDivergence,
    InformationEstimator,
    InformationSharing,
    MeasurementSharing,
    RangeBearingUpdate,
)
from swarmtrack.models import make_model
from swarmtrack.network.messages import Inbox
from swarmtrack.network.topology import adjacency
from swarmtrack.scenarios import ScenarioError, load_scenario
from swarmtrack.sensors.detections import Detections
from swarmtrack.sensors.range_bearing import measure

SIG = (0.08, 0.02)
DT = 0.05
SENSORS = np.array([[-4.0, -3.0], [0.0, -4.0], [4.0, -3.0]])


def _turning_track(steps, turn=0.4):
    """A target flying straight for a while, then turning at ``turn`` rad/s: [x, y, vx, vy] per step."""
    x = np.array([0.0, 0.0, 1.0, 0.3])
    out = []
    for k in range(steps):
        w = turn if k > steps // 3 else 0.0
        c, s = np.cos(w * DT), np.sin(w * DT)
        x = np.array([x[0] + DT * x[2], x[1] + DT * x[3], c * x[2] - s * x[3], s * x[2] + c * x[3]])
        out.append(x.copy())
    return np.array(out)


def _step(est, z, links, t, sensors=SENSORS):
    n = len(z)
    seen = ~np.isnan(z[:, 0])
    own = Detections(np.flatnonzero(seen), z[seen], sensors[seen], np.zeros(seen.sum(), dtype=int), n)
    est.fuse(t, own, Inbox(links, est.share(t, sensors, own)))


def _measurements(steps, seed, blind_every=7):
    """Noisy range-bearing measurements of the turning track; UAV 1 misses every ``blind_every``-th one."""
    rng = np.random.default_rng(seed)
    zs = []
    for k, target in enumerate(_turning_track(steps)):
        z = measure(target[:2], SENSORS, *SIG, rng)
        if k % blind_every == 3:
            z[0] = np.nan
        zs.append(z)
    return zs


@pytest.mark.slow
@pytest.mark.parametrize("share", ["information", "measurements"])
@pytest.mark.parametrize("name", ["cv", "ct", "fs"])
def test_one_model_equals_the_information_estimator(name, share):
    model = make_model(name, DT)
    upd = RangeBearingUpdate(*SIG)
    sharing = InformationSharing() if share == "information" else MeasurementSharing()
    plain = InformationEstimator(model, upd, 3, sharing=sharing, fake_vz_sigma=0.05)
    imm = IMMInformationEstimator([model], upd, 3, share=share, fake_vz_sigma=0.05)
    links = adjacency("line", 3)
    for k, z in enumerate(_measurements(80, 1)):
        _step(plain, z, links, k * DT)
        _step(imm, z, links, k * DT)
        (x, P), = imm.members()
        np.testing.assert_array_equal(x, plain.x)
        np.testing.assert_array_equal(P, plain.P)
        np.testing.assert_array_equal(imm.view().state, plain.x[:, :4])
        np.testing.assert_array_equal(imm.sample()["covariance"], plain.P[:, :4, :4])
        np.testing.assert_allclose(imm.sample()["nis"], plain.sample()["nis"], rtol=1e-9, equal_nan=True)
    assert np.all(imm.sample()["probability"] == 1.0)


@pytest.mark.slow
@pytest.mark.parametrize("force_mixing", [False, True])
def test_identity_markov_bank_members_equal_their_single_model_filters(force_mixing):
    """With rho = I nothing is mixed: every member is its model's own filter (share: measurements, each member
    linearising at its own prediction). ``force_mixing`` runs the interaction kernels anyway: they are then the
    identity up to rounding."""
    names = ["cv", "ct", "fs"]
    upd = RangeBearingUpdate(*SIG)
    imm = IMMInformationEstimator([make_model(m, DT) for m in names], upd, 3, share="measurements",
                                  markov=np.eye(3), fake_vz_sigma=0.05)
    imm._mixing = force_mixing
    single = [InformationEstimator(make_model(m, DT), upd, 3, sharing=MeasurementSharing(), fake_vz_sigma=0.05)
              for m in names]
    links = adjacency("line", 3)
    for k, z in enumerate(_measurements(60, 2)):
        _step(imm, z, links, k * DT)
        for est in single:
            _step(est, z, links, k * DT)
    for (x, P), est in zip(imm.members(), single, strict=True):
        if force_mixing:
            np.testing.assert_allclose(x, est.x, rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(P, est.P, rtol=1e-7, atol=1e-12)
        else:
            np.testing.assert_array_equal(x, est.x)
            np.testing.assert_array_equal(P, est.P)


@pytest.fixture(scope="module")
def default_bank_run():
    """The default bank (CV, CT, FS; 0.98 stay) on a straight-then-turning target, every step's probabilities,
    output covariances and mixed priors."""
    imm = IMMInformationEstimator([make_model(m, DT) for m in ("cv", "ct", "fs")], RangeBearingUpdate(*SIG), 3,
                                  fake_vz_sigma=0.05)
    links = adjacency("line", 3)
    mus, covs, mixed = [], [], []
    zs = _measurements(240, 3)
    for k, z in enumerate(zs):
        mixed.append(imm._mix()[1])
        _step(imm, z, links, k * DT)
        mus.append(imm.sample()["probability"].copy())
        covs.append(imm.sample()["covariance"].copy())
    return imm, np.array(mus), np.array(covs), mixed, _turning_track(len(zs))[-1]


@pytest.mark.slow
def test_probabilities_stay_normalised_and_non_negative(default_bank_run):
    _, mus, _, _, _ = default_bank_run
    assert mus.shape == (240, 3, 3)
    assert np.all(mus >= 0.0)
    np.testing.assert_allclose(mus.sum(axis=-1), 1.0, rtol=0, atol=1e-12)
    assert mus[-1, :, 1].mean() > 0.5  # on the turn the CT member carries the most weight


@pytest.mark.slow
def test_combined_covariance_is_spd(default_bank_run):
    imm, _, covs, _, target = default_bank_run
    np.testing.assert_array_equal(covs, np.swapaxes(covs, -1, -2))
    assert np.all(np.linalg.eigvalsh(covs)[..., 0] > 0)
    assert np.all(np.linalg.norm(imm.view().state[:, :2] - target[:2], axis=1) < 0.1)


def test_mixing_across_sizes_keeps_every_member_spd(default_bank_run):
    imm, _, _, mixed, _ = default_bank_run
    for P0 in mixed:
        for P in P0:
            np.testing.assert_array_equal(P, np.swapaxes(P, -1, -2))
            np.linalg.cholesky(P)
    # a strongly switching chain mixes much more of every member into the others
    imm.rho = np.full((3, 3), 1.0 / 3.0)
    x0, P0, mu_pred = imm._mix()
    for x, P, model in zip(x0, P0, imm.models, strict=True):
        assert x.shape == (3, model.dim) and P.shape == (3, model.dim, model.dim)
        assert np.all(np.linalg.eigvalsh(P)[:, 0] > 0)
    np.testing.assert_allclose(x0[0], x0[1][:, :4], atol=1e-12)  # every member gets the same common block
    np.testing.assert_allclose(x0[2][:, :4], x0[1][:, :4], atol=1e-12)
    np.testing.assert_allclose(mu_pred, 1.0 / 3.0)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_divergence_names_the_uav_and_the_model():
    upd = RangeBearingUpdate(*SIG)
    imm = IMMInformationEstimator([make_model("cv", DT), make_model("ct", DT, [1.7e308] * 5)], upd, 3)
    with pytest.raises(FilterDivergence, match=r"UAV 1, UAV 2, UAV 3: the CT model's filter"):
        for k, z in enumerate(_measurements(5, 4)):
            _step(imm, z, adjacency("line", 3), k * DT)


@pytest.mark.parametrize("override, field", [
    ("estimator.markov=[[1, 0], [0, 1]]", r"estimator\.markov.*2 x 2; models lists 3"),
    ("estimator.markov=[[0.9, 0.2, 0], [0, 1, 0], [0, 0, 1]]", r"estimator\.markov.*row 1 sums to 1\.1"),
    ("estimator.markov=[[1.1, -0.1, 0], [0, 1, 0], [0, 0, 1]]", r"estimator\.markov.*negative"),
    ("estimator.models=[cv, ca]", r"estimator\.models"),
    ("estimator.models=[cv, spiral]", r"estimator\.models"),
    ("estimator.q=[null, [1, 2]]", r"estimator\.q.*2 entries; models lists 3"),
])
def test_schema_refuses_bad_markov_and_unknown_models_naming_the_field(override, field):
    with pytest.raises(ScenarioError, match=field):
        load_scenario("l24-imm", [override])


@pytest.mark.slow
def test_l24_imm_short_run_tracks():
    from swarmtrack.analysis.metrics import summary
    from swarmtrack.sim.engine import simulate

    rec = simulate(load_scenario("l24-imm", ["duration=10"], seed=1))
    rmse = summary(rec)["rmse"]["total"]
    assert rmse["x"] < 0.3 and rmse["y"] < 0.3 and rmse["vx"] < 0.5 and rmse["vy"] < 0.5
    assert "probability" in rec.meta["probes"]
