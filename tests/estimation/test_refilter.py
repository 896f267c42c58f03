"""Time-stamp-aware fusion (estimation/refilter.py): late data, fused at its time stamp by re-filtering, gives the
posterior the filter would have had with every datum on time, whatever the lags and their order."""

import numpy as np

from swarmtrack.estimation.information import InformationEstimator, RangeBearingUpdate, predict, recover
from swarmtrack.estimation.refilter import RefilteringEstimator
from swarmtrack.models import make_model
from swarmtrack.network.channel import Channel
from swarmtrack.network.messages import Inbox
from swarmtrack.sensors.detections import Detections
from swarmtrack.sensors.range_bearing import measure

DT, N = 0.05, 3


def _data(steps: int, seed: int = 0):
    """A target on a curve and three UAVs around it, with each UAV's measurement at every step."""
    rng = np.random.default_rng(seed)
    t = np.arange(steps) * DT
    target = np.stack([np.cos(0.3 * t) * 3, np.sin(0.2 * t) * 2], axis=-1)
    uavs = target[:, None, :] + np.array([[2.0, 0.0], [-1.0, 2.0], [0.0, -2.5]])[None]
    z = measure(target[:, None, :], uavs, 0.08, 0.02, rng)
    return uavs, z


def _detections(z, pos, taken=None):
    return Detections(np.arange(N), z, pos, np.zeros(N, dtype=int), N, taken=taken)


def _none():
    return Detections(np.zeros(0, int), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0, int), N)


def _filters(window: int):
    model = make_model("cv", DT)
    update = RangeBearingUpdate(0.08, 0.02)
    return model, InformationEstimator(model, update, N), RefilteringEstimator(model, update, N, window=window)


def test_a_constant_latency_gives_the_on_time_posterior_predicted_to_now():
    lag, steps = 3, 60
    uavs, z = _data(steps)
    model, on_time, late = _filters(lag)
    full = ~np.eye(N, dtype=bool)
    history = []
    for k in range(steps):
        t = k * DT
        on_time.fuse(t, None, Inbox(full, on_time.share(t, None, _detections(z[k], uavs[k]))))
        history.append((on_time.x.copy(), on_time.P.copy()))
        own = _detections(z[k - lag], uavs[k - lag], taken=(k - lag) * DT) if k >= lag else _none()
        late.fuse(t, own, Inbox(full, late.share(t, None, own)))
        if k >= 2 * lag:
            x, P = history[k - lag]
            for _ in range(lag):  # the on-time posterior at the measurement's step, predicted to now
                Y, y, _ = predict(model, x, P)
                x, P = recover(Y, y)
            np.testing.assert_allclose(late.x, x, rtol=1e-9, atol=1e-12)
            np.testing.assert_allclose(late.P, P, rtol=1e-9, atol=1e-15)


def test_random_channel_delays_reorder_messages_but_not_the_posterior():
    """The same contributions (computed once, so both filters fuse identical numbers), delivered on time to one bank
    and with random delays of up to ``window`` steps to the other: every step's posterior agrees once all of its
    messages have arrived."""
    window, steps = 4, 80
    uavs, z = _data(steps, seed=1)
    model, on_time, late = _filters(window)
    channel = Channel("full", N, 10.0, delay=0.0, delay_max=window * DT, dt=DT,
                      delay_rng=np.random.default_rng(5))
    full = ~np.eye(N, dtype=bool)
    source = InformationEstimator(model, RangeBearingUpdate(0.08, 0.02), N)
    history, reordered, newest = [], 0, np.full((N, N), -np.inf)
    for k in range(steps):
        t = k * DT
        sent = source.share(t, None, _detections(z[k], uavs[k]))
        source.fuse(t, None, Inbox(full, sent))
        sent = {**sent, "taken": np.full(N, t)}
        on_time.share(t, None, _none())
        on_time.fuse(t, None, Inbox(full, sent))
        history.append(on_time.x.copy())
        late.share(t, None, _none())
        inbox = channel.deliver(full, sent, t)
        for part in inbox.parts():  # on one link, an older message after a newer one
            stamp = part.payloads["taken"][0]
            reordered += (part.links & (stamp < newest)).sum()
            newest = np.where(part.links, np.maximum(newest, stamp), newest)
        late.fuse(t, None, inbox)
        if k >= window:  # every message about step k − window has arrived by now
            np.testing.assert_allclose(late._posterior(k - window)[0], history[k - window], rtol=1e-9, atol=1e-12)
    assert reordered > 0
    assert late.sample()["stale"].sum() == 0


def test_data_older_than_the_window_is_dropped_and_counted():
    """A measurement 4 steps late (not broadcast: a UAV does not send what it dropped), and neighbours' messages 4
    steps late, against a 2-step window."""
    uavs, z = _data(12)
    _, _, late = _filters(2)
    channel = Channel("full", N, 10.0, delay=4 * DT, delay_max=4 * DT, dt=DT)
    full = ~np.eye(N, dtype=bool)
    stale = np.zeros(N)
    for k in range(12):
        t = k * DT
        own = _detections(z[k], uavs[k], taken=(k - 4) * DT)
        out = {**late.share(t, None, own), "seen": np.ones(N, dtype=bool)}  # sent anyway: neighbours drop it
        late.fuse(t, own, channel.deliver(full, out, t))
        stale += late.sample()["stale"]
    # own: from step 4 on (before that, taken before the filter started: dropped, not counted); two neighbours': their
    # messages arrive 4 steps after they were sent, 8 after they were taken, so from step 8 on
    assert stale.tolist() == [8 + 2 * 4] * N
    assert np.isfinite(late.x).all()
