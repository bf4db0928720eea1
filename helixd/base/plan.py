"""Plain plan and mode types: what the control core flies, free of the mission file format.

:mod:`helixd.mission` loads and validates mission files (pydantic, YAML) and resolves them into
a :class:`Plan`; the navigator only ever sees this module's types.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from helixd.base.angles import wrap_pi


class MotionMode(StrEnum):
    ROLL = "roll"  # hard ground: v_y = 0, drive along +x
    SCROLL = "scroll"  # water, mud, snow: v_x = 0, drive along +y
    OMNI = "omni"  # viscous media: ω_z = 0, heading held


class MissionFrameKind(StrEnum):
    START = "start"
    LOCAL_NED = "local_ned"
    GLOBAL = "global"


@dataclass(frozen=True, slots=True)
class PlanWaypoint:
    """One target in the mission frame (x/y metres, yaw CCW from +x)."""

    x_m: float
    y_m: float
    tolerance_m: float
    final_yaw_rad: float | None = None


@dataclass(frozen=True, slots=True)
class Plan:
    name: str
    mode: MotionMode
    frame: MissionFrameKind
    waypoints: tuple[PlanWaypoint, ...]
    speed_mps: float
    # Start of the first leg (mission frame, m). None: the rover's pose at the first step, as
    # for a fresh mission. A resumed mission sets the waypoint before its first one, so line
    # guidance re-enters the interrupted leg instead of cutting across to the waypoint.
    leg_start_xy_m: tuple[float, float] | None = None

    def path_length_m(self, start_xy_m: tuple[float, float] = (0.0, 0.0)) -> float:
        """Length of the polyline start → wp1 → … → wpN (m)."""
        total = 0.0
        px, py = start_xy_m
        for wp in self.waypoints:
            total += math.hypot(wp.x_m - px, wp.y_m - py)
            px, py = wp.x_m, wp.y_m
        return total

    def estimated_time_s(
        self, yaw_rate_radps: float, start_xy_m: tuple[float, float] = (0.0, 0.0)
    ) -> float:
        """Rough duration: path at cruise speed plus turns in place (roll/scroll) at yaw_rate."""
        travel = self.path_length_m(start_xy_m) / self.speed_mps
        if self.mode is MotionMode.OMNI or yaw_rate_radps <= 0:
            return travel
        turns = 0.0
        px, py = start_xy_m
        heading = 0.0 if self.mode is MotionMode.ROLL else math.pi / 2
        for wp in self.waypoints:
            leg = math.atan2(wp.y_m - py, wp.x_m - px)
            turns += abs(wrap_pi(leg - heading))
            heading = leg
            px, py = wp.x_m, wp.y_m
        return travel + turns / yaw_rate_radps


__all__ = ["MissionFrameKind", "MotionMode", "Plan", "PlanWaypoint"]
