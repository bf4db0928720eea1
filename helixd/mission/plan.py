"""Resolve a mission file into a plan: waypoints in the mission frame, ready for the navigator.

Pure: no I/O. ``global`` missions need the EKF origin (GPS_GLOBAL_ORIGIN) to resolve.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from helixd.config import ControlConfig, MissionLimits
from helixd.control.angles import wrap_pi
from helixd.frames import latlon_to_ne
from helixd.mission.model import Mission, MissionFrameKind, MotionMode


class PlanError(ValueError):
    """The mission cannot be resolved (e.g. a global point beyond the max range)."""


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


def resolve_plan(
    mission: Mission,
    control: ControlConfig,
    limits: MissionLimits,
    origin_latlon_deg: tuple[float, float] | None = None,
) -> Plan:
    """Convert the file's waypoints into the mission frame used by the control core.

    start frame: (x, y) as written.  local_ned/global: x = East, y = North (ENU), compass
    headings converted to CCW-from-East.
    """
    default_tol = mission.tolerance_m or control.waypoint_tolerance_m
    out: list[PlanWaypoint] = []
    for i, (wp, (a, b)) in enumerate(zip(mission.waypoints, mission.points(), strict=True)):
        tol = wp.tolerance_m or default_tol
        if mission.frame is MissionFrameKind.START:
            x, y = a, b
            yaw = None if wp.heading_deg is None else wrap_pi(math.radians(wp.heading_deg))
        else:
            if mission.frame is MissionFrameKind.GLOBAL:
                if origin_latlon_deg is None:
                    raise PlanError("a global mission needs the EKF origin (GPS_GLOBAL_ORIGIN)")
                north, east = latlon_to_ne(a, b, *origin_latlon_deg)
            else:
                north, east = a, b
            x, y = east, north
            yaw = (
                None
                if wp.heading_deg is None
                else wrap_pi(math.pi / 2 - math.radians(wp.heading_deg))
            )
        rng = math.hypot(x, y)
        if rng > limits.max_range_m:
            raise PlanError(
                f"waypoints.{i}: {rng:.1f} m from the origin; allowed at most "
                f"mission.max_range_m = {limits.max_range_m} m"
            )
        out.append(PlanWaypoint(x_m=x, y_m=y, tolerance_m=tol, final_yaw_rad=yaw))
    speed = min(mission.speed_mps or control.max_speed_mps, control.max_speed_mps)
    return Plan(
        name=mission.name,
        mode=mission.mode,
        frame=mission.frame,
        waypoints=tuple(out),
        speed_mps=speed,
    )
