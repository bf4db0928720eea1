"""The flight a run makes of a checked mission: planned around the map, the config's keep-out
shapes and a .plan's exclusion zones (helixd.planning) when there are any, with the re-planner
the daemon calls at preflight for the first leg from the rover's real pose.

No printing and no exits: refusals are :class:`helixd.prepare.inputs.InputsRefused`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import structlog

from helixd.base.frames import latlon_to_ne, ne_to_latlon
from helixd.base.plan import MissionFrameKind
from helixd.config.root import HelixdConfig
from helixd.control.estimate import TimeEstimate
from helixd.mission.expand import DEFAULT_OPTIONS, ExpandOptions
from helixd.mission.formats import fence_has_keep_outs
from helixd.mission.formats.items import GcsMission, fence_ne, keep_out_problems
from helixd.mission.judge import limit_problems, plan_time_estimate
from helixd.mission.model import Mission
from helixd.mission.resolve import PlanError
from helixd.mission.resume import RunInputs, fresh_inputs
from helixd.mission.validate import plan_for_check
from helixd.planning.fence import plan_global_mission
from helixd.planning.mapfile import MapFileError, OccupancyMap, load_map
from helixd.planning.obstacles import KeepOutCircle, ObstacleError
from helixd.planning.replan import replan_first_leg
from helixd.planning.route import (
    PlanningError,
    RoutePlan,
    plan_mission,
    planned_mission_yaml,
    planning_wanted,
)
from helixd.prepare.inputs import InputsRefused

Replanner = Callable[[tuple[float, float], tuple[float, float] | None], Mission]


def load_occupancy(cfg: HelixdConfig, map_path: Path | None) -> OccupancyMap | None:
    """The ``--map`` (helixd.planning.mapfile), or None; an unusable map is refused (exit 2)."""
    if map_path is None:
        return None
    try:
        return load_map(map_path, cfg.planning.max_cells)
    except MapFileError as exc:
        raise InputsRefused([str(exc)]) from None


def plan_loaded(
    cfg: HelixdConfig,
    msn: Mission,
    path: Path,
    occupancy: OccupancyMap | None,
    fence: GcsMission | None = None,
) -> tuple[Mission, RoutePlan | None]:
    """The mission with the intermediate waypoints inserted, and the route (None: nothing to
    plan around); ``fence``: the lat/lon fence (a .plan's geofence, --fence, the autopilot's)
    whose exclusion zones a global mission is planned around; refusals exit 2."""
    try:
        if msn.frame is MissionFrameKind.GLOBAL and cfg.planning.enabled:
            planned, route = plan_global(cfg, msn, fence, occupancy)
            if route is not None and planned.has_commands() and fence is not None:
                unplanned = unplanned_leg_problems(planned, cfg, fence)
                if unplanned:
                    raise InputsRefused([f"{path}: {p}" for p in unplanned])
        elif not (
            planning_wanted(cfg, occupancy) or (cfg.planning.enabled and msn.keep_out_polygons)
        ):
            return msn, None
        else:
            planned, route = plan_mission(msn, cfg, occupancy)
    except PlanningError as exc:
        raise InputsRefused([f"{path}: {p}" for p in exc.problems]) from None
    except (MapFileError, ObstacleError) as exc:
        raise InputsRefused([str(exc)]) from None
    if route is not None:  # the detours take time: the planned route must fit the limit
        estimate, note = route_time_estimate(cfg, planned, route, path)
        plan, _ = plan_for_check(planned, cfg)
        late = limit_problems(plan, estimate, cfg.safety.mission_time_limit_s, note)
        if late:
            raise InputsRefused([f"{path}: planned route: {p}" for p in late])
    return planned, route


def route_time_estimate(
    cfg: HelixdConfig, planned: Mission, route: RoutePlan | None, path: Path
) -> tuple[TimeEstimate, str]:
    """The estimate of the mission as flown (the planned route, via points included) and
    where it is counted from: a ``local_ned`` route from ``planning.start_ne_m``, where its
    first leg was planned from; ``start`` missions from the start point; else the first
    waypoint."""
    try:
        plan, _ = plan_for_check(planned, cfg)
    except PlanError as exc:
        raise InputsRefused([f"{path}: {exc}"]) from None
    if planned.frame is MissionFrameKind.LOCAL_NED and route is not None:
        north, east = cfg.planning.start_ne_m
        return plan_time_estimate(plan, cfg, start_xy_m=(east, north)), (
            " from planning.start_ne_m"
        )
    note = "" if planned.frame is MissionFrameKind.START else " from waypoint 1"
    return plan_time_estimate(plan, cfg), note


def unplanned_leg_problems(planned: Mission, cfg: HelixdConfig, fence: GcsMission) -> list[str]:
    """The legs of a mission with commands that planning does not route (a return home, the
    leg after a jump) checked against the fence's exclusion zones, with home where the
    mission's file put it: such a leg through a zone is refused (planning routes only the legs
    from one place to the next in the list)."""
    plan, _ = plan_for_check(planned, cfg)
    origin = planned.points()[0]
    pts = [ne_to_latlon(w.y_m, w.x_m, *origin) for w in plan.waypoints]
    labels = [f"plan waypoint {i}" for i in range(len(pts))]
    program = plan.program
    if program is not None:
        for step in program.steps:
            if step.first_waypoint is not None and step.last_waypoint is not None:
                for i in range(step.first_waypoint, step.last_waypoint + 1):
                    labels[i] = f"item {step.item} ({step.text.split(' (')[0][:40]})"
    why = "(a return or the leg after a jump is not planned around obstacles: add waypoints)"
    return [
        p.replace("(helixd flies straight legs)", why)
        for p in keep_out_problems(fence, pts, labels, legs=True)
    ]


def plan_global(
    cfg: HelixdConfig, msn: Mission, fence: GcsMission | None, occupancy: OccupancyMap | None
) -> tuple[Mission, RoutePlan | None]:
    """A global mission: planned around its .plan's exclusion zones and its own keep-out
    areas when it has any (in a frame around its first waypoint, helixd.planning.fence); with
    only a --map or config keep-outs, refused (they hang from the unknown EKF origin); else
    flown as it is."""
    own = fence_has_keep_outs(fence)
    if not (own or msn.keep_out_polygons or planning_wanted(cfg, occupancy)):
        return msn, None
    origin = msn.points()[0]
    polys: list[tuple[tuple[float, float], ...]] = msn.keep_outs_ne(origin)
    circles: list[KeepOutCircle] = []
    if own and fence is not None:
        shapes = fence_ne(fence, origin)
        polys.extend(shapes.exclusion_polygons)
        circles = [
            KeepOutCircle(c.centre_ne_m[0], c.centre_ne_m[1], c.radius_m)
            for c in shapes.exclusion_circles
        ]
    return plan_global_mission(msn, cfg, polys, circles, origin, occupancy)


def first_leg_replanner(
    cfg: HelixdConfig, original: Mission, planned: Mission, route: RoutePlan
) -> Replanner:
    """What the daemon calls at preflight with the rover's (north_m, east_m) and the EKF
    origin: the planned mission with its first leg re-planned from there
    (helixd.planning.replan); raises PlanningError (a ValueError) naming the pose when it
    cannot."""

    def replan_from(
        rover_ne_m: tuple[float, float], ekf_origin_latlon_deg: tuple[float, float] | None
    ) -> Mission:
        here = rover_ne_m
        if route.origin_latlon_deg is not None:  # a global mission's route: around waypoint 0
            if ekf_origin_latlon_deg is None:
                raise PlanningError(["a global mission's first leg needs the EKF origin"])
            latlon = ne_to_latlon(*rover_ne_m, *ekf_origin_latlon_deg)
            here = latlon_to_ne(*latlon, *route.origin_latlon_deg)
        again, again_route = replan_first_leg(planned, route, original, here, cfg)
        if again is not planned:
            leg = again_route.legs[0]
            structlog.get_logger("helixd.planning").info(
                "first_leg_replanned",
                rover_north_m=round(rover_ne_m[0], 2),
                rover_east_m=round(rover_ne_m[1], 2),
                vias=len(leg.points_ne_m) - 2,
                length_m=round(leg.length_m, 2),
            )
        return again

    return replan_from


def place_labels(mission: Mission) -> list[str]:
    """How the operator's places (:meth:`Mission.places`, the planner's via points left out)
    are named: by mission item, as the ground station and ``check``'s step table number them
    ("item 4"), in a mission with commands; "wp 3" in one of plain waypoints (the same
    number there)."""
    word = "item" if mission.has_commands() else "wp"
    number: dict[int, int] = {}
    n = 0
    for wp in mission.waypoints:
        if not wp.via:
            n += 1
            number[id(wp)] = n
    return [f"{word} {number[id(wp)]}" for wp in mission.places() if not wp.via]


def route_lines(route: RoutePlan, mission: Mission | None = None) -> list[str]:
    """The planned legs, one line each, with their intermediate points; places named as
    :func:`place_labels` names them (``mission``: the flown mission; without it "wp N" by
    place, from 1)."""
    labels = place_labels(mission) if mission is not None else []

    def label(index: int) -> str:
        return labels[index] if index < len(labels) else f"wp {index + 1}"

    fr = route.grid.frame
    lines = [
        f"planned : clearance {route.grid.clearance_m:.2f} m (rover half-width + "
        f"planning.margin_m), grid {fr.rows} × {fr.cols} at {fr.resolution_m:g} m, "
        f"{route.seconds * 1000:.0f} ms"
    ]
    for leg in route.legs:
        a = "start" if leg.from_index < 0 else label(leg.from_index)
        via = leg.points_ne_m[1:-1]
        straight = math.dist(leg.points_ne_m[0], leg.points_ne_m[-1])
        how = "straight" if not via else f"{len(via)} intermediate, straight {straight:.1f} m"
        lines.append(f"  leg {a} → {label(leg.to_index)}: {leg.length_m:.1f} m ({how})")
        lines.extend(f"      via north {n:9.2f}  east {e:9.2f}" for n, e in via)
    total = sum(leg.length_m for leg in route.legs)
    start = "planning.start_ne_m" if route.origin_latlon_deg is None else "waypoint 1"
    lines.append(f"  total {total:.1f} m from {start} (run: re-planned from the rover's pose)")
    return lines


@dataclass(frozen=True)
class Flight:
    """What is flown: the mission (planned around obstacles when there are any), the text the
    run directory records, the first-leg re-planner for the daemon's preflight, the inputs
    record (mission/config hashes, what --resume checks) and the route (None: not planned)."""

    mission: Mission
    mission_yaml: str
    replan_from: Replanner | None
    inputs: RunInputs
    route: RoutePlan | None = None
    options: ExpandOptions = DEFAULT_OPTIONS  # --strict / --skip-unsupported
    # a ground-station mission (.plan, .waypoints, the autopilot's): errors name its entries
    # by mission item ("item 3"), a YAML mission's by waypoint ("waypoint 3 (waypoints[2])")
    item_numbers: bool = False


def planned_flight(
    cfg: HelixdConfig,
    msn: Mission,
    mission_yaml: str,
    mission_path: Path,
    occupancy: OccupancyMap | None,
    config_sha: str,
    fence: GcsMission | None = None,
    options: ExpandOptions = DEFAULT_OPTIONS,
) -> Flight:
    """Plan around the map, keep-outs and the fence's exclusion zones (refusals exit 2)."""
    planned, route = plan_loaded(cfg, msn, mission_path, occupancy, fence)
    if route is None:
        inputs = fresh_inputs(mission_yaml, config_sha, msn)
        return Flight(msn, mission_yaml, None, inputs, options=options)
    map_path = None if occupancy is None else occupancy.source
    planned_yaml = planned_mission_yaml(planned, route, map_path)
    return Flight(
        planned,
        planned_yaml,
        first_leg_replanner(cfg, msn, planned, route),
        fresh_inputs(planned_yaml, config_sha, planned),
        route,
        options,
    )


__all__ = [
    "Flight",
    "Replanner",
    "first_leg_replanner",
    "load_occupancy",
    "plan_global",
    "plan_loaded",
    "planned_flight",
    "route_lines",
    "route_time_estimate",
]
