"""Capability 1's onboard builders (L24, L23): from settings to the estimators and the flocking controller (the
truth-side sensors are built in :mod:`.world`)."""

from __future__ import annotations

import dataclasses
from typing import Any

from swarmtrack.capabilities.tracking_swarm.settings import (
    FilterSpec,
    FlockingSpec,
    IMMSpec,
    refiltered_steps,
)
from swarmtrack.control import kernels
from swarmtrack.control.flocking import FlockingController, FlockingGains, flocking_control
from swarmtrack.estimation.imm import IMMInformationEstimator
from swarmtrack.estimation.information import (
    FusionCentre,
    InformationEstimator,
    InformationSharing,
    MeasurementSharing,
)
from swarmtrack.estimation.information_compiled import compiled_cycle
from swarmtrack.estimation.refilter import RefilteringEstimator
from swarmtrack.estimation.sharing import Chi2Gate, CovarianceIntersection
from swarmtrack.models import make_model
from swarmtrack.onboard.context import Context


def sharing(spec: FilterSpec, ctx: Context) -> InformationSharing:
    """What each UAV broadcasts and how it fuses what arrives: a fusion centre (the baseline), raw measurements, or
    information contributions (L24 eqs. 6-7) added whole, through a χ²-gate or by covariance intersection."""
    if spec.kind == "centralized":
        return FusionCentre()
    if spec.share == "measurements":
        return MeasurementSharing()
    if spec.gating == "ci":
        return CovarianceIntersection()
    gate = Chi2Gate(len(ctx.uavs), spec.gate_probability, senders=ctx.n_uavs) if spec.gating == "chi2" else None
    return InformationSharing(gate)


def information(spec: FilterSpec, ctx: Context) -> InformationEstimator:
    """L24's filter; with late data (latency, delays) and ``delayed_data: refilter``, the time-stamp-aware one,
    which runs the numpy cycle; otherwise the compiled cycle where the model has one and the scenario's ``kernels``
    allow it (the one place the choice is made). Built for any of the swarm's UAVs (``ctx.uavs``), except the
    fusion centre, which is not a UAV's."""
    if spec.kind == "centralized":
        ctx.whole_swarm_only("centralized", "the fusion centre is one filter fed every UAV's measurement, not a "
                             "UAV's own component")
    s = ctx.scenario.sensor
    window = refiltered_steps(ctx.scenario) if spec.delayed_data == "refilter" else 0
    own = ctx.scenario.swarm.nav_position_std if spec.own_position == "include" else 0.0
    model = make_model(spec.model, ctx.dt_estimation, spec.q)
    update = s.update_rule(own)
    shared = sharing(spec, ctx)
    common: dict[str, Any] = {"label": ctx.target_label(spec.target - 1), "sharing": shared,
                              "initial_info": spec.initial_information, "fake_vz_sigma": spec.fake_vz_sigma,
                              "rows": ctx.rows}
    if window:
        return RefilteringEstimator(model, update, len(ctx.uavs), window=window, **common)
    cycle = compiled_cycle(model, update, shared) if ctx.compiled else None
    return InformationEstimator(model, update, len(ctx.uavs), cycle=cycle, **common)


def imm(spec: IMMSpec, ctx: Context) -> IMMInformationEstimator:
    """L24's IMM bank; its members' predictions compiled (numba) or the numpy reference, as ``kernels`` asks."""
    s = ctx.scenario.sensor
    qs = spec.q or [None] * len(spec.models)
    return IMMInformationEstimator(
        [make_model(m, ctx.dt_estimation, q) for m, q in zip(spec.models, qs, strict=True)],
        s.update_rule(), len(ctx.uavs),
        label=ctx.target_label(spec.target - 1), share=spec.share, markov=spec.markov,
        initial_info=spec.initial_information, fake_vz_sigma=spec.fake_vz_sigma, rows=ctx.rows, compiled=ctx.compiled)


def flocking_gains(spec: FlockingSpec, r_comm: float) -> FlockingGains:
    """The scenario's flocking gains (names checked by the schema) with its d and r_comm."""
    return dataclasses.replace(FlockingGains(), **spec.gains, d=spec.d, r_comm=r_comm)


def flocking(spec: FlockingSpec, ctx: Context) -> FlockingController:
    """L24's flocking; the compiled law (numba) or the numpy reference, as the scenario's ``kernels`` asks."""
    gains = flocking_gains(spec, ctx.scenario.network.r_comm)
    law = kernels.compiled_law(gains) if ctx.compiled else flocking_control
    return FlockingController(gains, spec.variant, len(ctx.uavs), spec.chase_after_steps * ctx.dt_estimation, law=law)
