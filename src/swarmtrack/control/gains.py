"""The flocking protocols' gains and parameters (L24 Sec. 2, L23 Secs. 2-4): plain data with its own checks, which
the scenario's settings validate against without importing the control laws (:mod:`swarmtrack.control.flocking`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FlockingGains:
    """Gains and parameters of the flocking protocols (units: m, s; gains in s⁻² or s⁻¹ as appropriate).

    The papers give d = 4 m and r_comm = 4.8 m (L23 Sec. 4) but no gains, so the defaults were tuned on the
    L23 Fig. 1 experiment: 3 agents, target at rest at the origin (and, separately, moving at 0.5 m/s),
    random initial positions in a 10 m box, dt = 0.05 s, 60 s, agents modelled as double integrators with a
    first-order lag (τ = 0.15 s) on the commanded acceleration, standing in for the quadrotor attitude loop,
    and the acceleration clipped to 3 m/s². The tuning targets (checked over 20 seeds, static and moving
    target, see ``tests/control/test_flocking.py``):

    * standard: clear steady-state spacing offset (the target spring ``K_dt`` compresses the formation;
      equilibrium ``a(s) φ(‖s‖σ − ‖d‖σ)/(1 + ε‖s‖σ) = −K_dt/(3 K_d)`` for an equilateral triangle of side s);
      ``K_dt / K_d = 1.5`` gives s ≈ 3.5 m, i.e. ≈ 0.5 m offset;
    * integral: offset removed (``K_int``); the transient keeps the large overshoot of the strong constant
      target spring (agents rushing in from afar cross d by > 1 m) and the integral must wind up to cancel
      ``K_dt ‖q_i − q_t‖`` at the end;
    * tailored: offset removed and a smoother transient: the dynamic gain ``atan(‖q_i − q_t‖/D_dt)`` is
      below ``K_dt`` everywhere (≤ π/2) and small near the target, so agents approach more gently and much
      less integral has to build up. Note that with the target velocity used here ``∫ (p_i − p_t) dt`` equals
      the displacement of ``q_i − q_t`` since activation, so ``K_vint`` acts as a weak spring towards the
      initial relative position; it is kept small because it also helps hold open-chain configurations.

    Measured with these defaults (seeds 0-19, static target; 0.5 m/s target gives the same to ±0.02 m):
    standard offset 0.47 m on every seed; integral and tailored offsets < 1e-3 m on every seed; overshoot
    (max |distance − d| after a pair first reaches d) mean 1.41 m integral vs 0.62 m tailored, tailored
    lower on 20/20 seeds. Out of sample (seeds 20-59) tailored still removes the offset on 38/40 seeds (the
    two failures settle as an open chain with one pair beyond r_comm, which the integral terms then hold)
    and has the lower overshoot on 34/40. Lowering ``D_dt`` or ``K_vint`` trades smoothness for fewer
    such open-chain equilibria; raising ``K_int`` speeds the offset removal but favours them too.

    ``h`` is chosen so that the bump weight is 1 at the desired spacing (‖d‖σ/‖r_comm‖σ ≈ 0.75 for ε = 0.1),
    i.e. the regulator acts at full strength around d and fades out only between ≈ 4.17 m and r_comm.
    """

    K_d: float = 1.0
    """Distance-regulator gain (L24 eq. 1 u_d)."""
    K_v: float = 1.0
    """Velocity-consensus gain (L24 u_v)."""
    K_dt: float = 1.5
    """Constant target position gain for the standard and integral variants (L24 eq. 2)."""
    K_vt: float = 1.5
    """Target velocity gain (L24 eq. 2); also the damping that holds inactive agents in place."""
    K_int: float = 0.2
    """Gain of the integral of the inter-agent distance error (L23 eq. 8)."""
    K_vint: float = 0.1
    """Gain of the integral of the agent-target velocity mismatch (L23 eq. 9), tailored only."""
    D_dt: float = 3.0
    """Scale of the tailored dynamic target gain ``atan(‖q_i − q_t‖/D_dt)`` (L24 eq. 3), metres."""
    eps: float = 0.1
    """σ-norm parameter ε ∈ (0, 1)."""
    h: float = 0.8
    """Bump-function parameter h ∈ (0, 1)."""
    d: float = 4.0
    """Desired inter-agent distance (L23 Sec. 4), metres."""
    r_comm: float = 4.8
    """Communication / interaction range (L23 Sec. 4), metres."""
    accel_limit: float = 3.0
    """Norm clip on the commanded acceleration, m/s² (≤ 0 or inf disables it)."""

    def __post_init__(self) -> None:
        if not 0.0 < self.eps < 1.0:
            raise ValueError("eps must be in (0, 1)")
        if not 0.0 < self.h < 1.0:
            raise ValueError("h must be in (0, 1)")
        if self.d <= 0.0 or self.r_comm <= 0.0 or self.D_dt <= 0.0:
            raise ValueError("d, r_comm and D_dt must be positive")
        negative = [k for k in ("K_d", "K_v", "K_dt", "K_vt", "K_int", "K_vint") if not getattr(self, k) >= 0.0]
        if negative:  # the papers' gains are positive (L24 Sec. 2); zero switches a term off
            raise ValueError(f"{', '.join(negative)} must be non-negative")
