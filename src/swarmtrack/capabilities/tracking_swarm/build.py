"""Capability 1's builders (L24, L23): from settings to the onboard components and the truth-side sensor."""

from __future__ import annotations

import dataclasses

from swarmtrack.capabilities.tracking_swarm.settings import (
    FilterSpec,
    FlockingSpec,
    IMMSpec,
    RangeBearingSpec,
    refiltered_steps,
)
from swarmtrack.control import kernels
from swarmtrack.control.flocking import FlockingController, FlockingGains, flocking_control
from swarmtrack.estimation.imm import IMMInformationEstimator
from swarmtrack.estimation.information import InformationEstimator, RangeBearingUpdate
from swarmtrack.estimation.refilter import RefilteringEstimator
from swarmtrack.models import make_model
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.build import Context, occluders
from swarmtrack.sim.world import RangeBearingSensor


def information(spec: FilterSpec, ctx: Context) -> InformationEstimator:
    """L24's filter; with late data (latency, delays) and ``delayed_data: refilter``, the time-stamp-aware one."""
    s = ctx.scenario.sensor
    window = refiltered_steps(ctx.scenario) if spec.delayed_data == "refilter" else 0
    kind, extra = (RefilteringEstimator, {"window": window}) if window else (InformationEstimator, {})
    own = ctx.scenario.swarm.nav_position_std if spec.own_position == "include" else 0.0
    return kind(
        make_model(spec.model, ctx.dt_estimation, spec.q),
        RangeBearingUpdate(s.sigma_range, s.sigma_bearing, s.update, own_sigma=own),
        ctx.n_uavs, label=ctx.label_of("targets", spec.target - 1), share=spec.share,
        centralized=spec.kind == "centralized", initial_info=spec.initial_information,
        fake_vz_sigma=spec.fake_vz_sigma, compiled=ctx.compiled, gating=spec.gating,
        gate_probability=spec.gate_probability, **extra)


def imm(spec: IMMSpec, ctx: Context) -> IMMInformationEstimator:
    s = ctx.scenario.sensor
    qs = spec.q or [None] * len(spec.models)
    return IMMInformationEstimator(
        [make_model(m, ctx.dt_estimation, q) for m, q in zip(spec.models, qs, strict=True)],
        RangeBearingUpdate(s.sigma_range, s.sigma_bearing, s.update), ctx.n_uavs,
        label=ctx.label_of("targets", spec.target - 1), share=spec.share, markov=spec.markov,
        initial_info=spec.initial_information, fake_vz_sigma=spec.fake_vz_sigma)


def flocking_gains(spec: FlockingSpec, r_comm: float) -> FlockingGains:
    """The scenario's flocking gains (names checked by the schema) with its d and r_comm."""
    return dataclasses.replace(FlockingGains(), **spec.gains, d=spec.d, r_comm=r_comm)


def flocking(spec: FlockingSpec, ctx: Context) -> FlockingController:
    """L24's flocking; the compiled law (numba) or the numpy reference, as the scenario's ``kernels`` asks."""
    gains = flocking_gains(spec, ctx.scenario.network.r_comm)
    law = kernels.compiled_law(gains) if ctx.compiled else flocking_control
    return FlockingController(gains, spec.variant, ctx.n_uavs, spec.chase_after_steps * ctx.dt_estimation, law=law)


def range_bearing(s: RangeBearingSpec, scenario: Scenario) -> RangeBearingSensor:
    return RangeBearingSensor(s.sigma_range, s.sigma_bearing, s.max_range, s.latency, occluders(s))
