"""GOSPA and OSPA between a set of estimates and the true objects: equal to Stone Soup's on the same sets, and the
metric's own properties (its split adds up, a missed object and a false one each cost c^p / alpha)."""

from __future__ import annotations

import datetime

import numpy as np
import pytest

from swarmtrack.analysis.gospa import gospa, ospa

stonesoup = pytest.importorskip("stonesoup")
from stonesoup.metricgenerator.ospametric import GOSPAMetric, OSPAMetric  # noqa: E402
from stonesoup.types.state import State  # noqa: E402

NOW = datetime.datetime(2026, 12, 6)


def _states(points) -> list:
    return [State(np.asarray(p, dtype=float).reshape(-1, 1), timestamp=NOW) for p in points]


def _sets(rng, n: int, m: int, k: int = 2, spread: float = 30.0):
    truths = rng.uniform(0, 200, (m, k))
    near = truths[rng.integers(0, m, n)] + rng.normal(0, spread, (n, k)) if m else rng.uniform(0, 200, (n, k))
    return near, truths


@pytest.mark.parametrize("p", [1.0, 2.0])
def test_gospa_equals_stone_soups_on_the_same_sets(p):
    rng = np.random.default_rng(40)
    metric = GOSPAMetric(c=10.0, p=p)
    for n, m in [(10, 10), (8, 12), (15, 9), (0, 6), (5, 0), (1, 1), (30, 25)] * 5:
        estimates, truths = _sets(rng, n, m)
        ours = gospa(estimates, truths, c=10.0, p=p)
        theirs = metric.compute_gospa_metric(_states(estimates), _states(truths))[0].value
        for name in ("distance", "localisation", "missed", "false"):
            assert getattr(ours, name) == pytest.approx(theirs[name], abs=1e-9, rel=1e-12), (name, n, m)


def test_ospa_equals_stone_soups_on_the_same_sets():
    rng = np.random.default_rng(41)
    metric = OSPAMetric(c=10.0, p=1.0)
    for n, m in [(10, 10), (8, 12), (15, 9), (0, 6), (5, 0), (1, 1)] * 5:
        estimates, truths = _sets(rng, n, m)
        theirs = metric.compute_OSPA_distance(_states(estimates), _states(truths)).value
        assert ospa(estimates, truths, c=10.0, p=1.0) == pytest.approx(theirs, abs=1e-9, rel=1e-12)


def test_the_split_adds_up_and_each_missed_or_false_object_costs_c_to_the_p_over_alpha():
    truths = np.array([[0.0, 0.0], [50.0, 0.0], [100.0, 0.0]])
    estimates = np.array([[3.0, 4.0], [50.0, 20.0], [200.0, 0.0], [201.0, 0.0]])  # 5 m off, 20 m off, two false
    g = gospa(estimates, truths, c=10.0, p=2.0)
    assert (g.n_missed, g.n_false) == (2, 3)  # the truth 20 m from its estimate is missed, that estimate false
    assert g.localisation == pytest.approx(25.0) and g.missed == pytest.approx(2 * 50.0)
    assert g.false == pytest.approx(3 * 50.0)
    assert g.distance == pytest.approx(np.sqrt(25.0 + 100.0 + 150.0))
    assert g.assignment.tolist() == [0, -1, -1, -1]
    assert gospa(truths, truths, c=10.0).distance == 0.0 and gospa([], [], c=10.0).distance == 0.0


def test_with_alpha_below_2_far_pairs_are_assigned_at_the_cut_off():
    g = gospa([[0.0, 0.0]], [[30.0, 0.0]], c=10.0, p=1.0, alpha=1.0)
    assert (g.n_missed, g.n_false, g.localisation, g.distance) == (0, 0, 10.0, 10.0)  # c < 2 c / alpha


def test_bad_parameters_are_refused():
    for kwargs in ({"c": 0.0}, {"c": 1.0, "p": 0.5}, {"c": 1.0, "alpha": 3.0}):
        with pytest.raises(ValueError, match="GOSPA needs"):
            gospa([[0.0]], [[1.0]], **kwargs)
