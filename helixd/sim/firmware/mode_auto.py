"""Rover's AUTO mode as the simulator models it (pure: no sockets, no clocks).

From ArduPilot Rover's ``ModeAuto`` and ``AR_WPNav``:

* entering AUTO needs a mission (more than home): else "No Mission. Can't set AUTO." and the
  mode change fails (``ModeAuto::_enter``); armed or not, AUTO is entered and the mission
  starts as soon as the EKF has an origin (``waiting_to_start`` → ``start_or_resume``, which
  with MIS_RESTART 0 resumes the current command, or starts from the first when there is
  none or the mission had completed);
* a NAV_WAYPOINT is reached when the EKF's position is within WP_RADIUS of it, or has passed
  the line through it square to the leg (``AR_WPNav::update``,
  ``Location::past_interval_finish_line``); the leg starts at the previous destination while
  the controller runs (``AR_WPNav::set_desired_location``), else (AUTO just entered) where the
  rover is. Then "Reached waypoint
  #N" (``ModeAuto::verify_nav_wp``), MISSION_ITEM_REACHED N to every link
  (``verify_command_callback``), and the next nav command starts ("Mission: M WP"); after the
  last one "Mission Complete" (``ModeAuto::exit_mission``) and, with MIS_DONE_BEHAVE 0
  (HOLD, the default), the *Stop submode of AUTO*: the mode stays AUTO, the mission reads
  COMPLETE;
* leaving AUTO stops a running mission (``ModeAuto::_exit``); AUTO again resumes it from its
  current command.

Not modelled: nav commands other than a global NAV_WAYPOINT (the mission waits at them), the
loiter time of a waypoint (param1), ArduPilot's own steering and throttle (the simulator's
outputs pass the RC inputs through in every mode, as a Helix's do).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from helixd.base.frames import latlon_to_ne
from helixd.mav.constants import (
    GLOBAL_FRAMES,
    MAV_CMD_NAV_WAYPOINT,
    MAV_SEVERITY_INFO,
    MAV_SEVERITY_NOTICE,
)
from helixd.sim.firmware.messages import mission_item_reached
from helixd.sim.firmware.mission_items import Outcome
from helixd.sim.firmware.mission_server import MissionServer
from helixd.sim.firmware.rover_firmware import SimStatusText

NO_MISSION_TEXT = "No Mission. Can't set AUTO."
MISSION_COMPLETE_TEXT = "Mission Complete"
LINE_MIN_SQ_M2 = 0.001  # Location::line_path_proportion: a shorter leg counts as passed


def passed_finish_line(
    origin_ne: tuple[float, float], dest_ne: tuple[float, float], here_ne: tuple[float, float]
) -> bool:
    """Location::past_interval_finish_line: ``here`` projects at or beyond ``dest`` on the
    leg from ``origin`` (a leg shorter than 3 cm counts as passed)."""
    vx, vy = dest_ne[0] - origin_ne[0], dest_ne[1] - origin_ne[1]
    d2 = vx * vx + vy * vy
    if d2 < LINE_MIN_SQ_M2:
        return True
    px, py = here_ne[0] - origin_ne[0], here_ne[1] - origin_ne[1]
    return (px * vx + py * vy) / d2 >= 1.0


@dataclass(slots=True)
class ModeAuto:
    """AUTO's state between loops: waiting to start, and the leg being driven."""

    waiting_to_start: bool = False
    leg_index: int | None = None  # the nav command whose leg is set
    leg_origin_ne: tuple[float, float] | None = None
    leg_dest_ne: tuple[float, float] | None = None

    def enter(self) -> None:
        """ModeAuto::_enter (the caller checked the mission is present)."""
        self.waiting_to_start = True
        self.leg_index = None
        self.leg_dest_ne = None  # AR_WPNav::init: the next leg starts where the rover is

    def update(
        self,
        mission: MissionServer,
        here_ne: tuple[float, float] | None,
        origin_latlon_deg: tuple[float, float] | None,
        wp_radius_m: float,
    ) -> Outcome:
        """One loop in AUTO: start the mission once there is an origin, then verify the
        current nav command against the EKF's position (None: no position, nothing done)."""
        out = Outcome()
        if origin_latlon_deg is None or here_ne is None:
            return out
        if self.waiting_to_start:
            self.waiting_to_start = False
            mission.start_or_resume(out)
        current = mission.nav_item()  # AP_Mission::update: one verify per loop
        if current is None:
            return out
        index, cmd = current
        if cmd.command != MAV_CMD_NAV_WAYPOINT or cmd.frame not in GLOBAL_FRAMES:
            return out  # not modelled: the mission waits here
        if index != self.leg_index:
            self.leg_index = index
            self.leg_origin_ne = self.leg_dest_ne or here_ne
            self.leg_dest_ne = latlon_to_ne(cmd.x / 1e7, cmd.y / 1e7, *origin_latlon_deg)
        dest = self.leg_dest_ne
        origin = self.leg_origin_ne
        assert dest is not None and origin is not None
        near = math.hypot(here_ne[0] - dest[0], here_ne[1] - dest[1]) <= wp_radius_m
        if not (near or passed_finish_line(origin, dest, here_ne)):
            return out
        out.say(SimStatusText(MAV_SEVERITY_INFO, f"Reached waypoint #{index}"))
        out.send((None, mission_item_reached(index)))
        if not mission.nav_done(out):
            out.say(SimStatusText(MAV_SEVERITY_NOTICE, MISSION_COMPLETE_TEXT))
        return out
