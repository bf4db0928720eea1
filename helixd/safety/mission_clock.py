"""The mission time limit's clock: driving time only (pure: no clock read, no I/O).

``safety.mission_time_limit_s`` bounds how long a flight drives, checked against the plan's
time estimate. Time the crew holds the rover does not count, because no estimate could hold
it: paused in the autopilot's HOLD (``helixd serve``: the mode gate's
:attr:`helixd.runtime.mode_gate.Gate.HOLD`), held at the autopilot's place after arriving
there (a flight to a place holds until the crew gives another place or mode), and held at a
NAV_LOITER_UNLIM until the operator continues. A NAV_LOITER_TIME, NAV_DELAY or a waypoint's
hold is part of the plan and of its estimate: it counts.

The flight loop feeds :class:`MissionClock` at every tick with both clocks (the wall clock
since the flight started; the autopilot clock since its first pose) and whether the flight is
paused now; the mission time is the later of the two clocks, each less its own time paused
(the plan's estimate is autopilot time, and an autopilot reboot restarts that clock).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["MissionClock", "MissionTime", "PausedTime"]


class PausedTime:
    """The time paused on one clock, fed ``(t_s, paused)`` at every tick.

    The time from one update to the next counts as paused when the flight was paused at the
    first of the two (what the loop knew then held until it looked again). A clock that ran
    backwards (an autopilot reboot) or a non-finite time adds nothing; the count goes on from
    the new time."""

    def __init__(self) -> None:
        self.paused_s = 0.0
        self._last_t_s: float | None = None
        self._last_paused = False

    def update(self, t_s: float, paused: bool) -> float:
        """Now ``t_s`` on this clock, paused from now on or not; the total paused (s)."""
        if not math.isfinite(t_s):
            return self.paused_s
        last = self._last_t_s
        if last is not None and self._last_paused and t_s > last:
            self.paused_s += t_s - last
        self._last_t_s = t_s
        self._last_paused = paused
        return self.paused_s


@dataclass(frozen=True, slots=True)
class MissionTime:
    """The time the limit is checked against and the time paused that it leaves out, on the
    same clock (s)."""

    driving_s: float
    paused_s: float


class MissionClock:
    """The mission time of one flight: the later of the wall and the autopilot clock, each
    counted without its time paused."""

    def __init__(self) -> None:
        self._wall = PausedTime()
        self._vehicle = PausedTime()

    def update(self, wall_s: float, vehicle_s: float | None, paused: bool) -> MissionTime:
        """``wall_s``: the wall clock since the flight started; ``vehicle_s``: the autopilot
        clock since the flight's first pose (None: no pose yet); ``paused``: the flight holds
        for the crew from now on (HOLD, at its place, at a NAV_LOITER_UNLIM)."""
        wall_paused_s = self._wall.update(wall_s, paused)
        wall = MissionTime(wall_s - wall_paused_s, wall_paused_s)
        if vehicle_s is None:
            return wall
        vehicle_paused_s = self._vehicle.update(vehicle_s, paused)
        vehicle = MissionTime(vehicle_s - vehicle_paused_s, vehicle_paused_s)
        return vehicle if vehicle.driving_s > wall.driving_s else wall
