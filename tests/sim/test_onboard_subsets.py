"""Onboard components for one UAV (issue 22): every estimator and controller kind that can run in a UAV's own process
is built for a subset of the swarm's UAVs (each single UAV, and a pair) and, replayed with what the engine handed the
whole swarm's component restricted to those UAVs (their navigation, their detections, their rows of the delivered
inboxes, the view), produces bit for bit the whole swarm's rows of everything it returns: outboxes, samples, views
and commands.

The rows of the payloads a subset's inbox holds from senders its links did not deliver this step are overwritten
with nonsense before the replay, and the other UAVs' navigation, detections and views are not handed over at all,
so a component that read another UAV's row would fail here.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
import shapely

from swarmtrack import registry
from swarmtrack.control.base import SequentialPlanner
from swarmtrack.estimation.base import Regions, TargetView
from swarmtrack.estimation.raster_field import Field
from swarmtrack.network.links import edge_list
from swarmtrack.network.messages import Inbox
from swarmtrack.onboard.context import Context, command_width
from swarmtrack.scenarios import load_scenario
from swarmtrack.sim.build import build
from swarmtrack.sim.engine import step_loop
from swarmtrack.sim.recorder import Recorder

#: Per-sender tallies of the χ²-gate: a subset counts over its own receivers; the swarm's are the sums.
TALLIES = ("rejected", "delivered")


def _copy_inbox(inbox: Inbox) -> Inbox:
    return Inbox(inbox.links.copy(), {k: np.array(v, copy=True) for k, v in inbox.payloads.items()},
                 tuple(_copy_inbox(p) for p in inbox.late), inbox.receivers.copy())


def _copy(x):
    if isinstance(x, dict):
        return {k: np.array(v, copy=True) for k, v in x.items()}
    return np.array(x, copy=True)


class RecordingEstimator:
    """The whole swarm's estimator, logging every call of the engine in order as ``(method, inputs, output)``."""

    def __init__(self, inner, log: list):
        self.inner, self.log, self.probes = inner, log, inner.probes
        if hasattr(inner, "publish"):
            self.publish = self._publish
            self.combine = self._combine

    def share(self, t, nav, own):
        out = self.inner.share(t, nav, own)
        self.log.append(("share", (t, nav.copy(), own), _copy(out)))
        return out

    def fuse(self, t, own, inbox):
        self.log.append(("fuse", (t, own, _copy_inbox(inbox)), None))
        self.inner.fuse(t, own, inbox)

    def _publish(self, t):
        out = self.inner.publish(t)
        self.log.append(("publish", (t,), _copy(out)))
        return out

    def _combine(self, t, inbox):
        self.log.append(("combine", (t, _copy_inbox(inbox)), None))
        self.inner.combine(t, inbox)

    def view(self):
        return self.inner.view()

    def sample(self):
        out = self.inner.sample()
        self.log.append(("sample", (), (_copy(out), copy.deepcopy(self.inner.view()))))
        return out


class RecordingController:
    """The whole swarm's controller, logging its beacons and commands (with the view and inbox it was handed)."""

    def __init__(self, inner, log: list):
        self.inner, self.log, self.probes = inner, log, inner.probes

    def broadcast(self, t, nav):
        out = self.inner.broadcast(t, nav)
        self.log.append(("broadcast", (t, nav.copy()), _copy(out)))
        return out

    def command(self, t, nav, view, inbox, dt):
        logged = _copy_inbox(inbox)
        u = self.inner.command(t, nav, view, inbox, dt)
        if isinstance(self.inner, SequentialPlanner):  # the plans made in this call are messages too
            logged.payloads.update(_copy(self.inner.plans()))
        self.log.append(("command", (t, nav.copy(), copy.deepcopy(view), logged, dt), _copy(u)))
        return u

    def sample(self):
        return self.inner.sample()


def record(scenario, sparse: bool = False):
    """Run ``scenario`` whole, recording every call of the engine to its estimator and controller; returns the
    builder context (as :func:`swarmtrack.sim.build.build` made it) and the two logs. ``sparse``: the channel's
    proximity links in CSR form (as from 300 UAVs on)."""
    sim = build(scenario)
    if sparse:
        sim.channel.sparse = True
    est_log, ctl_log = [], []
    est = RecordingEstimator(sim.stack.estimator, est_log)
    if sim.stack.guide is sim.stack.estimator:
        sim.stack.guide = est
    sim.stack.estimator = est
    sim.stack.controller = RecordingController(sim.stack.controller, ctl_log)
    recorder = Recorder(sim.meta, sim.world.n_objects, scenario.swarm.n_uavs, sim.stack.probes, None)
    step_loop(sim, recorder)
    world, clock = sim.world, sim.clock
    ctx = Context(scenario, scenario.swarm.n_uavs, clock.dt_estimation, clock.dt_control, scenario.kernels != "numpy",
                  lambda group, member: world.label_of(world.slices[group].start + member), command_width(scenario))
    return ctx, est_log, ctl_log


def subset_context(ctx: Context, uavs) -> Context:
    return Context(ctx.scenario, ctx.n_uavs, ctx.dt_estimation, ctx.dt_control, ctx.compiled, ctx.label_of,
                   ctx.command_width, uavs=np.asarray(uavs))


def nonsense(inbox: Inbox) -> Inbox:
    """``inbox`` (a subset's) with the payload rows of every sender neither linked to its receivers in that part
    nor one of them overwritten: a component that read them would give other numbers."""
    parts = []
    for part in inbox.parts():
        keep = np.zeros(part.links.shape[1], dtype=bool)
        keep[edge_list(part.links)[1]] = True
        keep[inbox.receivers] = True
        payloads = {}
        for name, value in part.payloads.items():
            value = np.array(value, copy=True)
            if value.dtype == bool:
                value[~keep] = ~value[~keep]
            else:
                value[~keep] = 1234.5 + np.arange((~keep).sum()).reshape((-1,) + (1,) * (value.ndim - 1))
            payloads[name] = value
        parts.append(Inbox(part.links, payloads, (), part.receivers))
    return Inbox(parts[0].links, parts[0].payloads, tuple(parts[1:]), parts[0].receivers)


def not_yet_planned(inbox: Inbox, uav: int) -> Inbox:
    """``inbox`` (one UAV's) with the plan messages of UAV ``uav`` and every higher-indexed UAV overwritten: they
    plan after it in the same call (Sec. 5.3 of IB21), so it cannot have them."""
    if "plan" not in inbox.payloads:
        return inbox
    plans = np.array(inbox.payloads["plan"], copy=True)
    plans[uav:] = 1234.5
    return Inbox(inbox.links, {**inbox.payloads, "plan": plans}, inbox.late, inbox.receivers)


def view_of(view: TargetView, uavs) -> TargetView:
    return view.of_rows(uavs)


def same_set(a, b) -> bool:
    """Two entries of an object array equal bit for bit: IB21's sets (shapely geometries coordinate by coordinate,
    raster fields cell by cell), anything else as arrays."""
    if isinstance(a, Field) or isinstance(b, Field):
        return (isinstance(a, Field) and isinstance(b, Field) and (a.i0, a.j0, a.core) == (b.i0, b.j0, b.core)
                and np.array_equal(a.data, b.data))
    if isinstance(a, shapely.Geometry) or isinstance(b, shapely.Geometry):
        return isinstance(a, shapely.Geometry) and isinstance(b, shapely.Geometry) and bool(
            shapely.equals_identical(a, b))
    return bool(np.array_equal(a, b))


def assert_rows(whole, sub, uavs, what):
    """Every array of ``sub`` equals ``whole``'s rows ``uavs`` bit for bit (NaN where NaN; sets as
    :func:`same_set`)."""
    if isinstance(whole, Regions):
        assert isinstance(sub, Regions) and sub.grid == whole.grid, what
        assert_rows(whole.sets, sub.sets, uavs, f"{what}.sets")
        return
    if isinstance(whole, dict):
        assert set(sub) == set(whole), what
        for k in whole:
            assert_rows(whole[k], sub[k], uavs, f"{what}[{k}]")
        return
    if isinstance(whole, TargetView):
        for name in ("state", "model", "motion", "region"):
            w, s = getattr(whole, name), getattr(sub, name)
            assert (w is None) == (s is None), f"{what}.{name}"
            if w is not None:
                assert_rows(w, s, uavs, f"{what}.{name}")
        return
    whole, sub = np.asarray(whole), np.asarray(sub)
    if whole.dtype == object:
        assert sub.shape == whole[uavs].shape, what
        assert all(same_set(w, s) for w, s in zip(whole[uavs].ravel(), sub.ravel(), strict=True)), what
        return
    assert np.array_equal(whole[uavs], sub, equal_nan=whole.dtype.kind == "f"), what


def replay_estimator(ctx, log, uavs) -> list[dict]:
    """Replay the whole swarm's estimator log for ``uavs``, checking every output row; returns the χ²-gate's
    per-sender tallies of each sample (empty without a gate)."""
    spec = ctx.scenario.estimator
    est = registry.get("estimator", spec.kind).builder()(spec, subset_context(ctx, uavs))
    tallies = []
    for method, args, out in log:
        t = args[0] if args else None
        if method == "share":
            _, nav, own = args
            assert_rows(out, est.share(t, nav[uavs], own.of_uavs(uavs)), uavs, f"outbox at t={t}")
        elif method == "fuse":
            _, own, inbox = args
            est.fuse(t, own.of_uavs(uavs), nonsense(inbox.restrict(uavs)))
        elif method == "publish":
            assert_rows(out, est.publish(t), uavs, f"second outbox at t={t}")
        elif method == "combine":
            est.combine(t, nonsense(args[1].restrict(uavs)))
        else:
            sample, view = out
            got = est.sample()
            tallies.append({name: got.pop(name) for name in TALLIES if name in got})
            assert_rows({k: v for k, v in sample.items() if k not in TALLIES}, got, uavs, f"sample at step "
                        f"{len(tallies) - 1}")
            assert_rows(view, est.view(), uavs, "view")
    return tallies


def replay_controller(ctx, log, uavs):
    spec = ctx.scenario.controller
    ctl = registry.get("controller", spec.kind).builder()(spec, subset_context(ctx, uavs))
    for method, args, out in log:
        if method == "broadcast":
            t, nav = args
            assert_rows(out, ctl.broadcast(t, nav[uavs]), uavs, f"beacon at t={t}")
        else:
            t, nav, view, inbox, dt = args
            heard = nonsense(inbox.restrict(uavs))
            if len(uavs) == 1:
                heard = not_yet_planned(heard, uavs[0])
            u = ctl.command(t, nav[uavs], view_of(view, uavs), heard, dt)
            assert_rows(out, u, uavs, f"command at t={t}")


#: (scenario, overrides): every in-scope kind and its variants (sharing, gating, late data, cycles, flocking laws);
#: ``sparse``: CSR links.
CASES = {
    "information-cv-compiled": ("l24-cv", []),
    "information-cv-numpy": ("l24-cv", ["kernels=numpy"]),
    "information-ct-polar": ("l24-ct", ["sensor.update=polar"]),
    "information-measurements": ("robust-5", ["estimator.share=measurements", "estimator.model=ct"]),
    "information-chi2-liar": ("robust-5", ["estimator.gating=chi2", "network.liar={uav: 2}",
                                           "network.topology=ring"]),
    "information-ci-liar": ("robust-5", ["estimator.gating=ci", "network.liar={uav: 3, mode: random}"]),
    "information-refilter": ("l24-cv", ["estimator.delayed_data=refilter", "network.delay_max=0.3"]),
    "information-refilter-chi2": ("robust-5", ["estimator.delayed_data=refilter", "sensor.latency=0.1",
                                               "network.delay_max=0.2", "estimator.gating=chi2",
                                               "network.loss_probability=0.2", "network.liar={uav: 4}"]),
    "information-chi2-sparse": ("robust-5", ["estimator.gating=chi2", "network.liar={uav: 1}",
                                             "network.topology=proximity", "sparse"]),
    "information-measurements-sparse": ("robust-5", ["estimator.share=measurements", "network.topology=proximity",
                                                     "kernels=numpy", "sparse"]),
    "information-refilter-sparse": ("robust-5", ["estimator.delayed_data=refilter", "network.delay_max=0.2",
                                                 "network.topology=proximity", "sparse"]),
    "information-fs-delays-as-current": ("l24-cv", ["estimator.model=fs", "network.delay=0.1"]),
    "imm-information": ("l24-imm", []),
    "imm-measurements": ("l24-imm", ["estimator.share=measurements", "network.topology=full"]),
    "imm-no-mixing": ("l24-imm", ["estimator.models=cv,ct", "network.loss_probability=0.3"]),
    "flocking-standard-proximity": ("l23-flocking-standard", ["network.topology=proximity"]),
    "flocking-integral-numpy": ("l23-flocking-integral", ["kernels=numpy", "network.loss_probability=0.2"]),
    "flocking-sparse": ("robust-5", ["network.topology=proximity", "sparse"]),
    "static": ("l24-cv", ["controller={kind: static}"]),
    "multimodel-ttest": ("w20-switching", ["estimator.solo_steps=40"]),
    "multimodel-ttest-numpy-trace": ("w20-occlusion", ["estimator.solo_steps=40", "kernels=numpy",
                                                       "estimator.occlusion=trace",
                                                       "sensor.occluders=[{window: [4.0, 4.6]}]"]),
    "multimodel-ttest-last-one-blind": ("w20-occlusion", ["estimator.solo_steps=40",
                                                          "sensor.occluders=[{window: [3.0, 5.0], uavs: [2]}, "
                                                          "{window: [4.0, 4.5]}]"]),
    "multimodel-imm-thesis": ("w20-switching", ["estimator.solo_steps=40", "estimator.fusion=imm-thesis",
                                                "network.topology=line"]),
    "multimodel-imm-mixing": ("w20-switching", ["estimator.solo_steps=40", "estimator.fusion=imm",
                                                "estimator.models=ct,cv,ct"]),
    "multimodel-ml": ("w20-switching", ["estimator.solo_steps=40", "estimator.fusion=ml",
                                        "network.loss_probability=0.3"]),
    "multimodel-none-range-bearing": ("w20-switching", ["estimator.solo_steps=40", "estimator.fusion=none",
                                                        "estimator.models=cv,cv,ca",
                                                        "sensor={kind: range_bearing, sigma_range: 0.05, "
                                                        "sigma_bearing: 0.02}"]),
    "mpc-formation": ("w20-mpc-formation", ["controller.start=1"]),
    "mpc-collision": ("w20-mpc-collision", []),
    # IB21's estimator (raster and polygon sets) and SM-MPC (its plans as messages)
    "setmembership-raster": ("ib21-fleet-6", ["estimator.sets=raster"]),
    "setmembership-polygons": ("ib21-fleet-6", ["estimator.sets=polygons"]),
    # issue 40's LMB filter (its detections as messages; a lossy ring, the numpy reference alone)
    "lmb-ring-lossy": ("mtt-box-hard", ["network.topology=ring", "network.loss_probability=0.3"]),
    "lmb-numpy-alone": ("mtt-box-easy", ["kernels=numpy", "estimator.share=none"]),
    "lmb-track-assignment": ("mtt-swarm", ["network.r_comm=60"]),
    "gnn-ring-lossy": ("mtt-box-hard", ["estimator.kind=gnn", "network.topology=ring",
                                        "network.loss_probability=0.3"]),
    "jpda-line": ("mtt-box-easy", ["estimator.kind=jpda", "network.topology=line"]),
    "setmembership-raster-delays": ("ib21-fleet-6", ["estimator.sets=raster", "estimator.delayed_data=refilter",
                                                     "network.delay_max=1.2", "network.loss_probability=0.2"]),
}


#: The cases of the fast tier (``pytest -m "not slow"``); the others are marked slow.
FAST = ("information-cv-compiled", "flocking-sparse", "setmembership-raster")


@pytest.fixture(scope="module", params=[pytest.param(name, marks=() if name in FAST else pytest.mark.slow)
                                        for name in sorted(CASES)])
def recorded(request):
    name, overrides = CASES[request.param]
    scenario = load_scenario(name, [o for o in overrides if o != "sparse"] + ["duration=6"], seed=3)
    return (*record(scenario, sparse="sparse" in overrides), request.param)


def _subsets(n: int) -> list[list[int]]:
    """Each single UAV of a swarm of up to 4 (the first, one in the middle and the last of a larger one) and the pair
    of the first and the last."""
    singles = range(n) if n <= 4 else (0, n // 2, n - 1)
    return [[i] for i in singles] + [[0, n - 1]]


def test_each_uav_estimates_exactly_as_the_whole_swarm(recorded):
    ctx, est_log, _, _ = recorded
    samples = [out[0] for method, _, out in est_log if method == "sample"]
    gated = any(name in samples[0] for name in TALLIES)
    for uavs in _subsets(ctx.n_uavs):
        if not (gated and len(uavs) == 1):
            replay_estimator(ctx, est_log, uavs)
    if gated:  # the χ²-gate's per-sender tallies: each UAV's process counts what its own receiver did, the swarm's
        per_uav = [replay_estimator(ctx, est_log, [i]) for i in range(ctx.n_uavs)]  # are the sums over every UAV
        for k, sample in enumerate(samples):
            for name in TALLIES:
                if name in sample:
                    assert np.array_equal(sum(tallies[k][name] for tallies in per_uav), sample[name]), (name, k)


def test_each_uav_commands_exactly_as_the_whole_swarm(recorded):
    ctx, _, ctl_log, name = recorded
    assert any(method == "command" for method, _, _ in ctl_log)
    for uavs in _subsets(ctx.n_uavs):
        replay_controller(ctx, ctl_log, uavs)


#: The kinds that refuse a build for a subset of the swarm, by design: (role, scenario, overrides, why).
REFUSED = [("estimator", "l24-cv", ["estimator={kind: centralized, model: cv}"], "fusion centre")]


def test_the_cases_cover_every_registered_estimator_and_controller_kind():
    covered = {(role, getattr(load_scenario(name, [o for o in overrides if o != "sparse"]), role).kind)
               for name, overrides in CASES.values() for role in ("estimator", "controller")}
    covered |= {(role, getattr(load_scenario(name, overrides), role).kind) for role, name, overrides, _ in REFUSED}
    registered = {(role, kind) for role in ("estimator", "controller") for kind in registry.kinds(role)}
    assert registered <= covered, f"kinds no case builds for one UAV: {sorted(registered - covered)}"


@pytest.mark.parametrize("role, name, overrides, why", REFUSED)
def test_the_kinds_without_a_subset_build_refuse_one_by_name(role, name, overrides, why):
    scenario = load_scenario(name, overrides, seed=3)
    spec = getattr(scenario, role)
    ctx = Context(scenario, scenario.swarm.n_uavs, 0.1, 0.1, True, lambda group, member: member, uavs=[1])
    with pytest.raises(NotImplementedError, match=f"{spec.kind}: cannot be built for a subset.*{why}"):
        registry.get(role, spec.kind).builder()(spec, ctx)


def test_the_replay_catches_a_component_that_reads_a_sender_it_did_not_hear(monkeypatch):
    """The check has teeth: a filter that adds every sender's contribution, delivered or not, runs the whole swarm
    (as if the topology were full) but fails the replay of a UAV that does not hear everyone."""
    from swarmtrack.estimation.information import NeighbourSum

    def everyone(self, est, inbox):
        return tuple(inbox.payloads[name].sum(axis=0) - inbox.payloads[name][inbox.receivers]
                     for name in ("info_matrix", "info_vector"))

    monkeypatch.setattr(NeighbourSum, "current", everyone)
    ctx, log, _ = record(load_scenario("l24-cv", ["duration=2", "network.topology=line"], seed=3))
    replay_estimator(ctx, log, [1])  # the middle UAV of the line hears everyone
    with pytest.raises(AssertionError, match="sample"):
        replay_estimator(ctx, log, [0])
