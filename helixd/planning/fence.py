"""Plan a ``global`` mission (every QGC ``.plan``) around its own geofence's exclusion zones.

The EKF origin that ``local_ned`` shapes hang from is unknown until the rover connects, but a
.plan's waypoints and fence are all lat/lon: their geometry does not depend on it. So the legs
are planned in a provisional north/east frame around **waypoint 0** (ArduPilot's flat-earth
map, the one ``LOCAL_POSITION_NED`` uses), and the intermediate points are written back as
lat/lon waypoints: the mission stays ``global`` and the daemon converts it from the real EKF
origin at preflight like any other. The difference between planning around waypoint 0 and
around the EKF origin is the map's longitude scale at a different mean latitude: well under a
millimetre over a few hundred metres, inside ``planning.margin_m``.

The first leg starts at waypoint 0 itself (nothing is known of the rover at ``check``); at
``run`` it is re-planned from the rover's pose at preflight
(:func:`helixd.planning.replan.replan_first_leg`).

Shapes that hang from the EKF origin (a ``--map``, ``planning.keep_out_*``) cannot be placed
against a global mission before the origin is known: refused, saying what to do. Pure.
"""

from __future__ import annotations

from collections.abc import Sequence

from helixd.base.frames import latlon_to_ne
from helixd.base.plan import MissionFrameKind
from helixd.config.root import HelixdConfig
from helixd.mission.model import Mission
from helixd.planning.mapfile import OccupancyMap
from helixd.planning.obstacles import (
    KeepOutCircle,
    ObstacleError,
    Obstacles,
    PointNE,
    clearance_m,
    with_geofence,
)
from helixd.planning.route import (
    PlanningError,
    RoutePlan,
    plan_route,
    via_tolerance_m,
    via_waypoints,
    with_vias,
)

ORIGIN_SHAPES_REFUSED = (
    "a global mission (lat/lon, e.g. a .plan) cannot be planned around {what}: those are "
    "north/east of the EKF origin, unknown until the rover connects. Put the keep-outs in the "
    ".plan's geofence (exclusion polygons/circles), or fly a local_ned mission"
)


def plan_global_mission(
    mission: Mission,
    cfg: HelixdConfig,
    exclusion_polygons_ne_m: Sequence[Sequence[PointNE]],
    exclusion_circles: Sequence[KeepOutCircle],
    origin_latlon_deg: tuple[float, float],
    occupancy: OccupancyMap | None = None,
) -> tuple[Mission, RoutePlan]:
    """The global ``mission`` with lat/lon intermediate waypoints around the exclusion shapes
    (north/east around ``origin_latlon_deg``, which must be waypoint 0) and inside the
    mission's keep-in polygon. Raises :class:`PlanningError`."""
    if mission.frame is not MissionFrameKind.GLOBAL:
        raise PlanningError([f"plan_global_mission needs a global mission, not {mission.frame}"])
    pl = cfg.planning
    what = [
        name
        for name, there in (
            ("--map", occupancy is not None),
            ("planning.keep_out_polygons_ne_m", bool(pl.keep_out_polygons_ne_m)),
            ("planning.keep_out_circles", bool(pl.keep_out_circles)),
        )
        if there
    ]
    if what:
        raise PlanningError([ORIGIN_SHAPES_REFUSED.format(what=" and ".join(what))])
    pts_latlon = mission.points()
    if pts_latlon[0] != origin_latlon_deg:
        raise PlanningError(["the provisional planning frame must be around waypoint 0"])
    ne = [latlon_to_ne(a, b, *origin_latlon_deg) for a, b in pts_latlon]
    keep_in = [latlon_to_ne(a, b, *origin_latlon_deg) for a, b in mission.geofence_polygon or ()]
    try:
        obstacles = with_geofence(
            Obstacles(),
            exclusion_polygons_ne_m=exclusion_polygons_ne_m,
            exclusion_circles=exclusion_circles,
            inclusion_ne_m=keep_in,
        )
    except ObstacleError as exc:
        raise PlanningError([f"geofence: {exc}"]) from None
    try:  # the start is waypoint 0 itself: a zero-length first leg, re-planned at run
        route = plan_route(
            [ne[0], *ne],
            obstacles,
            clearance_m(cfg),
            resolution_m=pl.resolution_m,
            pad_m=pl.pad_m,
            max_cells=pl.max_cells,
        )
    except PlanningError as exc:  # "start" is waypoint 0: say it once
        raise PlanningError([p for p in exc.problems if not p.startswith("start ")]) from None
    route = RoutePlan(
        grid=route.grid,
        legs=route.legs,
        seconds=route.seconds,
        notes=(*route.notes, "planned around waypoint 0 (global mission)"),
        origin_latlon_deg=origin_latlon_deg,
    )
    vias = [
        via_waypoints(leg, via_tolerance_m(mission, wp, cfg), origin_latlon_deg)
        for leg, wp in zip(route.legs, mission.places(), strict=True)
    ]
    return with_vias(mission, vias), route
