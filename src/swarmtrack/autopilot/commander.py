"""The simulated vehicle's commander: its modes, arming, the commands that change them, the offboard setpoint stream
and its failsafe, and what each mode flies (reference: PX4-Autopilot v1.14, ``src/modules/commander/Commander.cpp``
``handle_command``, ``failsafe/failsafe.cpp``, ``failsafe/framework.cpp``; ``src/modules/mavlink/
mavlink_receiver.cpp``; parameters read by their PX4 names from the vehicle's table, ``params.get(NAME)``).

Commands (``COMMAND_LONG`` or ``COMMAND_INT``, answered with ``COMMAND_ACK``):

- ``MAV_CMD_COMPONENT_ARM_DISARM`` (400): arm (home is set where it first arms on the ground); disarm only landed,
  or with ``param2 = 21196`` (PX4's force: a kill in flight); a disarm in flight without it is
  ``MAV_RESULT_TEMPORARILY_REJECTED`` with ``STATUSTEXT`` "Disarming denied: not landed", as PX4;
- ``MAV_CMD_DO_SET_MODE`` (176), ``param1`` with ``MAV_MODE_FLAG_CUSTOM_MODE_ENABLED``, ``param2`` PX4's main mode,
  ``param3`` its sub mode within Auto: Position, Altitude, Manual, Stabilized (flown as Position with the pilot's
  sticks centred), Offboard (only with a fresh setpoint stream), Auto Takeoff, Hold (Loiter), Return (with a home),
  Land; Mission, Acro and Auto Ready are refused (``TEMPORARILY_REJECTED``, "Switching to X is currently not
  available"); an unknown Auto sub mode is ``MAV_RESULT_DENIED`` with PX4's "Unsupported auto mode";
- ``MAV_CMD_NAV_TAKEOFF`` (22): Takeoff (``param7``: altitude AMSL, NaN: ``MIS_TAKEOFF_ALT`` above home), climbing at
  ``MPC_TKO_SPEED``, then Hold; ``MAV_CMD_NAV_LAND`` (21): Land at ``MPC_LAND_SPEED``, disarmed ``COM_DISARM_LAND`` s
  after touching down; ``MAV_CMD_NAV_RETURN_TO_LAUNCH`` (20): climb to ``RTL_RETURN_ALT``, fly home at
  ``MPC_XY_CRUISE``, descend to ``RTL_DESCEND_ALT``, land;
- ``MAV_CMD_DO_REPOSITION`` (192): Hold at the given point (:meth:`Commander.reposition`);
- another command: ``MAV_RESULT_UNSUPPORTED``.

Offboard: a ``SET_POSITION_TARGET_LOCAL_NED`` (or ``SET_POSITION_TARGET_GLOBAL_INT``) that PX4 accepts
(:func:`~swarmtrack.autopilot.flight.setpoint_of`) is the offboard signal in any mode; it is flown only in Offboard
mode. One PX4 drops is counted
(:attr:`Commander.refused`, by PX4's text) and said once a second as ``STATUSTEXT`` (``MAV_SEVERITY_CRITICAL``).
Setpoints older than ``COM_OF_LOSS_T`` in Offboard mode are the offboard-loss failsafe: ``COM_OBL_RC_ACT`` (0
Position, 1 Altitude, 2 Manual, 3 Return, 4 Land, 5 Hold, 6 Terminate, 7 Disarm; PX4's ``fromOffboardLossActParam``)
with PX4's ``STATUSTEXT`` "Failsafe activated"; the heartbeat then shows the new mode. Armed, touching down and
lifting off are said as PX4 says them ("Landing detected", "Takeoff detected", ``MAV_SEVERITY_INFO``), and so are
arming and disarming ("Armed by external command", "Disarmed by landing", "... by auto preflight disarming", "... by
failsafe", "... by external command": PX4's ``arm_disarm_reason_str``). The vehicle
models a pilot with a radio: Position mode needs no further fallback.

Times are the caller's clock (``now``: simulated seconds in lockstep, the run's seconds in real time).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot import flight, px4
from swarmtrack.autopilot.flight import Limits, Setpoint, horizontal, setpoint_of, stopping_point, vertical

CRITICAL, INFO = mavlink.MAV_SEVERITY_CRITICAL, mavlink.MAV_SEVERITY_INFO
ACCEPTED, REJECTED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_TEMPORARILY_REJECTED
DENIED, UNSUPPORTED = mavlink.MAV_RESULT_DENIED, mavlink.MAV_RESULT_UNSUPPORTED
#: The pilot's modes, flown as Position mode with the sticks centred.
PILOT_MODES = (px4.MANUAL, px4.ALTCTL, px4.POSCTL, px4.STABILIZED)
#: Auto sub modes the vehicle flies.
AUTO_FLOWN = (px4.AUTO_TAKEOFF, px4.AUTO_LOITER, px4.AUTO_RTL, px4.AUTO_LAND)
#: COM_OBL_RC_ACT → (main, sub) of the failsafe's mode; 6 (Terminate) and 7 (Disarm) disarm.
OFFBOARD_LOSS_ACTIONS = {0: (px4.POSCTL, 0), 1: (px4.ALTCTL, 0), 2: (px4.STABILIZED, 0),
                         3: (px4.AUTO, px4.AUTO_RTL), 4: (px4.AUTO, px4.AUTO_LAND), 5: (px4.AUTO, px4.AUTO_LOITER)}
#: Metres within which a climb or descent has reached its altitude, and Return is above its home (then it lands).
REACHED_Z, REACHED_XY = 0.1, 0.5


class Commander:
    """One vehicle's modes and arming (module docstring). ``params``: its parameter table; ``say(severity, text)``
    sends a ``STATUSTEXT`` on its links; ``airborne``: it starts armed in the air in Position mode (a pilot who took
    off), else landed and disarmed; ``refuse``: results that replace the acceptance of ``"arm"``, ``"offboard"`` or
    ``"mode"`` (a vehicle whose checks fail, for tests)."""

    def __init__(self, params, say: Callable[[int, str], None], airborne: bool = False,
                 refuse: dict[str, int] | None = None):
        self.params, self.say, self.refuse = params, say, dict(refuse or {})
        self.armed, self.main, self.sub = airborne, px4.POSCTL, 0
        self.setpoint: Setpoint | None = None  # the latest accepted offboard setpoint
        self.signal_at = -math.inf  # when it came (the caller's clock)
        self.setpoint_ms = -1  # its time_boot_ms
        self.refused: Counter[str] = Counter()  # setpoints PX4 drops, by PX4's text
        self.failsafes: list[tuple[float, str]] = []  # (when, the mode it went to) of each offboard-loss failsafe
        self._said: dict[str, float] = {}
        self.home: np.ndarray | None = None  # NED (3,), set on the ground when it arms, or where it starts airborne
        self.anchor: np.ndarray | None = None  # the point (3,) its own mode holds, set when first flown
        self.target_z: float | None = None  # Takeoff's altitude (NED z)
        self.phase = ""  # Return's: climb, return, descend, land
        self.arrived_at: float | None = None  # when Return's descent reached its altitude above home
        self.armed_at = self.landed_at = None  # when it armed, when it touched down (None: not on the ground)
        self.flew = airborne  # it has been in the air since it armed
        self.changed = False  # the mode or arming changed: the vehicle tells it at once (HEARTBEAT)
        self.yaw = 0.0
        self.disarmed_by: str | None = None  # PX4's reason of the latest disarm
        self._on_ground: bool | None = None  # the land detector's latest

    # -- state ------------------------------------------------------------------------------------------------------

    def p(self, name: str) -> float:
        return float(self.params.get(name))

    def set_mode(self, main: int, sub: int = 0) -> None:
        if (main, sub) != (self.main, self.sub):
            self.main, self.sub, self.changed = main, sub, True
            self.anchor, self.target_z, self.phase = None, None, ""

    def offboard(self) -> bool:
        """Whether it flies the offboard setpoints: armed, in Offboard mode."""
        return self.armed and self.main == px4.OFFBOARD

    def fresh(self, now: float) -> bool:
        """Whether the offboard signal is fresh (a setpoint within ``COM_OF_LOSS_T``); one stamped later than
        ``now`` (a caller's clock that went back) is not."""
        return -1e-9 <= now - self.signal_at <= self.p("COM_OF_LOSS_T")

    def _disarm(self, reason: str) -> None:
        """Disarm, said as PX4 says it ("Disarmed by landing"; ``arm_disarm_reason_str``)."""
        self.armed, self.changed, self.armed_at = False, True, None
        self.disarmed_by = reason
        self.say(INFO, f"Disarmed by {reason}")

    def _say_once(self, text: str, now: float) -> None:
        """``STATUSTEXT`` at most once a second per text (the caller's clock)."""
        if now - self._said.get(text, -math.inf) >= 1.0:
            self._said[text] = now
            self.say(CRITICAL, text)

    # -- offboard setpoints -----------------------------------------------------------------------------------------

    def take_setpoint(self, msg, now: float, origin=None) -> bool:
        """A ``SET_POSITION_TARGET_LOCAL_NED`` (or ``..._GLOBAL_INT``, with the local frame's geodetic ``origin``):
        kept as the offboard signal when PX4 accepts it (True), else counted and said."""
        if msg.get_type() == "SET_POSITION_TARGET_GLOBAL_INT":
            sp, why = flight.global_setpoint_of(msg, origin, self.home)
        else:
            sp, why = setpoint_of(msg, self.yaw)
        if sp is None:
            self.refused[why] += 1
            self._say_once(why, now)
            return False
        if not (sp.horizontal_valid() and sp.vertical_valid()):
            self.refused["invalid setpoints"] += 1  # PX4's mc_pos_control flies its failsafe setpoint (brakes)
        self.setpoint, self.signal_at, self.setpoint_ms = sp, now, int(msg.time_boot_ms)
        return True

    # -- commands ---------------------------------------------------------------------------------------------------

    def command(self, cmd: int, params: tuple, now: float, on_ground: bool, position: np.ndarray) -> int:
        """The result of command ``cmd`` with ``params`` (param1..param7) at ``now``; ``on_ground``: the vehicle is
        landed; ``position``: its NED position (3,). A non-finite parameter is unset (0), as PX4's ``lroundf`` reads
        MAVSDK's NaN, except Takeoff's altitude (NaN: ``MIS_TAKEOFF_ALT``)."""
        raw = tuple(float(x) for x in params)
        params = tuple(x if math.isfinite(x) else 0.0 for x in raw)
        if cmd == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            return self._arm_disarm(params, now, on_ground, position)
        if cmd == mavlink.MAV_CMD_DO_SET_MODE:
            return self._set_mode_command(params, now)
        if cmd == mavlink.MAV_CMD_NAV_TAKEOFF:
            self.set_mode(px4.AUTO, px4.AUTO_TAKEOFF)
            if math.isfinite(raw[6]):
                self.target_z = -(raw[6] - self.home_amsl)
            return ACCEPTED
        if cmd == mavlink.MAV_CMD_NAV_LAND:
            self.set_mode(px4.AUTO, px4.AUTO_LAND)
            return ACCEPTED
        if cmd == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return self._switch(px4.AUTO, px4.AUTO_RTL, now)
        return UNSUPPORTED

    def reposition(self, target: np.ndarray, change_mode: bool, now: float, on_ground: bool) -> int:
        """``MAV_CMD_DO_REPOSITION`` (QGroundControl's "go to location", MAVSDK's ``goto_location``) to the NED point
        ``target`` (3,): in Hold (switched to when ``change_mode``, PX4's ``MAV_DO_REPOSITION_FLAGS_CHANGE_MODE``), it
        flies there at ``MPC_XY_CRUISE`` and holds it. Only armed in the air (PX4's navigator ignores it on the
        ground)."""
        if not self.armed or on_ground:
            self._say_once("Reposition is only possible in the air", now)
            return REJECTED
        if change_mode:
            result = self._switch(px4.AUTO, px4.AUTO_LOITER, now)
            if result != ACCEPTED:
                return result
        if (self.main, self.sub) == (px4.AUTO, px4.AUTO_LOITER):
            self.anchor = np.asarray(target, dtype=float).copy()
        return ACCEPTED

    home_amsl = 0.0
    """The home's altitude above mean sea level (m): Takeoff's ``param7`` is AMSL (the vehicle sets it from its
    origin)."""

    def _arm_disarm(self, params: tuple, now: float, on_ground: bool, position: np.ndarray) -> int:
        action, force = int(round(params[0])), int(round(params[1])) == px4.FORCE_MAGIC
        if action == 1:
            result = self.refuse.get("arm", ACCEPTED)
            if result == ACCEPTED and not self.armed:
                self.armed, self.changed, self.armed_at, self.flew = True, True, now, not on_ground
                self.say(INFO, "Armed by external command")
                self.landed_at = now if on_ground else None
                if on_ground or self.home is None:
                    self.home = np.array([position[0], position[1], position[2] if on_ground else 0.0])
            return result
        if action != 0:
            self._say_once(f"Unsupported ARM_DISARM param: {params[0]:.3f}", now)
            return DENIED
        if self.armed and not on_ground and not force:
            self._say_once("Disarming denied: not landed", now)
            return REJECTED
        if self.armed:
            self._disarm("external command")
        return ACCEPTED

    def _set_mode_command(self, params: tuple, now: float) -> int:
        base, main, sub = int(params[0]), int(params[1]), int(params[2])
        if not base & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return DENIED  # PX4's base-mode switching (manual/auto flags) is not modelled
        if main == px4.AUTO:
            if sub == 0:
                sub = px4.AUTO_MISSION  # PX4: Auto without a sub mode is Mission
            if (px4.AUTO, sub) not in px4.MODE_NAMES:
                self._say_once("Unsupported auto mode", now)
                return DENIED
        return self._switch(main, sub if main == px4.AUTO else 0, now)

    def _switch(self, main: int, sub: int, now: float) -> int:
        """Switch to (main, sub) if it can run (PX4's ``UserModeIntention::change``), else say why not."""
        flown = main in PILOT_MODES or main == px4.OFFBOARD or (main == px4.AUTO and sub in AUTO_FLOWN)
        can_run = flown and not (main == px4.OFFBOARD and not self.fresh(now)) \
            and not (main == px4.AUTO and sub == px4.AUTO_RTL and self.home is None)
        result = ACCEPTED if can_run else REJECTED
        result = self.refuse.get("offboard" if main == px4.OFFBOARD else "mode", result)
        if result == ACCEPTED:
            self.set_mode(main, sub)
        elif not can_run:
            self._say_once(f"Switching to {px4.mode_name(main, sub)} is currently not available", now)
        return result

    # -- the state machine ------------------------------------------------------------------------------------------

    def update(self, now: float, on_ground: bool, z: float) -> None:
        """What time does: the offboard-loss failsafe, Takeoff done (then Hold), touch-down and the auto-disarms
        (``COM_DISARM_LAND`` s after touching down, ``COM_DISARM_PRFLT`` s after arming without taking off, in any
        mode but Takeoff, as PX4's ``Commander::checkForAutoDisarm``). ``z``: its NED altitude (m)."""
        if self.main == px4.OFFBOARD and self.armed and not self.fresh(now):
            action = int(self.p("COM_OBL_RC_ACT"))
            if action in (6, 7):
                self.set_mode(px4.POSCTL)
                self._disarm("failsafe")
            else:
                self.set_mode(*OFFBOARD_LOSS_ACTIONS.get(action, (px4.POSCTL, 0)))
            self.failsafes.append((now, px4.mode_name(self.main, self.sub)))
            self.say(CRITICAL, "Failsafe activated")
        was, self._on_ground = self._on_ground, on_ground
        if self.armed and was is not None and was != on_ground:  # PX4's Commander::landDetectorUpdate
            self.say(INFO, "Landing detected" if on_ground else "Takeoff detected")
        if not self.armed:
            self.landed_at = now if on_ground else None
            return
        if not on_ground:
            self.flew, self.landed_at = True, None
        elif self.landed_at is None:
            self.landed_at = now
        if self.main == px4.AUTO and self.sub == px4.AUTO_TAKEOFF and self.target_z is not None \
                and z <= self.target_z + REACHED_Z and not on_ground:
            top = min(z, self.target_z)  # NED: already higher, it stays there
            takeoff = None if self.anchor is None else np.array([self.anchor[0], self.anchor[1], top])
            self.set_mode(px4.AUTO, px4.AUTO_LOITER)
            self.anchor = takeoff  # Hold keeps the takeoff's point and altitude
        if on_ground and self.landed_at is not None:
            wait = self.p("COM_DISARM_LAND") if self.flew else self.p("COM_DISARM_PRFLT")
            taking_off = self.main == px4.AUTO and self.sub == px4.AUTO_TAKEOFF
            if wait > 0 and now - self.landed_at >= wait and not taking_off:
                self._disarm("landing" if self.flew else "auto preflight disarming")

    def landed_state(self, on_ground: bool, vz: float) -> int:
        """``MAV_LANDED_STATE``: on the ground, taking off, landing, in the air."""
        if on_ground:
            return mavlink.MAV_LANDED_STATE_ON_GROUND
        if self.main == px4.AUTO and self.sub == px4.AUTO_TAKEOFF:
            return mavlink.MAV_LANDED_STATE_TAKEOFF
        if self.main == px4.AUTO and (self.sub == px4.AUTO_LAND or self.phase == "land") and vz > 0:
            return mavlink.MAV_LANDED_STATE_LANDING
        return mavlink.MAV_LANDED_STATE_IN_AIR

    # -- what it flies ----------------------------------------------------------------------------------------------

    def fly(self, now: float, p: np.ndarray, v: np.ndarray, on_ground: bool) -> tuple[np.ndarray, float]:
        """The horizontal acceleration (2,) and the vertical one (NED) it flies now from position ``p`` and velocity
        ``v`` (3,) (NED): the offboard setpoint, or its mode's own control."""
        lim = Limits.of(self.params)
        if self.offboard() and self.fresh(now) and self.setpoint is not None:
            sp = self.setpoint
            if math.isfinite(sp.yaw):
                self.yaw = sp.yaw
            return horizontal(sp, p[:2], v[:2], lim), vertical(sp, p[2], v[2], lim)
        brake = -lim.xy_vel_p * v[:2]
        if not self.armed:
            return (brake if on_ground else np.zeros(2)), 0.0
        if self.anchor is None or not np.isfinite(self.anchor).all():  # a NaN navigation sets none for good
            self.anchor = np.append(stopping_point(p[:2], v[:2], lim.acc_hor), p[2])
        if self.main == px4.AUTO and self.sub == px4.AUTO_TAKEOFF:
            if self.target_z is None:
                self.target_z = (self.home[2] if self.home is not None else p[2]) - self.p("MIS_TAKEOFF_ALT")
            return self._to(self.anchor[:2], self.target_z, p, v, lim, climb=self.p("MPC_TKO_SPEED"))
        if on_ground and not (self.main == px4.AUTO and self.sub == px4.AUTO_TAKEOFF):
            return brake, 0.0  # stays on the ground until it takes off
        if self.main == px4.AUTO and self.sub == px4.AUTO_LAND:
            return self._land(self.anchor[:2], p, v, lim)
        if self.main == px4.AUTO and self.sub == px4.AUTO_RTL:
            return self._return(now, p, v, lim)
        return self._to(self.anchor[:2], self.anchor[2], p, v, lim)  # Position, Hold and the pilot's modes

    def _to(self, xy: np.ndarray, z: float, p: np.ndarray, v: np.ndarray, lim: Limits,
            climb: float | None = None, descend: float | None = None) -> tuple[np.ndarray, float]:
        sp = Setpoint(position=np.array([xy[0], xy[1], z]))
        return horizontal(sp, p[:2], v[:2], lim, own_mode=True), vertical(sp, p[2], v[2], lim, climb, descend)

    def _land(self, xy: np.ndarray, p: np.ndarray, v: np.ndarray, lim: Limits) -> tuple[np.ndarray, float]:
        sp = Setpoint(position=np.array([xy[0], xy[1], math.nan]), velocity=np.array([math.nan, math.nan,
                                                                                    self.p("MPC_LAND_SPEED")]))
        return horizontal(sp, p[:2], v[:2], lim, own_mode=True), vertical(sp, p[2], v[2], lim)

    def _return(self, now: float, p: np.ndarray, v: np.ndarray, lim: Limits) -> tuple[np.ndarray, float]:
        """PX4's Return (``navigator/rtl_direct.cpp``): climb to ``RTL_RETURN_ALT`` above home (or stay higher), fly
        home at ``MPC_XY_CRUISE``, descend to ``RTL_DESCEND_ALT`` once within ``NAV_ACC_RAD`` of it, hover
        ``RTL_LAND_DELAY`` s above it (−1: for good), land."""
        home = self.home
        if not self.phase:
            self.phase, self.anchor = "climb", np.array([p[0], p[1], min(p[2], home[2] - self.p("RTL_RETURN_ALT"))])
        if self.phase == "climb" and p[2] <= self.anchor[2] + REACHED_Z:
            self.phase = "return"
        off = float(np.linalg.norm(p[:2] - home[:2]))
        if self.phase == "return" and off < self.p("NAV_ACC_RAD"):
            self.phase, self.arrived_at = "descend", None
        descend_z = max(self.anchor[2], home[2] - self.p("RTL_DESCEND_ALT"))
        if self.phase == "descend" and p[2] >= descend_z - REACHED_Z and off < REACHED_XY:
            self.arrived_at = now if self.arrived_at is None else self.arrived_at
            delay = self.p("RTL_LAND_DELAY")
            if delay >= 0 and now - self.arrived_at >= delay:  # -1: it stays there
                self.phase = "land"
        if self.phase == "climb":
            return self._to(self.anchor[:2], self.anchor[2], p, v, lim)
        if self.phase == "return":
            return self._to(home[:2], self.anchor[2], p, v, lim)
        if self.phase == "descend":
            return self._to(home[:2], descend_z, p, v, lim)
        return self._land(home[:2], p, v, lim)
