"""IB21's set-membership estimator on polygon sets, built for one UAV (or a pair) of ``ib21-fleet-6``: replayed with
the whole swarm's inputs restricted to those UAVs, it gives the swarm's rows bit for bit (issue 22's onboard build),
also when every set it receives is a copy (round-tripped through WKB: what a UAV's own process gets from the
network) instead of the object the swarm's estimator shares between UAVs, and with late messages replayed
(Sec. 4.5). The fusion of one UAV is a function of its own group alone (:func:`setmembership.fuse`)."""

from __future__ import annotations

import importlib.util
import pathlib

import numpy as np
import pytest
import shapely

from swarmtrack.estimation import polygons as pg
from swarmtrack.estimation.setmembership import Beliefs, fuse
from swarmtrack.network.messages import Inbox
from swarmtrack.scenarios import load_scenario


def _load_onboard_helpers():
    """``record`` and ``replay_estimator`` of tests/sim/test_onboard_subsets.py (a test file, not a package)."""
    path = pathlib.Path(__file__).resolve().parents[1] / "sim" / "test_onboard_subsets.py"
    spec = importlib.util.spec_from_file_location("_onboard_subsets_helpers", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


onboard = _load_onboard_helpers()

CASES = {
    "polygons": ["estimator.sets=polygons"],
    "polygons-delays": ["estimator.sets=polygons", "estimator.delayed_data=refilter", "network.delay_max=1.2"],
}
DURATION = {"polygons-delays": 8}


def _copies(value):
    """An array of payload rows with every set replaced by a value-equal copy (WKB out and in): no object shared with
    the swarm's estimator, nor between rows."""
    value = np.asarray(value)
    if value.dtype != object:
        return value
    out = value.copy()
    flat = out.reshape(-1)
    geoms = np.array([isinstance(g, shapely.Geometry) for g in flat], dtype=bool)
    if geoms.any():
        flat[geoms] = shapely.from_wkb(shapely.to_wkb(flat[geoms]))
    return out


def copied(inbox: Inbox) -> Inbox:
    """``inbox`` with every set a copy, each part separately (the swarm's parts of one time share one outbox)."""
    return Inbox(inbox.links, {k: _copies(v) for k, v in inbox.payloads.items()},
                 tuple(copied(p) for p in inbox.late), inbox.receivers)


def copied_log(log: list) -> list:
    out = []
    for method, args, result in log:
        if method == "fuse":
            t, own, inbox = args
            args = (t, own, copied(inbox))
        out.append((method, args, result))
    return out


@pytest.fixture(scope="module", params=[pytest.param(name, marks=pytest.mark.slow) for name in sorted(DURATION)])
def recorded(request):
    scenario = load_scenario("ib21-fleet-6", [*CASES[request.param], f"duration={DURATION[request.param]}"], seed=3)
    ctx, log, _ = onboard.record(scenario)
    return ctx, log, request.param


def _subsets(n: int) -> list[list[int]]:
    return [[i] for i in range(n)] + [[0, n - 1]]


def test_each_uav_on_polygons_estimates_exactly_as_the_whole_swarm_from_copies_of_the_sets(recorded):
    """Replaying late sets (Sec. 4.5) with every set received a copy; the plain polygons case replays from the shared
    sets in tests/sim/test_onboard_subsets.py, and from copies in the fast tier below."""
    ctx, log, _ = recorded
    heard = [len(part.edges()[0]) for method, args, _ in log if method == "fuse" for part in args[2].parts()]
    assert sum(heard) > 0  # it did fuse something
    log = copied_log(log)
    for uavs in _subsets(ctx.n_uavs):
        onboard.replay_estimator(ctx, log, uavs)


def test_one_uav_and_a_pair_from_copies_of_the_sets_on_a_short_run():
    """The fast tier's case: 4 s (8 fusions), UAV 4 alone (whose sets differed in their last bits at the first
    fusion when the order was chosen over the round) and the pair [0, 5], every set received a copy."""
    scenario = load_scenario("ib21-fleet-6", [*CASES["polygons"], "duration=4"], seed=3)
    ctx, log, _ = onboard.record(scenario)
    log = copied_log(log)
    for uavs in ([4], [0, 5]):
        onboard.replay_estimator(ctx, log, uavs)


def test_the_delayed_case_replays_late_sets(recorded):
    ctx, log, name = recorded
    late = [out[0]["late"] for method, _, out in log if method == "sample"]
    assert np.sum(late) > 0  # the replay (Sec. 4.5) was exercised


AREA = shapely.box(0, 0, 200, 200)


def _blobs(rng, n, radius):
    return shapely.union_all(shapely.buffer(shapely.points(rng.uniform(0, 200, (n, 2))), radius))


def _swarm_of_five(rng) -> Beliefs:
    """Five UAVs' corrected sets: X̄ of two lineages (UAVs 0-2 share one base object, 3-4 another), each UAV's own
    footprints cut; Xᵁ and two identified sets, some shared between UAVs as objects."""
    b = Beliefs.start(5, 2, AREA)
    bases = [shapely.difference(AREA, _blobs(rng, 6, 15.0)), shapely.difference(AREA, _blobs(rng, 6, 15.0))]
    unid = _blobs(rng, 3, 8.0)
    for i in range(5):
        cut = shapely.box(*(c := rng.uniform(0, 160, 2)), *(c + 40))
        b.base[i], b.cut[i] = bases[0 if i < 3 else 1], cut
        b.unexplored[i] = shapely.difference(b.base[i], cut)
        b.unidentified[i] = unid if i % 2 else shapely.difference(unid, cut)
        b.identified[i, 0] = _blobs(rng, 1, 6.0)
        b.identified[i, 1] = b.identified[0, 1] if i in (0, 4) else pg.EMPTY
    return b


def _wkb_copy(b: Beliefs) -> Beliefs:
    c = b.copy()
    for name in ("unexplored", "unidentified", "identified", "base", "cut"):
        a = getattr(c, name)
        a[...] = shapely.from_wkb(shapely.to_wkb(a))
    return c


def _same(a: Beliefs, b: Beliefs, i: int) -> bool:
    sets = [(a.unexplored[i], b.unexplored[i]), (a.unidentified[i], b.unidentified[i]),
            *zip(a.identified[i], b.identified[i], strict=True)]
    return all(bool(shapely.equals_identical(x, y)) for x, y in sets)


LINKS = (np.array([0, 0, 1, 1, 1, 2, 2, 3, 3, 4, 4]), np.array([1, 2, 0, 2, 3, 0, 1, 1, 4, 0, 3]))


@pytest.mark.parametrize("seed", [1, 2])
def test_a_uavs_fusion_depends_only_on_its_own_group_and_the_values_of_its_sets(seed):
    """Fused in the whole round (shared objects), or alone (its own links only, every set a copy), or with the
    senders' links listed in another order: UAV i's fused sets are equal bit for bit."""
    rng = np.random.default_rng(seed)
    sent = _swarm_of_five(rng)
    whole = sent.copy()
    fuse(whole, *LINKS, sent)
    recv, send = LINKS
    for i in range(5):
        mine = recv == i
        alone = _wkb_copy(sent)
        fuse(alone, recv[mine], send[mine][::-1], _wkb_copy(sent))
        assert _same(whole, alone, i), i
        assert all(_same(alone, sent, k) for k in range(5) if k != i)  # nobody else touched


def test_the_canonical_fusion_is_still_an_outer_approximation():
    """Eqs. 34-37 as fused (loosened operands, in the canonical order) contain the exact fusion."""
    rng = np.random.default_rng(3)
    sent = _swarm_of_five(rng)
    got = sent.copy()
    fuse(got, *LINKS, sent)
    recv, send = LINKS
    for i in range(5):
        group = np.r_[i, send[recv == i]]
        bars, us = sent.unexplored[group], sent.unidentified[group]
        exact_bar = shapely.intersection_all(bars)
        exact_u = shapely.intersection_all([shapely.union_all(us)]
                                           + [shapely.union_all([u, x]) for u, x in zip(us, bars, strict=True)])
        for exact, fused in ((exact_bar, got.unexplored[i]), (exact_u, got.unidentified[i])):
            assert shapely.difference(exact, fused).area < 1e-9
            assert shapely.hausdorff_distance(fused, exact) <= 5 * pg.LOOSEN + 1e-9
