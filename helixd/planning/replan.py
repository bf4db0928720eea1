"""Re-plan the first leg from where the rover really is at preflight.

``check`` and the planner start the first leg at ``planning.start_ne_m`` (default the EKF
origin). At ``run`` the rover's pose is known at preflight; if it is farther than the via
tolerance from that start, the first leg (start → waypoint 0, with its intermediate points) is
planned again from the rover's pose on the same inflated grid, so the rover never drives a
straight line through an obstacle that the planned leg went around. Refused (PlanningError,
naming the pose) when the pose is off the grid, inside an inflated obstacle, or cut off from
waypoint 0. Pure: numbers in, a mission out.
"""

from __future__ import annotations

import math
from dataclasses import replace

from helixd.config.root import HelixdConfig
from helixd.mission.model import Mission
from helixd.planning.obstacles import PointNE
from helixd.planning.route import (
    PlanningError,
    RoutePlan,
    plan_leg,
    via_tolerance_m,
    via_waypoints,
    with_vias,
)

_FIX = "move the rover, or set planning.start_ne_m to where it starts and check again"


def replan_first_leg(
    planned: Mission,
    route: RoutePlan,
    original: Mission,
    rover_ne_m: PointNE,
    cfg: HelixdConfig,
) -> tuple[Mission, RoutePlan]:
    """``planned`` (from :func:`helixd.planning.plan_mission` or
    :func:`helixd.planning.fence.plan_global_mission` of ``original``) with its first leg
    re-planned from ``rover_ne_m`` (in the route's frame: the EKF origin's, or around
    ``route.origin_latlon_deg`` for a global mission); unchanged when the rover is within
    ``planning.via_tolerance_m`` of the planned start. Raises :class:`PlanningError`."""
    n, e = float(rover_ne_m[0]), float(rover_ne_m[1])
    where = f"rover at preflight (north {n:.2f} m, east {e:.2f} m)"
    if not (math.isfinite(n) and math.isfinite(e)):
        raise PlanningError([f"{where}: pose is not finite; cannot plan the first leg"])
    if not route.legs or not original.waypoints:
        return planned, route
    first = route.legs[0]
    start = first.points_ne_m[0]
    if math.dist((n, e), start) <= cfg.planning.via_tolerance_m:
        return planned, route
    grid = route.grid
    cell = grid.frame.cell_of((n, e))
    if not grid.frame.inside(cell):
        raise PlanningError([f"{where} lies outside the planning grid; {_FIX}"])
    if grid.inflated[cell]:
        what = "an obstacle" if grid.blocked[cell] else "the clearance of an obstacle"
        raise PlanningError([f"{where} lies inside {what}; {_FIX}"])
    leg = plan_leg(grid, (n, e), first.points_ne_m[-1], -1)
    if isinstance(leg, str):
        raise PlanningError([f"{where}: {leg}; {_FIX}"])
    new_route = replace(route, legs=(leg, *route.legs[1:]))
    vias = [
        via_waypoints(lg, via_tolerance_m(original, wp, cfg), route.origin_latlon_deg)
        for lg, wp in zip(new_route.legs, original.places(), strict=True)
    ]
    return with_vias(original, vias), new_route
