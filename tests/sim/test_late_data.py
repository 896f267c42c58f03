"""Late data in closed loop: L24's 0.15 s sensor latency fused at its time stamps is no longer overconfident and
costs little accuracy; random network delays (reordering) are fused at their stamps with nothing dropped."""

import numpy as np
import pytest

from swarmtrack.analysis.metrics import summary
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.engine import simulate


def _linear(name, *extra):
    s = summary(simulate(load_scenario(name, ["duration=40", *extra])))
    c = s["consistency"]["linear"]
    return c["nees"], c["band"][1], float(np.hypot(s["rmse"]["linear"]["x"], s["rmse"]["linear"]["y"]))


@pytest.mark.slow  # three 40 s runs; tests/estimation/test_refilter.py is the fast tier's
def test_a_sensor_latency_fused_at_its_time_stamp_is_no_longer_overconfident():
    naive, upper, naive_rmse = _linear("l24-cv")
    stamped, _, stamped_rmse = _linear("l24-cv", "estimator.delayed_data=refilter")
    _, _, on_time_rmse = _linear("l24-cv", "sensor.latency=0")
    assert naive > upper  # the paper's filter: the delay makes it overconfident
    assert stamped <= upper
    assert stamped_rmse < naive_rmse and stamped_rmse <= 1.5 * on_time_rmse


@pytest.mark.slow
def test_random_network_delays_are_fused_with_nothing_dropped():
    rec = simulate(load_scenario("robust-5", ["duration=20", "network.delay_max=0.5"]))
    assert np.isfinite(rec.estimate).all()
    s = summary(rec)
    assert s["network"]["stale_per_uav"] == [0.0] * 5
    assert not [w for w in s["warnings"] if w["kind"] in ("lost_target", "stale_data")]


def _make_run_scenario() -> str:
    """The scenario ``make run`` runs (the README's first command), read from the Makefile."""
    from pathlib import Path

    makefile = Path(__file__).resolve().parents[2] / "Makefile"
    recipe = makefile.read_text().split("\nrun:", 1)[1]
    return recipe.split("swarmtrack run ", 1)[1].split()[0]


@pytest.mark.slow  # one whole 100 s run of the default scenario
def test_the_default_scenario_of_make_run_ends_without_a_warning_and_not_overconfident():
    name = _make_run_scenario()
    s = summary(simulate(load_scenario(name)))
    assert s["warnings"] == []
    total = s["consistency"]["total"]
    assert total["nees"] <= total["band"][1]
    # the same swarm with the paper's filter (late data fused as current) is the one that warns
    assert load_scenario(name, ["estimator.delayed_data=as_current"]).model_dump(exclude={"name", "description"}) == \
        load_scenario("l24-ct").model_dump(exclude={"name", "description"})
