"""Paths around what is in the way: maps, keep-out shapes, grid A*, line-of-sight legs."""

from helixd.planning.grid import GridFrame, PlanningGrid, build_grid, inflate, segment_is_free
from helixd.planning.mapfile import MapFileError, OccupancyMap, load_map
from helixd.planning.obstacles import (
    KeepOutCircle,
    ObstacleError,
    Obstacles,
    clearance_m,
    obstacles_from_config,
    with_geofence,
)
from helixd.planning.route import (
    Leg,
    PlanningError,
    RoutePlan,
    plan_mission,
    plan_route,
    planning_wanted,
)
from helixd.planning.search import grid_path, shortcut

__all__ = [
    "GridFrame",
    "KeepOutCircle",
    "Leg",
    "MapFileError",
    "ObstacleError",
    "Obstacles",
    "OccupancyMap",
    "PlanningError",
    "PlanningGrid",
    "RoutePlan",
    "build_grid",
    "clearance_m",
    "grid_path",
    "inflate",
    "load_map",
    "obstacles_from_config",
    "plan_mission",
    "plan_route",
    "planning_wanted",
    "segment_is_free",
    "shortcut",
    "with_geofence",
]
