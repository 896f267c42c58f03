"""A UAV cut off from the network for a while (``network.outages``) and rejoining: the filters and the flocking carry
on with the rest, nothing turns NaN, and the UAV's own filter keeps tracking on its own measurements."""

import numpy as np

from swarmtrack.analysis.metrics import summary
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate


def test_a_uav_that_drops_out_and_rejoins_breaks_nothing():
    outage = "network.outages=[{uavs: [2], window: [10, 25]}]"
    cut = simulate(load_scenario("l24-cv", ["duration=40", "network.topology=full", outage]))
    clean = simulate(load_scenario("l24-cv", ["duration=40", "network.topology=full"]))
    assert np.isfinite(cut.estimate).all() and np.isfinite(cut.uav).all()
    during = (cut.t >= 10) & (cut.t < 25)
    err = np.linalg.norm(cut.estimate[..., :2] - cut.target[:, None, :2], axis=-1)
    assert err[during].max() < 1.0  # every UAV still tracks (UAV 2 on its own measurements)
    # alone, UAV 2's covariance is larger than when it fused its neighbours' information
    p_cut = cut.covariance[during][:, 1, 0, 0].mean()
    p_clean = clean.covariance[during][:, 1, 0, 0].mean()
    assert p_cut > 1.5 * p_clean
    after = cut.t >= 30  # rejoined: fused again
    assert cut.covariance[after][:, 1, 0, 0].mean() < 1.2 * clean.covariance[after][:, 1, 0, 0].mean()
    assert not summary(cut)["warnings"] or all(w["kind"] != "lost_target" for w in summary(cut)["warnings"])
