"""Plan every leg of a mission around what is in the way and insert the intermediate waypoints.

Pure apart from reading nothing: the caller passes the obstacles and the optional map. Used by
``helixd check --map`` (prints the legs, refuses) and ``helixd run --map`` (flies the result):
the planned waypoints are added to the mission itself, so the daemon resolves and flies them
like any other waypoints.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy.typing as npt
import yaml

from helixd.base.frames import ne_to_latlon
from helixd.base.plan import MissionFrameKind
from helixd.base.problems import Problems
from helixd.config.root import HelixdConfig
from helixd.mav.constants import MAV_CMD_DO_JUMP
from helixd.mission.commands import stored_whole
from helixd.mission.model import Mission, WaypointSpec, entry_yaml
from helixd.planning.grid import GridFrame, PlanningGrid, build_grid, segment_is_free
from helixd.planning.mapfile import OccupancyMap
from helixd.planning.obstacles import (
    Obstacles,
    PointNE,
    clearance_m,
    obstacles_from_config,
    with_geofence,
)
from helixd.planning.search import grid_path, shortcut, turning_cells


class PlanningError(Problems, ValueError):
    """The mission cannot be planned; ``problems`` holds one line each."""


@dataclass(frozen=True)
class Leg:
    """One leg between mission waypoints (index -1 is the planning start point)."""

    from_index: int
    to_index: int
    points_ne_m: tuple[PointNE, ...]  # from-point, intermediate points…, to-point

    @property
    def length_m(self) -> float:
        pts = self.points_ne_m
        return sum(math.dist(a, b) for a, b in itertools.pairwise(pts))

    @property
    def straight(self) -> bool:
        return len(self.points_ne_m) == 2


@dataclass(frozen=True)
class RoutePlan:
    grid: PlanningGrid
    legs: tuple[Leg, ...]
    seconds: float = 0.0
    notes: tuple[str, ...] = field(default=())
    # a global mission's route: north/east around this (lat, lon) (its waypoint 0), not the
    # EKF origin; its intermediate waypoints are written back as lat/lon
    origin_latlon_deg: tuple[float, float] | None = None

    def polyline_ne_m(self) -> list[PointNE]:
        out: list[PointNE] = [self.legs[0].points_ne_m[0]] if self.legs else []
        for leg in self.legs:
            out.extend(leg.points_ne_m[1:])
        return out


def grid_frame_for(
    points: list[PointNE], obstacles: Obstacles, resolution_m: float, pad_m: float
) -> GridFrame:
    """A grid covering the points and every shape, ``pad_m`` beyond, aligned to the resolution."""
    ns = [p[0] for p in points]
    es = [p[1] for p in points]
    for poly in (*obstacles.polygons_ne_m, obstacles.inclusion_ne_m):
        ns.extend(v[0] for v in poly)
        es.extend(v[1] for v in poly)
    for c in obstacles.circles:
        ns.extend((c.north_m - c.radius_m, c.north_m + c.radius_m))
        es.extend((c.east_m - c.radius_m, c.east_m + c.radius_m))
    h = resolution_m
    n0 = math.floor((min(ns) - pad_m) / h) * h
    e0 = math.floor((min(es) - pad_m) / h) * h
    rows = math.ceil((max(ns) + pad_m - n0) / h) + 1
    cols = math.ceil((max(es) + pad_m - e0) / h) + 1
    return GridFrame(origin_north_m=n0, origin_east_m=e0, resolution_m=h, rows=rows, cols=cols)


def _name(index: int) -> str:
    return "start" if index < 0 else f"waypoint {index + 1}"  # numbered from 1, as a GCS does


def plan_leg(
    grid: PlanningGrid, a: PointNE, b: PointNE, from_index: int, search_weight: float = 1.0
) -> Leg | str:
    """One leg ``a`` → ``b`` (both free cells of ``grid``), or the problem line naming it."""
    frame = grid.frame
    ia, ib = from_index, from_index + 1
    if segment_is_free(grid, a, b):
        return Leg(ia, ib, (a, b))
    cells = grid_path(grid.free, frame.cell_of(a), frame.cell_of(b), search_weight)
    if cells is None:
        return (
            f"leg {_name(ia)} → {_name(ib)}: unreachable, no path keeps "
            f"{grid.clearance_m:.2f} m clearance"
        )
    # a → its own cell's centre → turning cells' centres → b's cell centre → b: every
    # segment stays inside cells the search walked, so the polyline is free before any
    # shortcut (the shortcut only ever replaces a stretch by a segment checked free)
    pts = [a, *(frame.centre_of(c) for c in turning_cells(cells)), b]
    return Leg(ia, ib, tuple(shortcut(grid, pts)))


def plan_route(
    points_ne_m: list[PointNE],
    obstacles: Obstacles,
    clearance: float,
    *,
    occupancy: OccupancyMap | None = None,
    resolution_m: float = 0.1,
    pad_m: float = 20.0,
    max_cells: int = 16_000_000,
    first_index: int = -1,
    search_weight: float = 1.0,
) -> RoutePlan:
    """Plan start → p1 → … ; ``points_ne_m[0]`` is numbered ``first_index`` (-1 = the start).

    Refuses (PlanningError, every problem at once) a point outside the grid or inside an
    inflated obstacle, and a leg with no path; each problem names the leg and waypoint.
    """
    t0 = time.perf_counter()
    if occupancy is not None:
        frame = occupancy.frame
        base: npt.NDArray[Any] | None = occupancy.blocked
    else:
        frame = grid_frame_for(points_ne_m, obstacles, resolution_m, pad_m)
        base = None
    if frame.rows * frame.cols > max_cells:
        raise PlanningError(
            [
                f"planning grid {frame.rows} × {frame.cols} cells exceeds planning.max_cells = "
                f"{max_cells} (raise planning.resolution_m or shrink the area)"
            ]
        )
    grid = build_grid(frame, obstacles, clearance, base)
    problems: list[str] = []
    bad: set[int] = set()
    where = "map" if occupancy is not None else "planning grid"
    for k, p in enumerate(points_ne_m):
        idx = first_index + k
        cell = frame.cell_of(p)
        if not frame.inside(cell):
            problems.append(
                f"{_name(idx)} (north {p[0]:.2f} m, east {p[1]:.2f} m) lies outside the {where}"
            )
            bad.add(k)
        elif grid.inflated[cell]:
            what = (
                "an obstacle"
                if grid.blocked[cell]
                else f"the {clearance:.2f} m clearance of an obstacle"
            )
            problems.append(
                f"{_name(idx)} (north {p[0]:.2f} m, east {p[1]:.2f} m) lies inside {what} "
                "(inflated by rover half-width + planning.margin_m)"
            )
            bad.add(k)
    legs: list[Leg] = []
    for k in range(len(points_ne_m) - 1):
        if k in bad or k + 1 in bad:
            continue
        leg = plan_leg(grid, points_ne_m[k], points_ne_m[k + 1], first_index + k, search_weight)
        if isinstance(leg, str):
            problems.append(leg)
        else:
            legs.append(leg)
    if problems:
        raise PlanningError(problems)
    return RoutePlan(grid=grid, legs=tuple(legs), seconds=time.perf_counter() - t0)


def planning_wanted(cfg: HelixdConfig, occupancy: OccupancyMap | None) -> bool:
    """Plan when enabled and there is something in the way (a map, a keep-out shape)."""
    pl = cfg.planning
    return pl.enabled and (
        occupancy is not None or bool(pl.keep_out_polygons_ne_m) or bool(pl.keep_out_circles)
    )


def plan_mission(
    mission: Mission,
    cfg: HelixdConfig,
    occupancy: OccupancyMap | None = None,
    obstacles: Obstacles | None = None,
) -> tuple[Mission, RoutePlan]:
    """The mission with the planned intermediate waypoints inserted, and the route.

    Only ``local_ned`` missions: obstacles are fixed to the EKF origin, and a ``start`` frame
    moves with the start pose while a ``global`` one needs the EKF origin, which neither
    ``check`` nor the plan resolver has. The first leg is planned from
    ``planning.start_ne_m``. Raises :class:`PlanningError`.
    """
    if mission.frame is not MissionFrameKind.LOCAL_NED:
        raise PlanningError(
            [
                f"planning around obstacles needs a local_ned mission (north/east from the EKF "
                f"origin, like the map and keep-out shapes); this one is '{mission.frame.value}'"
            ]
        )
    pl = cfg.planning
    obs = obstacles if obstacles is not None else obstacles_from_config(cfg)
    if mission.keep_out_polygons:  # the mission's own keep-out areas (a survey's islands)
        obs = with_geofence(obs, exclusion_polygons_ne_m=mission.keep_outs_ne())
    pts: list[PointNE] = [pl.start_ne_m, *mission.points()]
    route = plan_route(
        pts,
        obs,
        clearance_m(cfg),
        occupancy=occupancy,
        resolution_m=pl.resolution_m,
        pad_m=pl.pad_m,
        max_cells=pl.max_cells,
    )
    vias = [
        via_waypoints(leg, via_tolerance_m(mission, wp, cfg))
        for leg, wp in zip(route.legs, mission.places(), strict=True)
    ]
    return with_vias(mission, vias), route


def with_vias(mission: Mission, vias_before: list[list[WaypointSpec]]) -> Mission:
    """The mission with ``vias_before[k]`` inserted before its k-th place
    (:meth:`Mission.places`). In a mission with commands, DO_JUMP targets are renumbered so
    they still name the same item (a jump lands on the place itself; the leg a jump or a
    return flies is not planned around obstacles)."""
    places = {id(wp): k for k, wp in enumerate(mission.places())}
    out: list[WaypointSpec] = []
    shift: dict[int, int] = {}  # old item number → new
    for n, wp in enumerate(mission.waypoints, start=1):
        k = places.get(id(wp))
        if k is not None:
            out.extend(vias_before[k])
        out.append(wp)
        shift[n] = len(out)
    if len(out) == len(mission.waypoints):
        return mission
    renumbered: list[WaypointSpec] = []
    for wp in out:
        if wp.command == MAV_CMD_DO_JUMP and wp.params is not None:
            target = stored_whole(wp.param(0))
            if target in shift:
                params = (float(shift[target]), *wp.params[1:])
                wp = wp.model_copy(update={"params": params})
        renumbered.append(wp)
    return mission.model_copy(update={"waypoints": tuple(renumbered)})


def via_tolerance_m(mission: Mission, wp: WaypointSpec, cfg: HelixdConfig) -> float:
    """Tolerance of the intermediate waypoints before ``wp``: never looser than ``wp``'s own."""
    default_tol = mission.tolerance_m or cfg.control.waypoint_tolerance_m
    return min(cfg.planning.via_tolerance_m, wp.tolerance_m or default_tol)


def via_waypoints(
    leg: Leg, tolerance_m: float, origin_latlon_deg: tuple[float, float] | None = None
) -> list[WaypointSpec]:
    """The leg's intermediate points as waypoints (its end points excluded): north/east, or
    lat/lon when the route is around ``origin_latlon_deg`` (a global mission)."""
    if origin_latlon_deg is None:
        return [
            WaypointSpec(north=n, east=e, tolerance_m=tolerance_m, via=True)
            for n, e in leg.points_ne_m[1:-1]
        ]
    out = []
    for n, e in leg.points_ne_m[1:-1]:
        lat, lon = ne_to_latlon(n, e, *origin_latlon_deg)
        out.append(WaypointSpec(lat=lat, lon=lon, tolerance_m=tolerance_m, via=True))
    return out


def planned_mission_yaml(mission: Mission, route: RoutePlan, map_path: object = None) -> str:
    """The planned mission as a mission file (what ``run`` records as mission.yaml)."""
    head = (
        f"# Planned by helixd.planning: {sum(len(leg.points_ne_m) - 2 for leg in route.legs)} "
        f"intermediate waypoints, clearance {route.grid.clearance_m:.2f} m"
        + (f", map {map_path}" if map_path is not None else "")
        + "\n"
    )
    doc = mission.model_dump(mode="json", exclude_none=True)
    doc["waypoints"] = [entry_yaml(wp) for wp in mission.waypoints]
    return head + yaml.safe_dump(doc, sort_keys=False)
