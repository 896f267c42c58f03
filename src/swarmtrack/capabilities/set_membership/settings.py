"""IB21's settings: the footprint sensor with identification cones, the set-membership estimator and the
set-membership MPC."""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import Field

from swarmtrack.network.delays import delay_steps
from swarmtrack.scenarios.schema import (
    LIAR_NEEDS,
    Angle,
    AngularRate,
    Box,
    ControllerSpec,
    EstimatorSpec,
    HalfWidths,
    Length,
    Scenario,
    SensorSpec,
    Speed,
    Time,
)


class FootprintSpec(SensorSpec):
    """IB21's downward camera on fixed-wing UAVs: every walker in the footprint detected with box noise, identified
    only from inside a narrow cone (Sec. 3.2, Sec. 6, eqs. 50-54; our readings in docs/set-membership.md)."""

    kind: Literal["footprint"] = "footprint"
    gives: ClassVar[frozenset[str]] = frozenset({"bounded_detections"})
    opening: Angle = Field(0.7853981633974483, gt=0, description="rad, in azimuth and elevation (IB21: π/4)")
    convention: Literal["full", "half"] = Field("full", description=(
        "full: the opening is the full angle (82.8 m square at 100 m); half: the half angle (200 m)"))
    orientation: Literal["heading", "north"] = Field("heading", description="the footprint's sides")
    noise_bound: HalfWidths = Field((5.0, 5.0), description=(
        "m, the TRUE noise half-widths per axis (uniform; IB21: 5)"))
    confusion: Literal["outside_inner_cone", "inside_inner_cone"] = Field("outside_inner_cone", description=(
        "where a decoy is confused with a target: outside its inner π/60 cone (the text, Fig. 3) or inside (eq. 53)"))

    def check(self, scenario: Scenario) -> None:
        if scenario.swarm.vehicle != "fixed_wing":
            raise ValueError("sensor.kind footprint needs swarm.vehicle: fixed_wing")
        for group in ("targets", "decoys"):
            g = getattr(scenario, group)
            if g.size() and g.vehicle != "walker":
                raise ValueError(f"sensor.kind footprint needs {group}.vehicle: walker")
        if self.latency or self.occluders:
            raise ValueError("sensor.kind footprint has no latency or occluders")


class SetMembershipSpec(EstimatorSpec):
    """IB21's guaranteed search and track of targets among decoys (Algorithm 1): every UAV keeps the sets where each
    identified target, each unidentified object and anything unexplored can be, shares them every ``period``."""

    kind: Literal["setmembership"] = "setmembership"
    reads: ClassVar[frozenset[str]] = frozenset({"bounded_detections"})
    area: Box = Field((0.0, 0.0, 400.0, 400.0), description="X0 = [x0, y0, x1, y1], m")
    target_speed: Speed | None = Field(None, gt=0, description=(
        "m/s, the speed bound V^t the sets grow with; default: the targets' speed"))
    noise_bound: HalfWidths = Field((5.0, 5.0), description=(
        "m, the ASSUMED noise half-widths per axis (the guarantee needs them to contain the true ones)"))
    period: Time = Field(0.5, gt=0, description="s, between exchanges T^c (IB21: 0.5)")
    delayed_data: Literal["refused", "refilter"] = Field("refused", description=(
        "refused: network.delay is refused; refilter: a late neighbour's sets are fused at the time they describe "
        "and the updates since are replayed (IB21 Sec. 4.5), over a window of the delay bound in periods"))
    sets: Literal["polygons", "raster"] = Field("polygons", description=(
        "how the sets are held: polygons (shapely, exact up to outward margins of micrometres) or raster (grids of "
        "distance lower bounds, outer by up to a cell's half-diagonal along their edges; faster: "
        "docs/set-membership.md)"))
    cell: Length = Field(1.0, gt=0, le=50, description="m, the side of a raster cell (sets: raster)")

    def speed_bound(self, scenario: Scenario) -> float:
        return self.target_speed if self.target_speed is not None else scenario.targets.speed

    def replayed_periods(self, scenario: Scenario) -> int:
        """δ̄ of IB21 Sec. 4.5: how many sharing periods late a neighbour's sets can be fused, 0 without delays or
        neighbours. A message waits :func:`~swarmtrack.network.delays.delay_steps` estimation steps and is fused
        at the first sharing time after it arrived: the delay bound rounded up to whole periods."""
        if self.delayed_data != "refilter" or scenario.network.topology == "none":
            return 0
        dt = 1.0 / scenario.rates.estimation
        steps = int(delay_steps(scenario.network.delay_bound(), dt))
        per_period = round(self.period / dt)  # a whole number of steps (checked)
        return -(-steps // per_period)

    def check_network(self, scenario: Scenario) -> None:
        """A neighbour's late sets are fused at their time only with ``delayed_data: refilter`` (IB21 Sec. 4.5)."""
        if scenario.network.delay_bound() > 0 and self.delayed_data != "refilter":
            raise ValueError("network.delay needs estimator.delayed_data: refilter with estimator.kind setmembership "
                             "(a late neighbour's sets are fused at their time and the updates since replayed, IB21 "
                             "Sec. 4.5)")
        if scenario.network.liar is not None:
            raise ValueError(LIAR_NEEDS)

    def check(self, scenario: Scenario) -> None:
        if scenario.swarm.nav_position_std or scenario.swarm.nav_velocity_std:
            raise ValueError("swarm.nav_position_std and nav_velocity_std must be 0 with estimator.kind "
                             "setmembership: a Gaussian pose error has no bound, so no footprint is guaranteed")
        ratio = self.period * scenario.rates.estimation
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f"estimator.period {self.period:g} s must be a whole number of estimation steps")


class SMMPCSpec(ControllerSpec):
    """IB21 Sec. 5's set-membership MPC: every UAV picks, from a discrete set of yaw accelerations, the sequence over
    the horizon that leaves the smallest predicted set to search (plus α times its distance to it), given the plans of
    its lower-indexed neighbours; ``baseline``: the paper's SimpleBaselineMPC."""

    kind: Literal["sm_mpc"] = "sm_mpc"
    commands: ClassVar[int | None] = 1  # a fixed wing's yaw acceleration
    inputs: list[AngularRate] = Field([0.0, 0.25, -0.25, 0.5, -0.5], min_length=1, description=(
        "rad/s², the yaw accelerations tried, in tie order (ours: IB21 gives none)"))
    horizon: int = Field(2, ge=1, le=6, description="steps of the control period (IB21: 2)")
    period: Time = Field(0.5, gt=0, description="s (IB21: 0.5)")
    alpha: float = Field(1e-4, ge=0, le=1e6, description="weight of the distance to the set (IB21: 1e-4)")
    distance: Literal["nearest", "hausdorff"] = Field("nearest", description=(
        "eq. 47's distance from the UAV to the set: nearest point (ours) or farthest (the Hausdorff distance)"))
    baseline: bool = Field(False, description="SimpleBaselineMPC: no neighbours' plans, no growth of the sets")

    def check(self, scenario: Scenario) -> None:
        if scenario.estimator.kind != "setmembership" or scenario.swarm.vehicle != "fixed_wing":
            raise ValueError("controller.kind sm_mpc needs estimator.kind: setmembership and swarm.vehicle: fixed_wing")
        ratio = self.period * scenario.rates.control
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f"controller.period {self.period:g} s must be a whole number of control steps")
        if scenario.rates.physics != scenario.rates.estimation:
            raise ValueError("controller.kind sm_mpc predicts with the physics step: rates.estimation must equal "
                             "rates.physics (IB21: both T_d = 0.05 s)")
