"""What the autopilot's mode lets a flight do, when the crew's command is the mode (pure).

``helixd serve`` flies a mission the crew started from the ground station in the autopilot's
AUTO (:mod:`helixd.serve.core`): QGroundControl's Start Mission, Pause and mode
buttons talk to the autopilot, and the mode they leave it in is what helixd obeys:

* AUTO (the flight's driving mode): helixd drives with its own guidance;
* a mode in which the pilot drives (MANUAL, ACRO, STEERING: ArduPilot Rover's modes with
  manual input): the flight ends and every override is released at once, no HOLD asked;
* GUIDED, RTL or SMART_RTL publishing a place to go: a handover (below);
* any other mode (HOLD — QGroundControl's Pause for a rover —, LOITER, GUIDED with no place,
  …): the scrolls are held at neutral by helixd's overrides (with the scroll outputs on RC
  passthrough, ArduPilot's own HOLD would pass the sticks through) until AUTO comes back, when
  the flight goes on from where it stopped.

The mode is the HEARTBEAT's (1 Hz on ArduPilot), made sooner by MISSION_CURRENT's
``mission_mode`` (1 only in AUTO, streamed at ``link.telemetry_rate_hz``): one newer than the
last HEARTBEAT that disagrees with it tells a change into or out of AUTO before the next
HEARTBEAT names the new mode (:func:`crew_mode`), as does a 0 after a 1 both newer than it
(AUTO entered and left within one HEARTBEAT period); a 0 is taken for "AUTO left" only from an
autopilot seen to fill the field (older ones send 0 in every mode).

The crew's *set current waypoint* (MISSION_SET_CURRENT / MAV_CMD_DO_SET_MISSION_CURRENT to
the autopilot) shows as MISSION_CURRENT moving anywhere but on to the next item
(:func:`item_set_by_crew`): the flight ends and the next one starts at that item. A mission
with commands moves the item by itself (a DO_JUMP goes back): there the autopilot's item is
followed along the flight's own walk (:func:`autopilot_step`), and only a move the walk does
not make is the crew's.

A flight to the autopilot's own place (:func:`goto_gate`) drives in GUIDED (the ground
station's *Go to location*: MAV_CMD_DO_REPOSITION), RTL or SMART_RTL (:data:`GOTO_MODES`):
helixd drives to the place the autopilot publishes in those modes (POSITION_TARGET_GLOBAL_INT,
:func:`current_target`: received since the HEARTBEAT that named the mode, and renewed within
``serve.target_stale_s``) and holds there. Another place, or AUTO, is a *handover*
(:attr:`Gate.HANDOVER`): the flight ends without HOLD and ``helixd serve`` starts the next. A
flight of AUTO hands over the same way to a mode of :data:`GOTO_MODES` with a place.

A flight that sets MANUAL itself (``helixd run``) has no gate: a mode change is a takeover.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

from helixd.base.frames import latlon_to_ne
from helixd.link.vehicle import PositionTarget, VehicleState

AUTO_MODE = "AUTO"
MANUAL_MODE = "MANUAL"  # set (and armed) by a flight itself
# Rover's modes whose place helixd drives to: GUIDED's WP submode, RTL, SmartRTL
GOTO_MODES = frozenset({"GUIDED", "RTL", "SMART_RTL"})
# ArduPilot Rover's Mode::has_manual_input(): the pilot's sticks drive
PILOT_MODES = frozenset({"MANUAL", "ACRO", "STEERING"})


LEFT_AUTO = "not AUTO"  # MISSION_CURRENT says AUTO was left; the next HEARTBEAT says for what


@dataclass(frozen=True, slots=True)
class PlaceRule:
    """How a flight that follows the autopilot's mode tells the autopilot's place: the bounds
    ``helixd serve`` hands in (``serve.target_stale_s``, ``serve.same_place_m``; the flight
    loop reads no serve section)."""

    stale_s: float  # a place not renewed for this long is no place (:func:`current_target`)
    same_m: float  # a place that moved less than this is the same place (:func:`same_place`)


@dataclass(frozen=True, slots=True)
class Driving:
    """The autopilot's mode a flight drives in, lent by its host
    (:attr:`helixd.runtime.host.FlightHost.driving`). MANUAL: set (and armed) by the flight
    itself, any other mode is a takeover. Any other: the flight follows the autopilot's mode
    (this module's gate) and needs ``places``, how it tells the autopilot's
    place; ``goto``: the autopilot's place (GUIDED, RTL, SMART_RTL) it drives to and holds
    at (None: a mission flight)."""

    mode: str = MANUAL_MODE
    goto: PositionTarget | None = None
    places: PlaceRule | None = None

    def __post_init__(self) -> None:
        if self.follows_mode and self.places is None:
            raise ValueError(f"a flight driving in {self.mode} needs its PlaceRule")

    @property
    def follows_mode(self) -> bool:
        return self.mode != MANUAL_MODE


DRIVE_MANUAL = Driving()  # helixd run's, and serve's flights on its own id or switch


class Gate(StrEnum):
    DRIVE = "drive"  # helixd drives
    HOLD = "hold"  # neutral, overrides kept (a pause: the flight goes on in the driving mode)
    RELEASE = "release"  # overrides released, the flight ends: the pilot drives
    # another place (or mode) helixd drives to: the flight ends without HOLD, the next starts
    HANDOVER = "handover"


def gate_of(mode: str, driving_mode: str, place_to_go: bool = False) -> Gate:
    """What the autopilot's ``mode`` lets a flight whose driving mode is ``driving_mode`` do;
    ``place_to_go``: a mode of :data:`GOTO_MODES` publishes a place (:func:`current_target`),
    which the next flight drives to."""
    if mode == driving_mode:
        return Gate.DRIVE
    if mode in PILOT_MODES:
        return Gate.RELEASE
    if mode in GOTO_MODES and place_to_go:
        return Gate.HANDOVER
    return Gate.HOLD


def goto_gate(
    mode: str, flown: PositionTarget, target: PositionTarget | None, same_within_m: float
) -> Gate:
    """What the autopilot's ``mode`` and its current place ``target`` let a flight to the place
    ``flown`` do: drive while a mode of :data:`GOTO_MODES` still publishes that place (within
    ``same_within_m``), hand over to another place or to AUTO, release to the pilot, and hold
    otherwise (HOLD, GUIDED with no place yet, a place not renewed)."""
    if mode in PILOT_MODES:
        return Gate.RELEASE
    if mode == AUTO_MODE:
        return Gate.HANDOVER
    if mode not in GOTO_MODES or target is None:
        return Gate.HOLD
    return Gate.DRIVE if same_place(flown, target, same_within_m) else Gate.HANDOVER


def same_place(a: PositionTarget, b: PositionTarget, within_m: float) -> bool:
    """Whether two published places are the same (closer than ``within_m``)."""
    north_m, east_m = latlon_to_ne(a.lat_deg, a.lon_deg, b.lat_deg, b.lon_deg)
    return math.hypot(north_m, east_m) <= within_m


def current_target(
    mode: str,
    target: PositionTarget | None,
    mode_since_s: float | None,
    now_s: float,
    stale_s: float,
) -> PositionTarget | None:
    """The place the autopilot's ``mode`` drives to now: the latest POSITION_TARGET_GLOBAL_INT
    in a mode of :data:`GOTO_MODES`, received after the HEARTBEAT that named the mode (an
    older one may be the previous mode's) and within ``stale_s`` (ArduPilot stops sending it
    when the mode has no place: GUIDED entered from the menu, SmartRTL at its end)."""
    if target is None or mode not in GOTO_MODES:
        return None
    if mode_since_s is not None and target.rx_monotonic_s <= mode_since_s:
        return None
    if now_s - target.rx_monotonic_s > stale_s:
        return None
    return target


def current_target_of(st: VehicleState, now_s: float, stale_s: float) -> PositionTarget | None:
    """:func:`current_target` from what the vehicle state holds."""
    return current_target(st.mode, st.position_target, st.mode_since_s, now_s, stale_s)


def _newer(rx_s: float | None, heartbeat_rx_s: float | None) -> bool:
    """A report received at ``rx_s`` after the last HEARTBEAT (or with none yet)."""
    return rx_s is not None and (heartbeat_rx_s is None or rx_s > heartbeat_rx_s)


def crew_mode(
    heartbeat_mode: str,
    heartbeat_rx_s: float | None,
    mission_mode: int | None,
    mission_current_rx_s: float | None,
    mission_mode_reported: bool,
    auto_rx_s: float | None = None,
) -> str:
    """The autopilot's mode as the freshest report tells it: the HEARTBEAT's, unless a later
    MISSION_CURRENT says AUTO was entered (``mission_mode`` 1) or left (0, from an autopilot
    seen to fill the field: :data:`LEFT_AUTO`) since. Left also when the HEARTBEAT names
    another mode but AUTO was entered after it (``auto_rx_s``: the last MISSION_CURRENT with
    1): GUIDED → AUTO → HOLD within one HEARTBEAT period is not GUIDED again."""
    if mission_mode is None or not _newer(mission_current_rx_s, heartbeat_rx_s):
        return heartbeat_mode
    if mission_mode == 1 and heartbeat_mode != AUTO_MODE:
        return AUTO_MODE  # only an autopilot that fills the field sends 1
    entered = heartbeat_mode == AUTO_MODE or _newer(auto_rx_s, heartbeat_rx_s)
    if mission_mode == 0 and entered and mission_mode_reported:
        return LEFT_AUTO
    return heartbeat_mode


def crew_mode_rx_s(st: VehicleState) -> float | None:
    """When the report :func:`crew_mode_of` rests on was received: a MISSION_CURRENT newer
    than the last HEARTBEAT that tells AUTO or not (1, or any from an autopilot that fills the
    field), else the HEARTBEAT. A mode told before a moment (a HOLD acknowledged) is not news
    of after it."""
    mc, heartbeat_rx_s = st.mission_current, st.last_heartbeat_s
    if mc is None or mc.mission_mode is None or not _newer(mc.rx_monotonic_s, heartbeat_rx_s):
        return heartbeat_rx_s
    if mc.mission_mode == 1 or st.mission_mode_reported:
        return mc.rx_monotonic_s
    return heartbeat_rx_s


def item_set_by_crew(previous_seq: int | None, seq: int) -> bool:
    """Whether the autopilot's current item (MISSION_CURRENT.seq) moved as only a crew's *set
    current waypoint* moves it: anywhere but on to the next item (ArduPilot's own progress,
    one item per verified waypoint). The next item set by hand cannot be told from progress;
    neither can 0 (no current item)."""
    return previous_seq is not None and seq not in (previous_seq, previous_seq + 1) and seq > 0


# how many steps of the walk the autopilot's item may move on between two MISSION_CURRENT
# messages: its own progress is one step per navigation item completed; two passes a short
# step (a DO_JUMP's target reached within WP_RADIUS) seen only after the next began
AUTOPILOT_STEPS_AHEAD = 2


def autopilot_step(walk_items: Sequence[int], at: int | None, seq: int) -> int | None:
    """Where the autopilot's AUTO is in a mission with commands, flown as the walk
    ``walk_items`` (each step's navigation item, in flight order, jumps expanded): the step
    (0-based) whose item is the autopilot's current item ``seq`` (MISSION_CURRENT), moving on
    from step ``at`` (None: none seen yet, the flight's first). ArduPilot's own progress keeps
    it on ``at`` or moves it up to :data:`AUTOPILOT_STEPS_AHEAD` steps on, back through a
    DO_JUMP as the walk does. None: the item moved as only a crew's *set current waypoint*
    moves it. Item 0 (none current) leaves it where it was (returned as ``at``, or step 0).
    The flight's first report of a do item before its first step's item is that step: a
    flight of AUTO started at the autopilot's current do item (the simulator's item 4, a
    DO_CHANGE_SPEED of a mission uploaded since its AUTO last ran) flies it with that step, and
    is not ended at once as set by the crew, the next started there again and again (a soak
    day of seed 10: 580 flights in a row)."""
    start = 0 if at is None else at
    if seq <= 0:
        return start
    if at is None and walk_items and seq < walk_items[0]:
        return 0
    end = min(start + AUTOPILOT_STEPS_AHEAD + 1, len(walk_items))
    return next((i for i in range(start, end) if walk_items[i] == seq), None)


def crew_mode_of(st: VehicleState) -> str:
    """:func:`crew_mode` from what the vehicle state holds."""
    mc = st.mission_current
    return crew_mode(
        st.mode,
        st.last_heartbeat_s,
        None if mc is None else mc.mission_mode,
        None if mc is None else mc.rx_monotonic_s,
        st.mission_mode_reported,
        st.mission_auto_rx_s,
    )


__all__ = [
    "AUTOPILOT_STEPS_AHEAD",
    "AUTO_MODE",
    "GOTO_MODES",
    "LEFT_AUTO",
    "PILOT_MODES",
    "Gate",
    "PlaceRule",
    "autopilot_step",
    "crew_mode",
    "crew_mode_of",
    "crew_mode_rx_s",
    "current_target",
    "current_target_of",
    "gate_of",
    "goto_gate",
    "item_set_by_crew",
    "same_place",
]
