"""The engine: one clock, three rates (physics, estimation, control), and the wiring of world, network and
onboard code. It is the only place where truth (for the recorder) and onboard state meet.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from swarmtrack.control.flocking import FlockingGains
from swarmtrack.estimation.information import RangeBearingUpdate
from swarmtrack.models import make_model
from swarmtrack.network.channel import Channel
from swarmtrack.network.topology import adjacency
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.agent import OnboardEstimators, OnboardFlocking
from swarmtrack.sim.recorder import Recording
from swarmtrack.sim.world import World


def flocking_gains(scenario: Scenario) -> FlockingGains:
    """The scenario's flocking gains (names checked by the schema) with its d and r_comm."""
    return dataclasses.replace(FlockingGains(), **scenario.flocking.gains, d=scenario.flocking.d,
                               r_comm=scenario.network.r_comm)


def simulate(scenario: Scenario, progress: Callable[[float], None] | None = None) -> Recording:
    """Run one closed-loop simulation and return its recording. Same scenario and seed, same numbers."""
    rates = scenario.rates
    dt_phys = 1.0 / rates.physics
    ticks_est = round(rates.physics / rates.estimation)
    ticks_ctrl = round(rates.physics / rates.control)
    dt_est, dt_ctrl = ticks_est * dt_phys, ticks_ctrl * dt_phys

    rng = np.random.default_rng(scenario.seed)
    world_rng, net_rng = rng.spawn(2)
    n = scenario.swarm.n_uavs
    duration = scenario.run_duration()
    # one decision for every compiled fast path (numba kernels, same numbers as the numpy reference)
    compiled = scenario.kernels != "numpy"
    world = World(scenario, world_rng, dt_phys, duration, compiled=compiled)
    steps = int(round(duration / dt_est))

    net = scenario.network
    channel = Channel(net.topology, n, net.r_comm, tuple((a - 1, b - 1) for a, b in net.edges),
                      net.loss_probability, net_rng)
    est = scenario.estimator
    model = make_model(est.model, dt_est, est.q)
    estimators = OnboardEstimators(
        model, RangeBearingUpdate(scenario.sensor.sigma_range, scenario.sensor.sigma_bearing, scenario.sensor.update),
        n, share=est.share, centralized=est.kind == "centralized", initial_info=est.initial_information,
        fake_vz_sigma=est.fake_vz_sigma, compiled=compiled)
    chase_after = scenario.flocking.chase_after_steps * dt_est
    flock = OnboardFlocking(flocking_gains(scenario), scenario.flocking.variant, n, chase_after, compiled=compiled)
    follow_truth = scenario.flocking.follow == "truth"
    # the beacons' proximity graph equals the channel's links at an estimation step when those are the
    # lossless proximity topology (same positions, same r_comm): computed once and shared
    beacons_are_links = net.topology == "proximity" and net.loss_probability == 0.0

    rec_t = np.arange(steps) * dt_est
    rec_phase = np.empty(steps, dtype=np.int64)
    rec_target = np.empty((steps, 4))
    rec_uav = np.empty((steps, n, 4))
    rec_est = np.empty((steps, n, 4))
    rec_cov = np.empty((steps, n, 4, 4))

    u = np.zeros((n, 2))
    report_every = max(1, steps // 100)
    for k in range(steps):
        t = k * dt_est
        # estimation step: measure, broadcast, fuse (L24 Sec. 3)
        nav = world.navigation()
        links = channel.links(world.uav_truth[:, :2])
        z, pose, seen = world.measure_target()
        with np.errstate(over="ignore", invalid="ignore"):  # a diverging filter is reported by fuse()
            own = estimators.predict_and_measure(pose, z, seen)
            estimators.fuse(own, links, t)
        x, P = estimators.estimates()
        rec_phase[k] = world.phase_index()
        rec_target[k] = world.target_truth
        rec_uav[k] = world.uav_truth
        rec_est[k] = x[:, :4]
        rec_cov[k] = P[:, :4, :4]
        # (a copy: the compiled world advances its state in place)
        target_for_control = np.broadcast_to(world.target_truth.copy(), (n, 4)) if follow_truth else x[:, :4]
        # control and physics until the next estimation step
        tick = 0
        while tick < ticks_est:
            phase = (k * ticks_est + tick) % ticks_ctrl
            if phase == 0:
                if tick:
                    nav = world.navigation()
                if tick == 0 and beacons_are_links:
                    beacons = links
                else:
                    beacons = adjacency("proximity", n, positions=world.uav_truth[:, :2], r_comm=net.r_comm)
                u = flock.command(nav, beacons, target_for_control, world.t, dt_ctrl)
            run = min(ticks_est - tick, ticks_ctrl - phase)  # physics ticks until the next control step
            world.advance(u, run)
            tick += run
        if progress is not None and (k % report_every == 0 or k == steps - 1):
            progress((k + 1) / steps)

    return Recording(
        t=rec_t, phase=rec_phase, phase_names=list(world.profile.phase_names), target=rec_target, uav=rec_uav,
        estimate=rec_est, covariance=rec_cov, d=scenario.flocking.d, r_comm=net.r_comm,
        chase_start=chase_after,
        meta={"scenario": scenario.name, "model": est.model, "seed": scenario.seed,
              "topology": net.topology, "estimator": est.kind, "share": est.share,
              "variant": scenario.flocking.variant})
