"""The IB21 paper: each claim holds on favourable synthetic metrics and flips with its numbers."""

import pytest

from swarmtrack.analysis.papers import PAPERS, ib21
from swarmtrack.scenarios import builtin_names

# per experiment: (runs that clear X̄ out of 3, time-mean Φ̄, violations per run, alarm per run, fleet solve time)
GOOD = {"ib21-fleet-2": (0, 60000), "ib21-fleet-3": (0, 40000), "ib21-fleet-4": (1, 20000), "ib21-fleet-5": (3, 9000),
        "ib21-fleet-6": (3, 5000), "ib21-speed-1.6": (2, 9000), "ib21-speed-1.8": (0, 15000),
        "ib21-decoys-0": (2, 15000), "ib21-decoys-6": (0, 30000), "ib21-noise-5": (3, 8000),
        "ib21-noise-20": (3, 12000), "ib21-noise-over": (3, 16000), "ib21-noise-under": (3, 7000),
        "ib21-comm-50": (0, 20000), "ib21-comm-100": (1, 10000), "ib21-comm-600": (3, 4000)}
PARTS = {"ib21-decoys-0": (5000, 2000, 1000), "ib21-fleet-4": (5000, 6000, 1500), "ib21-decoys-6": (5000, 9000, 2000)}


def run(name, k, change):
    ok, phi = change.get(name, GOOD[name])
    n_uavs = ib21.FLEET.get(name, 6)
    unexplored, unidentified, identified = PARTS.get(name, (phi / 2, phi / 4, phi / 4))
    under = name == "ib21-noise-under"
    return {"set_membership": {"time_unexplored_cleared": 100.0 if k < ok else None,
                               "guarantee_violations": 2 if under else 0, "empty_set_alarms": 1 if under else 0,
                               "solve_time": {"fleet_mean": 0.003 * n_uavs}},
            "series": {"phi_bar": [phi, phi], "phi_unexplored": [unexplored], "phi_unidentified": [unidentified],
                       "phi_identified": [identified]}}


def verdicts(change=None):
    data = {e: [run(e, k, change or {}) for k in range(3)] for e in ib21.EXPERIMENTS}
    claims, md, _ = ib21.analyse(data)
    assert "X̄ cleared" in md
    return {c.id: c.holds for c in claims}


def test_every_claim_holds_on_favourable_numbers():
    assert all(verdicts().values()), verdicts()


@pytest.mark.parametrize(("change", "broken"), [
    ({"ib21-fleet-3": (1, 40000)}, "ib21-fig8-three-or-fewer"),
    ({"ib21-fleet-4": (3, 20000)}, "ib21-fig8-four-some"),
    ({"ib21-fleet-5": (2, 9000)}, "ib21-fig8-five-or-more"),
    ({"ib21-speed-1.8": (1, 15000)}, "ib21-fig9-speed"),
    ({"ib21-decoys-6": (0, 14000)}, "ib21-fig9-decoys"),
    ({"ib21-noise-20": (3, 17000)}, "ib21-fig10-over-slowest"),
    ({"ib21-comm-100": (1, 30000)}, "ib21-fig11-range"),
])
def test_each_claim_flips_with_its_numbers(change, broken):
    got = verdicts(change)
    assert {k for k, v in got.items() if not v} == {broken}


def test_a_violation_with_a_matched_bound_breaks_the_guarantee_claim(monkeypatch):
    data = {e: [run(e, k, {}) for k in range(3)] for e in ib21.EXPERIMENTS}
    data["ib21-fleet-6"][1]["set_membership"]["guarantee_violations"] = 1
    claims, _, _ = ib21.analyse(data)
    assert not next(c for c in claims if c.id == "ib21-guarantee").holds


def test_registered_with_builtin_experiments():
    assert set(PAPERS["ib21"].experiments) <= set(builtin_names())
