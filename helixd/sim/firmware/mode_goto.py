"""Rover's GUIDED (a place from MAV_CMD_DO_REPOSITION), RTL and SmartRTL as the simulator
models them (pure: no sockets, no clocks).

From ArduPilot Rover:

* GUIDED is entered in its Stop submode, with no place to go (``ModeGuided::_enter``:
  ``start_stop``); ``MAV_CMD_DO_REPOSITION`` (COMMAND_INT;
  ``GCS_MAVLINK_Rover::handle_command_int_do_reposition``) gives it one: DENIED outside
  GUIDED without the MAV_DO_REPOSITION_FLAGS_CHANGE_MODE bit in param2, DENIED for a
  latitude/longitude off the Earth (``check_latlng``), for 0/0, and for a frame or altitude
  ``location_from_command_t`` cannot read; FAILED when the switch to GUIDED fails; else the
  place is set (``ModeGuided::set_desired_location``, the WP submode) and ACCEPTED. A
  COMMAND_LONG carries it as degrees (``command_long_stores_location``: converted to
  COMMAND_INT). A MISSION_ITEM(_INT) with ``current`` 2 outside an upload is the older way
  (``GCS_MAVLINK::handle_mission_item`` → ``handle_guided_request``): taken only in GUIDED
  (MISSION_ACK ACCEPTED, else ERROR); ``current`` 3 (an altitude change) is ACCEPTED and
  changes nothing on a rover (:func:`helixd.sim.firmware.mission_items.guided_request`);
* RTL's place is the nearest rally point, if it is closer than home, else home
  (``ModeRTL::_enter``, ``AP_Rally::calc_best_rally_or_home_location`` with Rover's defaults
  RALLY_LIMIT_KM 0.5 and RALLY_INCL_HOME 1: rally points all beyond the limit give home);
  RTL needs home (checked by the caller);
* a place is reached within WP_RADIUS or past the line through it square to the leg
  (``AR_WPNav::update``): RTL then says "Reached destination" once (``ModeRTL::update``; a
  rover stops there), GUIDED sends MISSION_ITEM_REACHED 0 (``ModeGuided::update``);
* both publish their place while they have one (``get_desired_location``: RTL always, GUIDED
  in its WP submode), which ``GCS_MAVLINK::send_position_target_global_int`` streams as
  POSITION_TARGET_GLOBAL_INT in the EXTENDED_STATUS group.

SmartRTL (``Rover/mode_smart_rtl.cpp``, ``AP_SmartRTL``): the path starts where the EKF
first has a position and again at each arming (``set_home``), and a point is saved whenever
the rover is SRTL_ACCURACY (2 m) from the last one, outside SmartRTL (``ModeSmartRTL::
save_position``, ``add_point``). Entering SmartRTL needs the path (``_enter``: else refused,
and a failsafe asking it falls back to RTL, then HOLD); it pops the newest point, publishes it,
pops the next once that one is reached, and with none left says "Reached destination" and
publishes nothing more (``StopAtHome``). Not modelled: the path's simplification and pruning
(the simulator returns by every saved point), the wait for that cleanup (the first point is
published at once), SRTL_POINTS and the 15 s timeouts.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from helixd.mav.constants import (
    GLOBAL_FRAMES,
    MAV_DO_REPOSITION_FLAGS_CHANGE_MODE,
    MAV_RESULT_DENIED,
    MAV_SEVERITY_INFO,
)
from helixd.sim.firmware.messages import mission_item_reached
from helixd.sim.firmware.mission_items import Outcome
from helixd.sim.firmware.mode_auto import passed_finish_line
from helixd.sim.firmware.rover_firmware import SimStatusText

SRTL_ACCURACY_M = 2.0  # SRTL_ACCURACY's default: points no closer than this
LOCATION_ALT_MAX_M = 83_000.0  # LOCATION_ALT_MAX_M (AP_Common/Location.h)
LAT_MAX_E7 = 90 * 10_000_000
LON_MAX_E7 = 180 * 10_000_000
RALLY_LIMIT_M = 500.0  # RALLY_LIMIT_KM's Rover default, 0.5 km
REACHED_TEXT = "Reached destination"  # ModeRTL::update, ModeSmartRTL::update

NE = tuple[float, float]


def reposition_refusal(
    in_guided: bool, param2: float, lat_e7: int, lon_e7: int, frame: int, alt_m: float
) -> int | None:
    """``handle_command_int_do_reposition``'s refusals before the mode change (DENIED), or
    None when the place is taken."""
    change_mode = math.isfinite(param2) and int(param2) & MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
    if not in_guided and not change_mode:
        return MAV_RESULT_DENIED
    if not (-LAT_MAX_E7 <= lat_e7 <= LAT_MAX_E7 and -LON_MAX_E7 <= lon_e7 <= LON_MAX_E7):
        return MAV_RESULT_DENIED
    if lat_e7 == 0 and lon_e7 == 0:
        return MAV_RESULT_DENIED
    if frame not in GLOBAL_FRAMES or not abs(alt_m) <= LOCATION_ALT_MAX_M:  # NaN: refused
        return MAV_RESULT_DENIED
    return None


@dataclass(frozen=True, slots=True)
class Place:
    """A place to drive to: north/east of the EKF origin, and as the autopilot's Location
    holds it (what POSITION_TARGET_GLOBAL_INT carries)."""

    ne: NE
    lat_e7: int
    lon_e7: int
    alt_amsl_m: float


def rtl_destination(here_ne: NE, home: Place, rally: Sequence[Place]) -> Place:
    """``calc_best_rally_or_home_location`` (RALLY_INCL_HOME 1): the nearest rally point when
    it is within RALLY_LIMIT_KM and closer than home, else home."""
    if not rally:
        return home
    nearest = min(rally, key=lambda p: math.dist(p.ne, here_ne))
    d = math.dist(nearest.ne, here_ne)
    if d > RALLY_LIMIT_M or d >= math.dist(home.ne, here_ne):
        return home
    return nearest


@dataclass(slots=True)
class SmartRtlPath:
    """AP_SmartRTL's saved path: the points back home, the newest last."""

    points: list[Place] = field(default_factory=list)
    active: bool = False

    def set_home(self, here: Place) -> None:
        """``set_home``: the path cleared, this point first."""
        self.points, self.active = [here], True

    def due(self, here_ne: NE) -> bool:
        """``add_point``: far enough from the last point to be saved."""
        if not self.active:
            return False
        return not self.points or math.dist(self.points[-1].ne, here_ne) >= SRTL_ACCURACY_M


@dataclass(slots=True)
class ModeGoto:
    """The place GUIDED, RTL or SmartRTL drives to, and whether it was reached."""

    place: Place | None = None  # None: GUIDED's Stop submode (nothing published)
    origin_ne: NE | None = None
    reached: bool = False
    rtl: bool = False  # RTL's place (says "Reached destination"), else GUIDED's
    path: list[Place] | None = None  # SmartRTL: the saved points left (popped from the end)

    def stop(self) -> None:
        """GUIDED entered (Stop submode), or the mode left."""
        self.place, self.origin_ne, self.reached, self.rtl = None, None, False, False
        self.path = None

    def follow(self, path: list[Place], here_ne: NE | None) -> Outcome:
        """SmartRTL entered: the newest saved point first (``pop_point``)."""
        self.stop()
        self.path = path
        return self._next(here_ne)

    def _next(self, here_ne: NE | None) -> Outcome:
        out = Outcome()
        path = self.path
        assert path is not None
        if path:
            self.go(path.pop(), here_ne, rtl=False)
            return out
        out.say(SimStatusText(MAV_SEVERITY_INFO, REACHED_TEXT))
        self.place, self.reached = None, True  # StopAtHome: nothing published
        return out

    def go(self, place: Place, here_ne: NE | None, rtl: bool) -> None:
        """A new place (AR_WPNav::set_desired_location: the leg starts at the previous
        destination while one is set, else where the rover is)."""
        self.origin_ne = self.place.ne if self.place is not None else here_ne
        self.place, self.reached, self.rtl = place, False, rtl

    def published(self) -> tuple[int, int, float] | None:
        """What POSITION_TARGET_GLOBAL_INT carries (lat_e7, lon_e7, alt_amsl_m), or None."""
        p = self.place
        return None if p is None else (p.lat_e7, p.lon_e7, p.alt_amsl_m)

    def update(self, here_ne: NE | None, wp_radius_m: float) -> Outcome:
        """One loop: the place reached (once) says so."""
        out = Outcome()
        place, origin = self.place, self.origin_ne
        if place is None or here_ne is None or self.reached:
            return out
        dest = place.ne
        near = math.dist(here_ne, dest) <= wp_radius_m
        if not (near or (origin is not None and passed_finish_line(origin, dest, here_ne))):
            return out
        self.reached = True
        if self.path is not None:
            return self._next(here_ne)
        if self.rtl:
            out.say(SimStatusText(MAV_SEVERITY_INFO, REACHED_TEXT))
        else:
            out.send((None, mission_item_reached(0)))
        return out


__all__ = [
    "REACHED_TEXT",
    "ModeGoto",
    "Place",
    "SmartRtlPath",
    "reposition_refusal",
    "rtl_destination",
]
