"""Who flies the vehicle: the operator always wins.

PX4 lets a companion computer fly the vehicle in offboard mode, and anyone else take it back: a pilot's mode switch,
a ground station's command, the autopilot's own failsafe, a disarm or a landing. From the companion computer all of
these look alike (the heartbeat's mode is no longer offboard), so :class:`Authority`:

- engages once, when the UAV joins its swarm (:meth:`Authority.engage`: arm if disarmed, stream setpoints for
  :data:`PRIME` s, ``MAV_CMD_DO_SET_MODE`` to offboard);
- hands over whenever the vehicle leaves offboard mode or is disarmed, whatever the reason: it stops its setpoint
  stream at once (in the thread that reads the heartbeat), records the handover (:attr:`Authority.events`: when, the
  mode the vehicle went to, who is believed to have caused it, as far as MAVLink tells: :func:`cause`) and never
  takes the vehicle back by itself;
- re-engages only on an explicit act: ``MAV_CMD_NAV_GUIDED_ENABLE`` (param1 = 1; MAVLink's "hand control over to an
  external controller") addressed to this companion computer (component ``MAV_COMP_ID_ONBOARD_COMPUTER``), from a
  ground station through the autopilot (``swarmtrack engage``), answered with ``COMMAND_ACK``; param1 = 0 hands the
  vehicle back (to Hold). It is refused on a disarmed or landed vehicle;
- with ``reengage_after_link_loss`` (opt-in, dangerous: a pilot who took the vehicle while the link was down loses it
  again when the link returns) re-engages after the offboard-loss failsafe that followed a silence of the link, only
  while the vehicle is armed, in the air and still in the failsafe's mode; never after a mode change that came while
  the link was heard.

Engaging again runs in a thread of its own: the UAV's step loop never waits on the autopilot.
"""

from __future__ import annotations

import threading
import time

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from swarmtrack.autopilot import px4
from swarmtrack.autopilot.link import ACK_TIMEOUT, AutopilotLink, AutopilotRefused, AutopilotSilent

#: Seconds of setpoints streamed before asking for offboard mode (PX4 v1.14 enters it only after they came for over a
#: second).
PRIME = 1.2
#: A silence of the link at least this long (s) before a handover makes it the offboard-loss failsafe (PX4's default
#: ``COM_OF_LOSS_T``, 1 s: shorter silences cannot have tripped it).
LINK_LOSS = 1.0
#: How recent (s) the end of a silence of the link must be to explain a handover (the first heartbeat after a link
#: comes back arrives within a second of it), and how recent a STATUSTEXT.
SILENCE_ENDED, RECENT = 1.5, 3.0
#: The modes PX4's offboard-loss failsafe can leave the vehicle in (``COM_OBL_RC_ACT``), where the opt-in re-engages.
FAILSAFE_MODES = {(px4.POSCTL, 0), (px4.AUTO, px4.AUTO_LOITER)}
#: How many times the opt-in asks for offboard mode again when the autopilot does not answer in time (a link that
#: just came back, or a busy companion computer, may lose an acknowledgement); a refusal is final.
REENGAGE_TRIES = 3


def cause(armed: bool, mode: int | None, sub: int, landed: int | None, silence: float, text: str | None) -> str:
    """Who is believed to have taken the vehicle, from what MAVLink tells: ``"disarm"`` (not armed), ``"land"`` (Land
    mode), ``"failsafe"`` (a silence of the link of at least :data:`LINK_LOSS` s came before, or the autopilot said
    "failsafe"), ``"land"`` again on the ground or landing, otherwise ``"operator"`` (a pilot's switch or a ground
    station's command)."""
    if not armed:
        return "disarm"
    if (mode, sub) == (px4.AUTO, px4.AUTO_LAND):
        return "land"
    if silence >= LINK_LOSS or (text is not None and "failsafe" in text.lower()):
        return "failsafe"
    if landed in (mavlink.MAV_LANDED_STATE_ON_GROUND, mavlink.MAV_LANDED_STATE_LANDING):
        return "land"
    return "operator"


class Authority:
    """Operator authority over UAV ``link.uav``'s vehicle (module docstring)."""

    def __init__(self, link: AutopilotLink, reengage_after_link_loss: bool = False, prime: float = PRIME):
        self.link, self.reengage_after_link_loss, self.prime = link, reengage_after_link_loss, prime
        self.engaged = False
        self.engaging = False  # a re-engagement's thread is on its way
        self.events: list[dict] = []  # handovers and engagements, in order (``t`` filled by :meth:`take`)
        self._new: list[dict] = []  # not yet taken by the UAV's step
        self._releasing = False  # handing the vehicle back on a ground station's request
        self._lock = threading.Lock()
        link.watch(self._watch)

    def engage(self) -> None:
        """Arm if disarmed, stream zero setpoints for :attr:`prime` s, enter offboard mode (:class:`AutopilotRefused`
        on a refusal): when the UAV joins (it may wait), or in a thread on an explicit request. Engaged once the
        heartbeat says offboard."""
        link = self.link
        if not link.armed:
            link.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0, what="to arm")
        link.send_acceleration(np.zeros(2), max(link.nav_ms, 0) / 1000)
        time.sleep(self.prime)
        try:
            link.command(mavlink.MAV_CMD_DO_SET_MODE, float(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED),
                         float(px4.OFFBOARD), what="offboard mode")
            if not link.wait(lambda: link.mode == px4.OFFBOARD and link.armed, ACK_TIMEOUT):
                raise AutopilotRefused(f"UAV {link.uav + 1}'s autopilot accepted offboard mode but its heartbeat "
                                       f"did not say so within {ACK_TIMEOUT:g} s")
        except AutopilotRefused:
            link.stop_stream()
            raise
        with self._lock:
            self.engaged = True

    def fly(self, accel: np.ndarray, t: float) -> bool:
        """Send the controller's acceleration of time ``t`` while engaged; returns whether it was sent."""
        with self._lock:
            if self.engaged:
                self.link.send_acceleration(accel, t)
            return self.engaged

    def take(self, t: float) -> list[dict]:
        """The handovers and engagements since the last call, stamped with the UAV's time ``t`` (s), the first step
        that saw them."""
        with self._lock:
            new, self._new = self._new, []
        for event in new:
            event["t"] = round(t, 9)
        return new

    def _record(self, event: dict) -> None:
        self.events.append(event)
        self._new.append(event)

    def _watch(self) -> None:
        """In the link's reading thread, after a heartbeat or a request: hand over at once when the vehicle left
        offboard mode or was disarmed; serve the requests."""
        link = self.link
        with self._lock:
            if self.engaged and (link.mode != px4.OFFBOARD or not link.armed):
                self.engaged = False
                link.stop_stream()
                now = time.monotonic()
                silence = max([gap for at, gap in link.gaps if now - at < SILENCE_ENDED], default=0.0)
                text = next((text for at, text in reversed(link.texts) if now - at < RECENT), None)
                event = {"event": "handover", "mode": px4.mode_name(link.mode, link.sub_mode), "armed": link.armed,
                         "cause": "released" if self._releasing else
                         cause(link.armed, link.mode, link.sub_mode, link.landed, silence, text)}
                if text is not None:
                    event["autopilot_said"] = text
                if silence:
                    event["link_silent_s"] = round(silence, 3)
                self._record(event)
                self._releasing = False
                if event["cause"] == "failsafe" and silence >= LINK_LOSS and self.reengage_after_link_loss:
                    self._start(None)
        while link.requests:
            self._serve(link.requests.popleft())

    def _serve(self, request) -> None:
        """A ground station's ``MAV_CMD_NAV_GUIDED_ENABLE``: param1 = 1 engage, 0 hand back (to Hold)."""
        link = self.link
        if request.param1 < 0.5:
            if self.engaged:
                threading.Thread(target=self._release, args=(request,), daemon=True).start()
            else:
                link.acknowledge(request, mavlink.MAV_RESULT_ACCEPTED, f"UAV {link.uav + 1}: not engaged")
            return
        refusal = ("already engaged" if self.engaged else "engaging") if self.engaged or self.engaging \
            else self._unfit()
        if refusal is not None:
            link.acknowledge(request, mavlink.MAV_RESULT_DENIED, f"UAV {link.uav + 1}: {refusal}")
            return
        self._start(request)

    def _unfit(self) -> str | None:
        """Why the vehicle cannot be engaged now (None: it can): disarmed, or not in the air."""
        link = self.link
        if not link.armed:
            return "disarmed: arm and take off first"
        if link.landed in (mavlink.MAV_LANDED_STATE_ON_GROUND, mavlink.MAV_LANDED_STATE_LANDING,
                           mavlink.MAV_LANDED_STATE_TAKEOFF):
            return "not in the air: take off first"
        return None

    def _start(self, request) -> None:
        self.engaging = True
        threading.Thread(target=self._reengage, args=(request,), name="mavlink-engage", daemon=True).start()

    def _reengage(self, request) -> None:
        """Engage again (a thread): on a ground station's ``request``, or (None) the opt-in after a link loss, once
        the link is heard again and only while the vehicle is armed, in the air and in the failsafe's mode; the opt-in
        asks up to :data:`REENGAGE_TRIES` times while the autopilot does not answer, and records why it gave up
        (``"not engaged"``): it never fails silently."""
        link = self.link
        try:
            for attempt in range(1 if request is not None else REENGAGE_TRIES):
                if request is None:
                    why = self._not_after_link_loss()
                    if why is not None:
                        self._record_locked({"event": "not engaged", "why": why})
                        return
                try:
                    self.engage()
                    break
                except AutopilotRefused as exc:
                    if request is not None:
                        link.acknowledge(request, mavlink.MAV_RESULT_FAILED, str(exc)[:50])
                        return
                    if not isinstance(exc, AutopilotSilent) or attempt == REENGAGE_TRIES - 1:
                        self._record_locked({"event": "not engaged", "why": f"{exc} (try {attempt + 1})"})
                        return
            self._record_locked({"event": "engaged", "by": "link back (--reengage-after-link-loss)"
                                 if request is None else f"NAV_GUIDED_ENABLE from system {request.get_srcSystem()}, "
                                 f"component {request.get_srcComponent()}"})
            if request is not None:
                link.acknowledge(request, mavlink.MAV_RESULT_ACCEPTED, f"UAV {link.uav + 1}: engaged")
        finally:
            self.engaging = False

    def _not_after_link_loss(self) -> str | None:
        """Why the opt-in must not engage now (None: it may): the link is not heard again within 60 s, the vehicle
        left the failsafe's mode (someone took it), or it is unfit (:meth:`_unfit`)."""
        link = self.link
        if not link.wait(lambda: time.monotonic() - link.heard < 0.2, 60.0):
            return "the link did not come back within 60 s"
        if (link.mode, link.sub_mode) not in FAILSAFE_MODES:
            return f"the vehicle left the failsafe's mode: {px4.mode_name(link.mode, link.sub_mode)}"
        return self._unfit()

    def _record_locked(self, event: dict) -> None:
        with self._lock:
            self._record(event)

    def _release(self, request) -> None:
        """Hand the vehicle back on a ground station's request: Hold (the handover is recorded from its heartbeat)."""
        self._releasing = True
        try:
            self.link.command(mavlink.MAV_CMD_DO_SET_MODE, float(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED),
                              float(px4.AUTO), float(px4.AUTO_LOITER), what="Hold")
            self.link.acknowledge(request, mavlink.MAV_RESULT_ACCEPTED, f"UAV {self.link.uav + 1}: released")
        except AutopilotRefused as exc:
            self._releasing = False
            self.link.acknowledge(request, mavlink.MAV_RESULT_FAILED, str(exc)[:50])
