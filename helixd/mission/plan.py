"""Resolve a mission file into a plan: waypoints in the mission frame, ready for the navigator.

Pure: no I/O. ``global`` missions need the EKF origin (GPS_GLOBAL_ORIGIN) to resolve.
:class:`Plan` and :class:`PlanWaypoint` live in :mod:`helixd.base.plan` (re-exported here).
"""

from __future__ import annotations

import math

from helixd.base.angles import wrap_pi
from helixd.base.frames import latlon_to_ne
from helixd.base.plan import MissionFrameKind, Plan, PlanWaypoint
from helixd.config import ControlConfig, MissionLimits
from helixd.mission.model import Mission


class PlanError(ValueError):
    """The mission cannot be resolved (e.g. a global point beyond the max range)."""


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
        out.append(PlanWaypoint(x_m=x, y_m=y, tolerance_m=tol, final_yaw_rad=yaw, via=wp.via))
    speed = min(mission.speed_mps or control.max_speed_mps, control.max_speed_mps)
    return Plan(
        name=mission.name,
        mode=mission.mode,
        frame=mission.frame,
        waypoints=tuple(out),
        speed_mps=speed,
    )


__all__ = ["Plan", "PlanError", "PlanWaypoint", "resolve_plan"]
