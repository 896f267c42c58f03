"""A 3-D run's altitude section (capabilities/tracking_swarm/metrics.py): the RMSE of z and vz and the NEES of
[x, y, vx, vy, z, vz] equal their direct computation from the recording; a planar run has no such section."""

import numpy as np
import pytest

from swarmtrack.analysis.metrics import chase_window, summary
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate


@pytest.fixture(scope="module")
def run_3d():
    return simulate(load_scenario("l24-ct", ["duration=8", "sensor.kind=range_bearing_elevation",
                                             "estimator.model=ct3d", "estimator.delayed_data=refilter"]))


def test_the_altitude_section_equals_its_direct_computation(run_3d):
    rec = run_3d
    s = summary(rec)["altitude"]["total"]
    chunks = list(rec.chunks())
    keep = np.concatenate([chase_window(rec, c.t) for c in chunks])
    est = np.concatenate([c.probes["estimate"] for c in chunks])[keep]
    cov = np.concatenate([c.probes["covariance"] for c in chunks])[keep]
    truth = np.concatenate([np.concatenate([c.truth, c.altitude], axis=-1) for c in chunks])[keep, rec.tracked]
    err = est[..., :6] - truth[:, None, :]
    rmse = np.sqrt((err[..., 4:6] ** 2).mean(axis=0)).mean(axis=0)
    assert s["z"] == pytest.approx(rmse[0], rel=1e-12) and s["vz"] == pytest.approx(rmse[1], rel=1e-12)
    nees = np.einsum("kna,kna->kn", err, np.linalg.solve(cov[..., :6, :6], err[..., None])[..., 0])
    assert s["nees"] == pytest.approx(nees.mean(), rel=1e-9)
    assert s["band"][0] < 6 < s["band"][1]


def test_a_planar_run_has_no_altitude_section():
    assert "altitude" not in summary(simulate(load_scenario("l24-ct", ["duration=3"])))
