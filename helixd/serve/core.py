"""``helixd serve``'s decisions, pure: what the service is doing, and what it answers.

No socket, clock or log here (:mod:`helixd.serve.service` is the shell). The service is in
one :class:`ServeState` at a time, told to the ground station as NAMED_VALUE_INT ``hx_state``
(the enum's value) and a STATUSTEXT on every change. Requests come from three places and are
judged the same way:

* the start switch (``startup.start_switch_channel``): a low → high edge asks to start (or
  continue), high → low mid-flight asks to pause. A switch found high when the service comes
  up is *not* a start: it must be seen low first, so a reboot never drives off on its own;
* ``MAV_CMD_MISSION_START`` (param1 first item: 0 continues where the last flight stopped, 1
  starts from item 1, k > 1 starts from item k with the jump counters at zero, as
  ``AP_Mission::start`` and a *set current item* k do; param2 last item: 0, -1 or the
  mission's last item: helixd flies to the end) addressed to helixd;
* ``MAV_CMD_DO_PAUSE_CONTINUE`` (param1 0 pause, 1 continue) addressed to helixd; 1 also
  ends a NAV_LOITER_UNLIM hold of the flight in progress. A continue goes on from the first
  waypoint not reached, or a mission with commands from the step it stopped at
  (:func:`helixd.prepare.builder.continue_commands`).
* ``MAV_CMD_DO_CHANGE_SPEED`` (param2 m/s) addressed to helixd (:func:`answer_speed`): the
  cruise speed of the flight in progress from now on. One sent to the autopilot (the
  ground station's fly view) cannot reach helixd: ArduPilot handles it itself, forwards it
  nowhere and reports the new speed in no message.
* the autopilot's own mode (:class:`AutoWatch`, :func:`answer_auto`): the crew's ground
  station (QGroundControl's Start Mission: GUIDED, arm, MAV_CMD_MISSION_START to the
  autopilot, which switches to AUTO) leaves the autopilot armed in AUTO: a flight of the
  checked mission starts from the item the autopilot is on, driving in AUTO. The mode then
  is the crew's command (:mod:`helixd.runtime.mode_gate`). Like the switch, an autopilot
  found armed in AUTO when the service comes up (or when a flight ends) is not a start: it
  must be seen out of it first, or have acknowledged the HOLD a refused start asked.
* the autopilot's place (:class:`GotoWatch`, :func:`answer_goto`): armed in GUIDED (the
  crew's *Go to location*), RTL or SMART_RTL, the autopilot publishes where it drives to; a
  flight of one leg from where the rover is drives there and holds (neutral, overrides kept),
  and each new place is a new flight. Like AUTO, a place already published when the service
  comes up is not a start, nor is the one a flight just ended at (the crew gives a new one).

Each command gets one :class:`Answer`: ACCEPTED with an action, DENIED with why (also for a
sender that is not one of ``serve.gcs_system_ids``), TEMPORARILY_REJECTED while a flight is
starting or stopping.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum, StrEnum

from helixd.base.exitcodes import ExitCode
from helixd.link.vehicle import PositionTarget
from helixd.mav.constants import (
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_PAUSE_CONTINUE,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MAV_RESULT_TEMPORARILY_REJECTED,
    MAV_RESULT_UNSUPPORTED,
)
from helixd.mission.commands import SPEED_MIN_MPS, speed_refused
from helixd.runtime.mode_gate import AUTO_MODE, GOTO_MODES, same_place
from helixd.safety.watchdogs import HANDED_CAUSES, STOP_CAUSES, FaultCause

__all__ = [
    "GROUND_SPEED_TYPES",
    "Answer",
    "AutoWatch",
    "GotoWatch",
    "Request",
    "ServeState",
    "ServeView",
    "SwitchEdge",
    "SwitchWatch",
    "answer_auto",
    "answer_command",
    "answer_goto",
    "answer_speed",
    "answer_switch",
    "crew_paused",
    "radio_live",
    "state_after_flight",
]


class ServeState(IntEnum):
    """What the service is doing (NAMED_VALUE_INT ``hx_state`` carries the value)."""

    CONNECTING = 0  # no autopilot HEARTBEAT
    IDLE = 1  # connected; no mission checked yet (none stored, or reading it)
    READY = 2  # the autopilot's mission is checked: it will fly it on an operator's start
    REFUSED = 3  # the autopilot's mission was checked and refused (the GCS was told why)
    FLYING = 4
    PAUSED = 5  # an operator paused: a continue goes on from the interrupted leg
    FAULTED = 6  # a fault or a pilot takeover ended the flight (the fall-back ran)
    COMPLETED = 7  # the last flight completed the mission


class Request(StrEnum):
    """What an operator's command or switch asks the service to do."""

    START = "start"  # from item 1
    FROM_ITEM = "from_item"  # from the item :attr:`Answer.item` (MISSION_START param1 > 1)
    CONTINUE = "continue"  # from the first waypoint not reached (or item 1 if none)
    RELEASE = "release"  # flying, held at a NAV_LOITER_UNLIM: go on with the mission
    PAUSE = "pause"
    AUTO = "auto"  # the autopilot armed in AUTO: from its current item, driving in AUTO
    GOTO = "goto"  # the autopilot armed in GUIDED, RTL or SMART_RTL: to its place
    SPEED = "speed"  # the flight in progress cruises at Answer.speed_mps from now on
    HOLD = "hold"  # no flight, the autopilot armed where it drives itself: its start cancelled


@dataclass(frozen=True, slots=True)
class ServeView:
    """What the decisions look at."""

    state: ServeState
    busy: bool  # a flight is starting or stopping
    refusal: str  # why the mission was refused (REFUSED), or why nothing can start yet
    resumable: bool  # an interrupted flight of this mission can be continued
    switch_low: bool  # a start switch is configured and is low (the pilot's veto)
    last_item: int  # the mission's last item number (0: no mission)
    holding: bool = False  # flying, held at a NAV_LOITER_UNLIM until an operator continues
    flies_file: bool = False  # serve.mission_file: not the autopilot's mission (no AUTO start)
    # no flight, the autopilot armed in a mode where it drives by itself (AUTO, GUIDED): a start
    # the AUTO or place watch may take, a Pause cancels
    self_driving: bool = False


@dataclass(frozen=True, slots=True)
class Answer:
    result: int  # MAV_RESULT
    text: str  # what the GCS is told (empty: nothing to say)
    request: Request | None = None  # what to do (ACCEPTED only)
    speed_mps: float | None = None  # Request.SPEED: the speed asked (m/s)
    item: int = 0  # FROM_ITEM: the mission item to start from
    reason: str = ""  # PAUSE: why, in words (the flight's pause names it, and who asked)


def _finite_int(value: float) -> int | None:
    return int(value) if math.isfinite(value) and float(value).is_integer() else None


def _startable(view: ServeView) -> str | None:
    """Why nothing can start now (None: it can)."""
    if view.state is ServeState.CONNECTING:
        return "no autopilot"
    if view.state is ServeState.REFUSED:
        return f"mission refused: {view.refusal}"
    if view.state is ServeState.IDLE:
        return view.refusal or "no mission checked yet"
    if view.switch_low:
        return "the start switch is low (pause): flip it high to start"
    return None


def answer_command(
    view: ServeView,
    command: int,
    params: tuple[float, ...],
    sender_sysid: int,
    gcs_ids: frozenset[int],
) -> Answer:
    """The service's answer to one command addressed to it."""
    if command not in (MAV_CMD_MISSION_START, MAV_CMD_DO_PAUSE_CONTINUE, MAV_CMD_DO_CHANGE_SPEED):
        return Answer(MAV_RESULT_UNSUPPORTED, "")
    if sender_sysid not in gcs_ids:
        ids = ", ".join(str(i) for i in sorted(gcs_ids))
        return Answer(
            MAV_RESULT_DENIED,
            f"system {sender_sysid} is not a ground station of this rover "
            f"(serve.gcs_system_ids: {ids})",
        )
    if command == MAV_CMD_DO_CHANGE_SPEED:
        return answer_speed(view, params)
    if view.busy:
        return Answer(MAV_RESULT_TEMPORARILY_REJECTED, "busy: a flight is starting or stopping")
    p1 = _finite_int(params[0]) if params else None
    if command == MAV_CMD_DO_PAUSE_CONTINUE:
        if p1 == 0:
            if view.state is not ServeState.FLYING and view.self_driving:
                # the crew's Start Mission not yet taken (a reconnect, a mission read): the
                # crew's latest word is stop, so that start is cancelled (soak seed 4002)
                return Answer(MAV_RESULT_ACCEPTED, "paused: start cancelled, HOLD", Request.HOLD)
            if view.state is not ServeState.FLYING:
                return Answer(MAV_RESULT_DENIED, "pause: not flying")
            return _pause("pause from the ground station")  # words, not the command's name
        if p1 == 1:
            if view.state is ServeState.FLYING and view.holding:
                return Answer(MAV_RESULT_ACCEPTED, "continuing after the hold", Request.RELEASE)
            return _start(view, Request.CONTINUE)
        return Answer(MAV_RESULT_DENIED, "DO_PAUSE_CONTINUE param1 must be 0 (pause) or 1")
    p2 = _finite_int(params[1]) if len(params) > 1 else None
    if p1 is None or p1 < 0:
        return Answer(
            MAV_RESULT_DENIED,
            "MISSION_START param1 (first item) must be 0 (continue), 1 (from the start) or "
            "an item of the mission",
        )
    if p1 > 1 and view.last_item >= 1 and p1 > view.last_item:
        return Answer(
            MAV_RESULT_DENIED,
            f"MISSION_START param1 (first item) {p1} is not in the mission: 0 (continue) or "
            f"an item 1..{view.last_item}",
        )
    if p2 is None or p2 not in (0, -1, view.last_item):
        return Answer(
            MAV_RESULT_DENIED,
            f"MISSION_START param2 (last item) must be 0, -1 or {view.last_item}: helixd "
            "flies to the end of the mission",
        )
    if p1 > 1:
        return _start(view, Request.FROM_ITEM, p1)
    return _start(view, Request.START if p1 == 1 else Request.CONTINUE)


# DO_CHANGE_SPEED's param1 (SPEED_TYPE) Rover takes: airspeed (as ground speed) and ground
# speed; climb and descent speeds are DENIED (GCS_MAVLINK_Rover::handle_command_int_packet)
GROUND_SPEED_TYPES = (0, 1)


def answer_speed(view: ServeView, params: tuple[float, ...]) -> Answer:
    """``MAV_CMD_DO_CHANGE_SPEED`` addressed to helixd, judged as Rover judges one: a climb or
    descent speed type DENIED, a speed below 0.05 m/s (−1: "no change") FAILED. Accepted only
    while a flight is flying: its cruise speed from now on (the flight bounds it to its
    limits; a later DO_CHANGE_SPEED item of the mission sets it again; the next flight starts
    at the mission's speed, as ArduPilot's AUTO does)."""
    kind = _finite_int(params[0]) if params else None
    if kind not in GROUND_SPEED_TYPES:
        return Answer(
            MAV_RESULT_DENIED,
            "DO_CHANGE_SPEED param1 (speed type) must be 0 or 1: a rover has a ground speed",
        )
    asked = float(params[1]) if len(params) > 1 else math.nan
    if speed_refused(asked):
        return Answer(
            MAV_RESULT_FAILED, f"change speed {asked:g} m/s: no change (below {SPEED_MIN_MPS})"
        )
    if view.state is not ServeState.FLYING:
        return Answer(MAV_RESULT_DENIED, "change speed: not flying")
    return Answer(MAV_RESULT_ACCEPTED, "", Request.SPEED, speed_mps=asked)


def _pause(reason: str) -> Answer:
    return Answer(MAV_RESULT_ACCEPTED, f"pausing: {reason}", Request.PAUSE, reason=reason)


def _start(view: ServeView, request: Request, item: int = 0) -> Answer:
    if view.state is ServeState.FLYING:
        return Answer(MAV_RESULT_TEMPORARILY_REJECTED, "busy: flying")
    why = _startable(view)
    if why is not None:
        return Answer(MAV_RESULT_DENIED, f"cannot start: {why}")
    if request is Request.CONTINUE and not view.resumable:
        request = Request.START  # nothing interrupted: from the start
    if request is Request.FROM_ITEM:
        return Answer(MAV_RESULT_ACCEPTED, f"starting from item {item}", request, item=item)
    text = "continuing" if request is Request.CONTINUE else "starting from item 1"
    return Answer(MAV_RESULT_ACCEPTED, text, request)


class SwitchEdge(StrEnum):
    NONE = "none"
    RISING = "rising"  # low → high: start / continue
    FALLING = "falling"  # high → low: pause


@dataclass(slots=True)
class SwitchWatch:
    """The start switch's edges. ``None`` readings (no RC_CHANNELS yet, channel not sent)
    change nothing. A switch first seen high is not an edge: it must be seen low first."""

    threshold_us: int
    _seen_low: bool = False
    _high: bool | None = None

    def update(self, pwm_us: int | None) -> SwitchEdge:
        if pwm_us is None or pwm_us <= 0:
            return SwitchEdge.NONE
        high = pwm_us >= self.threshold_us
        was, self._high = self._high, high
        if not high:
            self._seen_low = True
            return SwitchEdge.FALLING if was else SwitchEdge.NONE
        if was is False and self._seen_low:
            return SwitchEdge.RISING
        return SwitchEdge.NONE

    @property
    def low(self) -> bool:
        """Low now (or never seen high, or the radio not live): the pilot's veto on starting."""
        return not self._high

    def lost(self) -> None:
        """The radio is not live (:func:`radio_live`): what the switch showed before says
        nothing of now, and a switch high when the radio is back is no start until seen low."""
        self._seen_low, self._high = False, None


def radio_live(
    receiver_healthy: bool | None, rc_rx_s: float | None, now_s: float, stale_s: float
) -> bool:
    """Whether the start switch is read from a live radio: ArduPilot's radio failsafe is off
    (SYS_STATUS's receiver bit; None: not reported) and RC_CHANNELS arrived within
    ``stale_s`` (``serve.switch_stale_s``)."""
    if receiver_healthy is False or rc_rx_s is None:
        return False
    return 0.0 <= now_s - rc_rx_s <= stale_s


def answer_switch(view: ServeView, edge: SwitchEdge) -> Answer | None:
    """What a switch edge asks (None: nothing). A rising edge that cannot start is answered
    DENIED (the text goes to the GCS); a falling edge pauses a flight."""
    if edge is SwitchEdge.FALLING:
        if view.state is ServeState.FLYING:
            return _pause("start switch low")
        return None
    if edge is SwitchEdge.RISING:
        if view.busy:
            return Answer(MAV_RESULT_TEMPORARILY_REJECTED, "busy: a flight is starting or stopping")
        return _start(view, Request.CONTINUE)
    return None


@dataclass(slots=True)
class AutoWatch:
    """The autopilot armed in AUTO, as a start: pending from the moment it is seen armed in
    AUTO after having been seen otherwise, until the service took it (:meth:`taken`). Blind
    while a flight runs (the flight follows the mode itself); when it ends, the watch is told
    whether the crew had left AUTO (:meth:`flight_ended`): after a release to a mode the
    pilot drives, AUTO again starts the next flight at once; after any other ending (the
    fall-back asks HOLD) the autopilot must first be seen out of AUTO, so a flight ending with
    the autopilot still in AUTO never starts the next by itself.

    A refused start whose HOLD the autopilot acknowledged (:meth:`left`) needs no sighting
    of that HOLD: the crew's next Start Mission may put the autopilot back in AUTO before
    any HEARTBEAT (1 Hz) or MISSION_CURRENT (a few a second) showed the HOLD, and the mode
    is read here once per tick. The mode held then is older than the acknowledgement and stands
    for nothing; the first one reported after it is news: AUTO is a start, any other mode
    is the HOLD seen."""

    _seen_out: bool = False
    _pending: bool = False
    _stale_until_s: float | None = None  # mode reports received until then are no news

    def update(self, armed: bool, mode: str, flying: bool, report_s: float | None) -> bool:
        """Whether a start from AUTO is pending now; ``report_s``: when the report that told
        ``mode`` was received (:func:`helixd.runtime.mode_gate.crew_mode_rx_s`)."""
        if flying:
            return False
        stale_until_s = self._stale_until_s
        if stale_until_s is not None:
            if report_s is None or report_s <= stale_until_s:
                return False
            self._stale_until_s = None
        if not (armed and mode == AUTO_MODE):
            self._seen_out, self._pending = True, False
        elif self._seen_out:
            self._seen_out, self._pending = False, True
        return self._pending

    def taken(self) -> None:
        self._pending = False

    def flight_ended(self, left_auto: bool) -> None:
        self._seen_out, self._pending, self._stale_until_s = left_auto, False, None

    def left(self, acked_s: float) -> None:
        """The autopilot acknowledged leaving AUTO (a refused start's HOLD) by ``acked_s``:
        out of AUTO, whatever the reports received until then still say."""
        self._seen_out, self._pending, self._stale_until_s = True, False, acked_s


def answer_auto(view: ServeView) -> Answer | None:
    """A pending start from AUTO: ACCEPTED (a flight from the autopilot's current item; a
    refused mission is read again first: the crew may have uploaded a fixed one), or DENIED
    with why (the GCS is told; the crew leaves AUTO and tries again); None while the
    mission is still being read (IDLE): the start waits for the verdict."""
    if view.busy or view.state is ServeState.FLYING:
        return None
    if view.state is ServeState.IDLE and not view.refusal.startswith("no mission"):
        return None
    if view.flies_file:
        return Answer(
            MAV_RESULT_DENIED,
            "AUTO: helixd flies serve.mission_file, not the autopilot's mission: start it "
            "with the start switch or MISSION_START to helixd",
        )
    if view.state is ServeState.REFUSED and not view.switch_low:
        # a plan of the same size uploaded since is not seen until read: the start reads
        # the mission again, and flies it if it passes (else HOLD and why)
        return Answer(MAV_RESULT_ACCEPTED, "AUTO: reading the mission again", Request.AUTO)
    why = _startable(view)
    if why is not None:
        return Answer(MAV_RESULT_DENIED, f"AUTO: helixd will not drive: {why}")
    return Answer(MAV_RESULT_ACCEPTED, "AUTO: driving the mission", Request.AUTO)


@dataclass(slots=True)
class GotoWatch:
    """The autopilot's place to go (GUIDED, RTL, SMART_RTL, armed) as a start: each place not
    flown yet is pending (:meth:`update` returns it) until the service took it
    (:meth:`taken`). Blind while a flight runs (the flight hands over to a new place itself).
    The place published when the watch first looks, and the last place taken, are not starts
    again until the autopilot is seen out of those modes (or disarmed): a flight ending in a
    fault with the autopilot still there never restarts itself."""

    same_within_m: float  # serve.same_place_m
    _primed: bool = False
    _blocked: PositionTarget | None = None

    def update(
        self, armed: bool, mode: str, target: PositionTarget | None, flying: bool
    ) -> PositionTarget | None:
        """The place pending now (None: none)."""
        there = armed and mode in GOTO_MODES
        if not self._primed:
            self._primed = True
            if there and target is not None:
                self._blocked = target
        if flying:
            return None
        if not there:
            self._blocked = None
            return None
        if target is None:
            return None
        blocked = self._blocked
        if blocked is not None and same_place(target, blocked, self.same_within_m):
            return None
        return target

    def taken(self, target: PositionTarget) -> None:
        self._blocked = target


def answer_goto(view: ServeView, mode: str, motion_mode_set: bool) -> Answer:
    """A pending place of the autopilot's ``mode``: ACCEPTED (a flight there), or DENIED with
    why (the GCS is told)."""
    if view.state is ServeState.CONNECTING:
        return Answer(MAV_RESULT_DENIED, f"{mode}: helixd will not drive: no autopilot")
    if not motion_mode_set:
        return Answer(
            MAV_RESULT_DENIED,
            f"{mode}: helixd will not drive: no motion mode: set mission.ground_station_mode "
            "in the config (or serve --mode)",
        )
    if view.switch_low:
        return Answer(
            MAV_RESULT_DENIED,
            f"{mode}: helixd will not drive: the start switch is low (pause)",
        )
    return Answer(MAV_RESULT_ACCEPTED, f"{mode}: driving to the autopilot's place", Request.GOTO)


def crew_paused(cause: FaultCause | None, paused: bool) -> bool:
    """Whether a flight ended on an operator's pause: its cause, or (``paused``: the pause
    asked of its stop request) a pause that came while it was still starting, before any
    cause; a fault that came first stays a fault."""
    return cause is FaultCause.PAUSED or (paused and cause is None)


def state_after_flight(code: ExitCode, cause: FaultCause | None, paused: bool) -> ServeState:
    """Where a flight leaves the service: completed; paused (the flight ended on an operator's
    pause, ``paused``, even one that came while it was still starting, or on the service's own
    stop: the crew's, no fault, and a continue goes on from there); or faulted (a fault, a
    pilot's takeover, a refusal at its start)."""
    if code is ExitCode.OK:
        return ServeState.COMPLETED
    if cause in STOP_CAUSES or cause in HANDED_CAUSES or crew_paused(cause, paused):
        return ServeState.PAUSED
    return ServeState.FAULTED
