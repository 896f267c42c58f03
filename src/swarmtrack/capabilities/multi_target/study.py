"""What the multi-target study measures beside the runs' metrics (issue 40): the time a UAV's tracker takes per
step, and the field's trackers run on the same detections (Stone Soup's GM-PHD over every sensor and JPDA on one,
:mod:`swarmtrack.interop.stonesoup_mtt`) scored by the same GOSPA.

:func:`timed` runs a scenario with its estimator's share, fuse, publish and combine timed (the whole of a UAV's
estimation work: prediction, its messages, the corrections, the track fusion); :func:`references` feeds the
recorded detections of a run, as world positions per step and UAV, to Stone Soup's trackers.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from swarmtrack.analysis.gospa import gospa
from swarmtrack.capabilities.multi_target.metrics import ALPHA, C, P, objects
from swarmtrack.capabilities.multi_target.settings import LMBSpec, PositionSpec, positions_sensor
from swarmtrack.scenarios.schema import Scenario
from swarmtrack.sim.recorder import Recording


class _Timed:
    """An estimator whose estimation calls are timed (``seconds``), everything else its own."""

    def __init__(self, estimator):
        self._inner, self.seconds = estimator, 0.0
        for name in ("share", "fuse", "publish", "combine"):
            if hasattr(estimator, name):
                setattr(self, name, self._timing(getattr(estimator, name)))

    def _timing(self, call):
        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return call(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - start
        return timed

    def __getattr__(self, name):
        return getattr(self._inner, name)


def timed(scenario: Scenario) -> tuple[Recording, float]:
    """Run ``scenario`` (keeping its inputs) and return its recording and the seconds a UAV's estimation takes per
    step (the whole swarm's, divided by the UAVs and the steps)."""
    from swarmtrack.sim.build import build
    from swarmtrack.sim.engine import recorder_of, step_loop

    sim = build(scenario)
    clock = _Timed(sim.stack.estimator)
    sim.stack.estimator = clock
    rec = step_loop(sim, recorder_of(sim, scenario, inputs=True))
    return rec, clock.seconds / (sim.clock.steps * scenario.swarm.n_uavs)


@dataclass(frozen=True)
class Reference:
    """A tracker of the field on a run's detections: its name, its GOSPA (mean over the judged steps) and its
    seconds per step (the whole tracker's: it is one, fed every sensor)."""

    name: str
    gospa: float
    seconds_per_step: float


def scans(rec: Recording, scenario: Scenario) -> list[list[np.ndarray]]:
    """The run's detections as world positions, per step and UAV (what a fusion centre of the field is fed)."""
    to_positions = positions_sensor(scenario).position_rule(0.0)
    out = []
    for _k, _t, _nav, det in rec.inputs():
        p, _ = to_positions(det)
        out.append([p[det.owner == i] for i in range(det.n_uavs)])
    return out


def judged_gospa(rec: Recording, estimates: list[np.ndarray]) -> float:
    """The mean GOSPA of ``estimates`` (per step, (n, ≥ 2)) over the run's judged steps (after its settling)."""
    rows = objects(rec)
    values = []
    for c in rec.chunks(probes_wanted=False):
        for s, t in enumerate(c.t):
            if t >= rec.chase_start - 1e-9:
                k = int(round(t / rec.dt))
                values.append(gospa(estimates[k][:, :2], c.truth[s, rows, :2], C, P, ALPHA).distance)
    return float(np.mean(values))


def references(rec: Recording, scenario: Scenario) -> list[Reference]:
    """Stone Soup's GM-PHD (every UAV's detections, iterated corrector) and JPDA (the first UAV's) on the run's
    detections, with the scenario's model (its sensor's noise, detection probability and clutter over the
    estimator's region). Needs Stone Soup (``ImportError`` naming the extra otherwise)."""
    from swarmtrack.interop import stonesoup_mtt

    sensor, est = scenario.sensor, scenario.estimator
    assert isinstance(sensor, PositionSpec) and isinstance(est, LMBSpec) and est.region is not None, \
        "the references run on the box: a position sensor, an LMB filter with the box as its region"
    x0, y0, x1, y1 = est.region
    area = (x1 - x0) * (y1 - y0)
    rate = sensor.clutter_rate * area / (sensor.field_of_view() or area)  # the clutter the box holds
    args = (scans(rec, scenario), rec.dt, est.accel_std, sensor.sigma, sensor.detection_probability, rate,
            (x0, y0, x1, y1))
    out = []
    for name, run in (("Stone Soup GM-PHD, every sensor", stonesoup_mtt.gmphd),
                      ("Stone Soup JPDA, one sensor", stonesoup_mtt.jpda)):
        tracked = run(*args)
        out.append(Reference(name, judged_gospa(rec, tracked.estimates), tracked.seconds_per_step))
    return out
