"""Channel delays (network/channel.py): fixed or random within a bound, messages held in flight and delivered at the
first estimation step at or after their delay ends; no delay changes nothing, and losses are the same draws."""

import numpy as np

from swarmtrack.network.channel import Channel
from swarmtrack.network.links import to_dense

DT, N = 0.05, 4


def _outbox(k):
    return {"taken": np.full(N, k * DT), "seen": np.ones(N, dtype=bool)}


def _arrivals(channel, steps=40):
    """Per (receiver, sender): the steps each message took (arrival − sending)."""
    full = ~np.eye(N, dtype=bool)
    ages = []
    for k in range(steps):
        inbox = channel.deliver(channel.links(np.zeros((N, 2)), k * DT), _outbox(k), k * DT)
        for part in inbox.parts():
            sent = round(part.payloads["taken"][0] / DT)
            ages += [k - sent] * int(to_dense(part.links).sum())
        assert not (to_dense(inbox.links) & ~full).any()
    return np.array(ages)


def test_a_fixed_delay_arrives_whole_steps_later():
    ages = _arrivals(Channel("full", N, 10.0, delay=0.12, delay_max=0.12, dt=DT))
    assert set(ages.tolist()) == {3}  # ceil(0.12 / 0.05)
    assert len(ages) == (40 - 3) * N * (N - 1)  # the last three steps' messages are still in flight


def test_random_delays_stay_within_their_bound_and_spread_over_it():
    ages = _arrivals(Channel("full", N, 10.0, delay=0.0, delay_max=0.2, dt=DT,
                             delay_rng=np.random.default_rng(3)))
    assert set(ages.tolist()) == {1, 2, 3, 4}  # ceil(U(0, 0.2] / 0.05): any delay > 0 waits for a later step


def test_no_delay_delivers_now_and_delays_do_not_change_the_losses():
    plain = Channel("full", N, 10.0, loss_probability=0.3, rng=np.random.default_rng(1))
    late = Channel("full", N, 10.0, loss_probability=0.3, rng=np.random.default_rng(1), delay=0.05,
                   delay_max=0.05, dt=DT, delay_rng=np.random.default_rng(9))
    for k in range(10):
        a = plain.links(np.zeros((N, 2)), k * DT)
        b = late.links(np.zeros((N, 2)), k * DT)
        assert (to_dense(a) == to_dense(b)).all()
        inbox = plain.deliver(a, _outbox(k), k * DT)
        assert inbox.late == () and inbox.links is a
