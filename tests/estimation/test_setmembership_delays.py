"""IB21 Sec. 4.5, delayed messages for the set-membership estimator (ReplayingSetMembershipEstimator): the guarantee
holds with random delays, a late message gives the sets an on-time one would have given and never larger sets than
ignoring it, sets older than the window are dropped and counted, and with nothing late nothing changes. The same
replay on raster sets (RasterReplayingSetMembershipEstimator) gives the on-time sets exactly."""

import numpy as np
import pytest
import shapely

from swarmtrack.estimation import polygons as pg
from swarmtrack.estimation import raster as rs
from swarmtrack.estimation.setmembership import (
    UNLABELLED,
    ReplayingSetMembershipEstimator,
    SetMembershipEstimator,
)
from swarmtrack.network.channel import Channel
from swarmtrack.network.messages import Inbox
from swarmtrack.sensors.detections import Detections

AREA = shapely.box(0, 0, 200, 200)
N, N_T, SIDE, SPEED, BOUND, DT, PERIOD = 3, 3, 60.0, 1.0, 4.0, 0.1, 0.5
FULL = ~np.eye(N, dtype=bool)


def world(seed: int, steps: int):
    """Per estimation step: the targets' true positions and every UAV's frame (square footprints sweeping the area,
    every target inside detected with box noise, identified at a random tenth of the frames), drawn once so that runs
    that differ only in what the network delivers see the same world."""
    rng = np.random.default_rng(seed)
    objs = rng.uniform(20, 180, (N_T, 2))
    out = []
    for k in range(steps):
        t = k * DT
        heading = rng.uniform(-np.pi, np.pi, N_T)
        objs = np.clip(objs + SPEED * DT * np.column_stack([np.cos(heading), np.sin(heading)]), 0, 200)
        sweep = (16 * t) % 140
        centres = np.array([[30 + sweep, 30 + 70 * (k // 44 % 3)], [170 - sweep, 170 - 70 * (k // 44 % 3)],
                            [30 + 70 * (k // 44 % 3), 170 - sweep]])
        corners = centres[:, None, :] + SIDE / 2 * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
        owner, source = np.nonzero(np.all(np.abs(objs[None] - centres[:, None]) <= SIDE / 2, axis=2))
        z = objs[source] + rng.uniform(-BOUND, BOUND, (len(source), 2))
        label = np.where(rng.random(len(source)) < 0.1, source, UNLABELLED)
        out.append((objs.copy(), Detections(owner, z, centres[owner], label, N, footprint=corners)))
    return out


def run(est, frames, deliver, steps=None, totals=None):
    """Drive ``est`` through ``frames`` (the steps ``steps``, default all); ``deliver(k, outbox)`` gives step k's
    inbox. Returns the guarantee violations counted on the UAVs whose sets describe the step (the truth-side monitor's
    rule); adds the ``late`` and ``stale`` probes of every step to ``totals`` (as the recorder and the health check
    do: a message counts once)."""
    violations = 0
    for k in range(len(frames)) if steps is None else steps:
        objs, det = frames[k]
        t = k * DT
        est.fuse(t, det, deliver(k, est.share(t, None, det)))
        now = est.current(t)
        violations += int((~est.containing(objs, np.arange(N_T))[now]).sum())
        if totals is not None:  # every step, as the recorder sums them
            for name in totals:
                totals[name] += est.sample()[name].sum()
    return violations


def make(window: int = 0, sets: str = "polygons"):
    kw = dict(speed=SPEED, bound=(BOUND, BOUND), period=PERIOD)
    if sets == "raster":
        from swarmtrack.estimation import setmembership_raster as raster

        if window:
            return raster.RasterReplayingSetMembershipEstimator(N, N_T, AREA, window=window, **kw)
        return raster.RasterSetMembershipEstimator(N, N_T, AREA, **kw)
    if window:
        return ReplayingSetMembershipEstimator(N, N_T, AREA, window=window, **kw)
    return SetMembershipEstimator(N, N_T, AREA, **kw)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2])
def test_the_guarantee_holds_with_random_delays_up_to_one_second(seed):
    channel = Channel("full", N, 1e6, delay=0.0, delay_max=1.0, dt=DT, delay_rng=np.random.default_rng(seed))
    est = make(window=2)  # 1 s = 2 sharing periods
    totals = {"late": 0.0, "stale": 0.0}
    deliver = lambda k, outbox: channel.deliver(channel.links(np.zeros((N, 2)), k * DT), outbox, k * DT)  # noqa: E731
    violations = run(est, world(seed, 200), deliver, totals=totals)
    assert violations == 0
    assert sum(int(a.sum()) for a in est.beliefs.alarms.values()) == 0  # no target lost, no detection unexplained
    sent = 40 * N * (N - 1)  # 40 sharing times, every link
    assert 0.5 * sent < totals["late"] <= sent and totals["stale"] == 0  # most came late (each counted once), none
    # beyond the window
    assert pg.area(est.beliefs.unexplored).max() < 0.5 * AREA.area  # and the sets did learn something


S1, HOLD = 12, 7  # UAV 1's message to UAV 0 at sharing time 12 (6 s) arrives 7 steps (0.7 s) later


def _one_late(hold: int | None = HOLD, s1: int = S1):
    """Step k's inbox: every link on time, except UAV 1 → 0 at sharing time ``s1``, which arrives ``hold`` steps later
    (0: on time; between two sharing times: it waits for the next one) or never (``hold`` None); UAV 0 hears nobody
    after ``s1`` (nobody relays what that message said)."""
    held: dict = {}
    due = round(s1 * PERIOD / DT)

    def deliver(k, outbox):
        links = FULL.copy()
        links[0] &= k <= due
        if k == due and hold != 0:
            links[0, 1] = False
            held["part"] = Inbox(_only(0, 1), outbox)
        late = (held["part"],) if hold and k == due + hold else ()
        return Inbox(links, outbox, late)

    return deliver


def _only(i, ell):
    out = np.zeros((N, N), dtype=bool)
    out[i, ell] = True
    return out


def _sets(est):
    """UAV 0's sets: X̄, Xᵁ and every X_j."""
    b = est.beliefs
    return [b.unexplored[0], b.unidentified[0], *b.identified[0]]


def _holders(est):
    """UAV 0's ``X_j ∪ Xᵁ ∪ X̄`` for every j, ``Xᵁ ∪ X̄`` and ``X̄``: where target j, an unidentified object and an
    unseen one can be (the fusion intersects exactly these, eqs. 31-37)."""
    b = est.beliefs
    rest = pg.union_all([b.unidentified[0], b.unexplored[0]])
    return [*(pg.union_all([x, rest]) for x in b.identified[0]), rest, b.unexplored[0]]


ARRIVE = round(S1 * PERIOD / DT) + 10  # the first sharing time after the arrival: 2 periods late


def _all_sets(est):
    b = est.beliefs
    return [*b.unexplored, *b.unidentified, *b.identified.ravel()]


@pytest.mark.slow
def test_a_late_message_gives_the_sets_it_would_have_given_on_time():
    frames = world(3, 160)
    on_time, late = make(), make(window=2)
    runs = ((on_time, _one_late(hold=0)), (late, _one_late()))
    for est, deliver in runs:
        run(est, frames, deliver, range(ARRIVE))
    before = [shapely.symmetric_difference(a, b).area for a, b in zip(_sets(on_time), _sets(late), strict=True)]
    assert max(before) > 50.0  # the message mattered: without it UAV 0 knew less
    for steps in (range(ARRIVE, ARRIVE + 1), range(ARRIVE + 1, len(frames))):  # right after the replay, and later
        for est, deliver in runs:
            run(est, frames, deliver, steps)
        for a, b in zip(_sets(on_time), _sets(late), strict=True):  # (UAVs 1, 2 fused UAV 0's poorer sets meanwhile)
            assert shapely.symmetric_difference(a, b).area < 1e-6
        if steps.start == ARRIVE:
            assert late.sample()["late"].tolist() == [1.0, 0.0, 0.0]  # fused at its time, 2 periods back


def _no_larger(a, b, updates: int) -> bool:
    """``a ⊆ b`` up to the outer approximations of ``updates`` predictions: each can push a set out of a superset's
    by the circumscribed disc's excess (:func:`polygons.circumscribed`) plus the simplification tolerance."""
    r = SPEED * PERIOD
    margin = updates * (pg.circumscribed(r) - r + pg.SIMPLIFY_EPS)
    return shapely.difference(a, shapely.buffer(b, margin)).area < 1e-6


@pytest.mark.slow
@pytest.mark.parametrize("seed", [4, 5])
def test_a_late_message_makes_the_sets_no_larger_than_ignoring_it(seed):
    """Fusion intersects where each target can be (``X_j ∪ Xᵁ ∪ X̄``), ``Xᵁ ∪ X̄`` and ``X̄`` over the UAVs
    (eqs. 31-37), and prediction and correction are monotone in them: one more message can only shrink them."""
    frames = world(seed, 160)
    late, ignored = make(window=2), make(window=2)
    sent = round(S1 * PERIOD / DT) + 1
    runs = ((late, _one_late()), (ignored, _one_late(hold=None)))
    for est, deliver in runs:
        run(est, frames, deliver, range(sent))
    since = late.updates[0]  # the updates replayed or done since, each one prediction
    for steps in (range(sent, ARRIVE + 1), range(ARRIVE + 1, len(frames))):  # right after the replay, and later
        for est, deliver in runs:
            run(est, frames, deliver, steps)
        pairs = list(zip(_holders(late), _holders(ignored), strict=True))
        assert all(_no_larger(a, b, late.updates[0] - since) for a, b in pairs)
        assert max(b.area - a.area for a, b in pairs) > 10.0  # and the message did tell something
    assert ignored.sample()["late"].sum() == 0


def test_sets_older_than_the_window_are_dropped_and_counted():
    frames = world(3, ARRIVE + 1)
    short, ignored = make(window=1), make(window=1)
    run(short, frames, _one_late())
    probes = short.sample()
    assert probes["stale"].tolist() == [1.0, 0.0, 0.0] and probes["late"].sum() == 0  # 2 periods > δ̄ = 1
    run(ignored, frames, _one_late(hold=None))
    assert [g.wkb for g in _all_sets(short)] == [g.wkb for g in _all_sets(ignored)]  # as if never sent


@pytest.mark.slow
def test_with_nothing_late_the_replaying_estimator_gives_the_plain_sets_bit_for_bit():
    frames = world(5, 120)
    plain, replaying = make(), make(window=2)
    for est in (plain, replaying):
        run(est, frames, _one_late(hold=0))
    assert [g.wkb for g in _all_sets(plain)] == [g.wkb for g in _all_sets(replaying)]
    assert (plain.beliefs.t == replaying.beliefs.t).all() and replaying.sample()["late"].sum() == 0


def _held(sends: dict[int, int], hold: int | None, cut=(), heard=()):
    """Step k's inbox: nobody hears UAV 0 (so UAVs 1 and 2 broadcast what they alone learn), no link in ``cut`` and
    every one in ``heard`` (``(receiver, sender)`` pairs) carries anything; UAV 0 hears UAV ℓ at the steps ``sends``
    ``{k: ℓ}``, and that message arrives ``hold`` steps later (0: on time; None: never)."""
    flight: dict[int, list] = {}

    def deliver(k, outbox):
        links = FULL.copy()
        links[:, 0] = False
        links[0] = False
        for pairs, on in ((cut, False), (heard, True)):
            for i, ell in pairs:
                links[i, ell] = on
        if k in sends:
            if hold == 0:
                links[0, sends[k]] = True
            elif hold is not None:
                flight.setdefault(k + hold, []).append(Inbox(_only(0, sends[k]), outbox))
        return Inbox(links, outbox, tuple(flight.pop(k, ())))

    return deliver


STEP_S1 = round(S1 * PERIOD / DT)
REPLAYS = {  # late messages whose replay fuses again on the way (what _one_late's missions never do)
    # UAV 0 hears UAV 2 at every step, which never hears UAV 1: the replay fuses 2's on-time messages with 0's
    # recomputed sets (fuse's ``own``)
    "on-time messages fused again during the replay": ({STEP_S1: 1}, {"cut": [(2, 1)], "heard": [(0, 2)]}),
    # UAVs 1 and 2 never hear each other: the second replay must start from the sets the first one recomputed
    "a second late message replayed over the first one's":
        ({STEP_S1: 1, STEP_S1 + 2 * round(PERIOD / DT): 2}, {"cut": [(1, 2), (2, 1)]}),
}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3, 4])
@pytest.mark.parametrize("case", sorted(REPLAYS))
def test_a_replay_that_fuses_again_stays_with_the_on_time_sets(case, seed):
    """The replay fuses UAV 0's *recomputed* sets with the messages of each time again, and keeps them for later
    replays: its sets match the on-time ones within the outer approximations (each set inside the other's, up to
    :func:`_no_larger`'s margin per prediction: new objects are loosened and simplified differently), while
    ignoring the message leaves a large region they do not share."""
    sends, links = REPLAYS[case]
    frames = world(seed, 160)
    runs = {hold: (make(window=3), _held(sends, hold, **links)) for hold in (0, HOLD, None)}
    for est, deliver in runs.values():
        run(est, frames, deliver)
    (on_time, _), (late, _), (ignored, _) = runs.values()
    n = late.updates[0]
    for a, b in zip(_sets(on_time), _sets(late), strict=True):
        assert _no_larger(a, b, n) and _no_larger(b, a, n)
    assert max(shapely.symmetric_difference(a, b).area for a, b in zip(_sets(on_time), _sets(ignored),
                                                                       strict=True)) > 100.0


# --- raster sets: the replay recomputes the on-time numbers exactly ---------------------------------------------


def _grids(est) -> list[np.ndarray]:
    """Every set of every UAV as its bounds on the whole grid (what the raster sets are, whatever their windows)."""
    g = est.grid
    return [rs.values(g, f, (0, 0, g.ny, g.nx)) for f in _all_sets(est)]


def _equal(a, b) -> bool:
    return all(np.array_equal(x, y) for x, y in zip(_grids(a), _grids(b), strict=True))


@pytest.mark.slow
def test_the_guarantee_holds_on_raster_sets_with_random_delays():
    channel = Channel("full", N, 1e6, delay=0.0, delay_max=1.0, dt=DT, delay_rng=np.random.default_rng(1))
    est = make(window=2, sets="raster")
    totals = {"late": 0.0, "stale": 0.0}
    deliver = lambda k, outbox: channel.deliver(channel.links(np.zeros((N, 2)), k * DT), outbox, k * DT)  # noqa: E731
    assert run(est, world(1, 200), deliver, totals=totals) == 0
    assert sum(int(a.sum()) for a in est.beliefs.alarms.values()) == 0
    sent = 40 * N * (N - 1)
    assert 0.5 * sent < totals["late"] <= sent and totals["stale"] == 0
    assert max(rs.area(est.grid, f) for f in est.beliefs.unexplored) < 0.5 * AREA.area


@pytest.mark.slow
def test_a_late_message_gives_the_on_time_raster_sets_exactly():
    frames = world(3, 160)
    on_time, late, ignored = make(sets="raster"), make(window=2, sets="raster"), make(window=2, sets="raster")
    runs = ((on_time, _one_late(hold=0)), (late, _one_late()), (ignored, _one_late(hold=None)))
    for est, deliver in runs:
        run(est, frames, deliver, range(ARRIVE))
    assert not _equal(on_time, late)  # the message mattered
    for steps in (range(ARRIVE, ARRIVE + 1), range(ARRIVE + 1, len(frames))):  # right after the replay, and later
        for est, deliver in runs:
            run(est, frames, deliver, steps)
        assert _equal(on_time, late)
        if steps.start == ARRIVE:
            assert late.sample()["late"].tolist() == [1.0, 0.0, 0.0]  # fused at its time, 2 periods back
    assert not _equal(on_time, ignored)


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(REPLAYS))
def test_a_raster_replay_that_fuses_again_gives_the_on_time_sets_exactly(case):
    sends, links = REPLAYS[case]
    frames = world(3, 160)
    runs = {hold: (make(window=3, sets="raster"), _held(sends, hold, **links)) for hold in (0, HOLD)}
    for est, deliver in runs.values():
        run(est, frames, deliver)
    (on_time, _), (late, _) = runs.values()
    assert _equal(on_time, late)


def test_with_nothing_late_the_replaying_raster_estimator_gives_the_plain_sets_bit_for_bit():
    frames = world(5, 120)
    plain, replaying = make(sets="raster"), make(window=2, sets="raster")
    for est in (plain, replaying):
        run(est, frames, _one_late(hold=0))
    assert _equal(plain, replaying) and (plain.beliefs.t == replaying.beliefs.t).all()
