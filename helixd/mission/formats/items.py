"""Ground-station missions in ArduPilot's terms: mission items, fences, and their conversion
to and from helixd's :class:`~helixd.mission.model.Mission`. Pure: no I/O.

A :class:`MissionItem` is what MISSION_ITEM_INT carries (seq, frame, command, param1..4,
x/y/z with x/y in degrees), so the MAVLink mission download of a later session can feed
:func:`items_to_mission` the same way the file readers do. Sequence numbers follow the
autopilot's: 0 is home (ArduPilot keeps home in slot 0), flown items start at 1.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

from pydantic import ValidationError

from helixd.base.frames import latlon_to_ne, ne_to_latlon
from helixd.files.models import format_validation_error
from helixd.mav.constants import (
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
)
from helixd.mission.model import Mission, MissionFrameKind, MotionMode

# _RELATIVE_ALT_INT, _TERRAIN_ALT, _TERRAIN_ALT_INT); the altitude means nothing to a rover.
GLOBAL_FRAMES = frozenset({0, 3, 5, 6, 10, 11})
MAX_ITEMS = 100_000  # as many as a helixd YAML mission may hold in practice
COMMAND_NAMES = {
    16: "NAV_WAYPOINT",
    17: "NAV_LOITER_UNLIM",
    19: "NAV_LOITER_TIME",
    20: "NAV_RETURN_TO_LAUNCH",
    21: "NAV_LAND",
    22: "NAV_TAKEOFF",
    177: "DO_JUMP",
    178: "DO_CHANGE_SPEED",
    183: "DO_SET_SERVO",
    206: "DO_SET_CAM_TRIGG_DIST",
    2000: "IMAGE_START_CAPTURE",
    2001: "IMAGE_STOP_CAPTURE",
}


class FormatError(ValueError):
    """A ground-station file or item list cannot become a mission; one line per problem."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        super().__init__("\n".join(problems))


@dataclass(frozen=True, slots=True)
class MissionItem:
    """One mission item as ArduPilot stores it (x = latitude, y = longitude in degrees for the
    global frames). ``where`` says where it came from, for messages (e.g. "mission.items.3")."""

    seq: int
    frame: int
    command: int
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    autocontinue: bool = True
    where: str = ""


@dataclass(frozen=True, slots=True)
class FencePolygon:
    vertices_latlon_deg: tuple[tuple[float, float], ...]
    inclusion: bool


@dataclass(frozen=True, slots=True)
class FenceCircle:
    centre_latlon_deg: tuple[float, float]
    radius_m: float
    inclusion: bool


@dataclass(frozen=True, slots=True)
class GcsMission:
    """What a .plan / .waypoints file (or the autopilot) holds."""

    items: tuple[MissionItem, ...]
    home_latlon_deg: tuple[float, float] | None = None
    polygons: tuple[FencePolygon, ...] = ()
    circles: tuple[FenceCircle, ...] = ()
    survey_polygons: tuple[tuple[tuple[float, float], ...], ...] = field(default=())
    home_alt_m: float | None = None  # the home row's / planned home's altitude, if it has one
    cruise_speed_mps: float | None = None  # a QGC .plan's cruiseSpeed (not used yet: a note)
    time_limit_s: float | None = None  # helixd's own key in a .plan it wrote


def command_name(command: int) -> str:
    return COMMAND_NAMES.get(command, f"command {command}")


def _latlon_problem(lat: float, lon: float) -> str | None:
    if not (math.isfinite(lat) and math.isfinite(lon)):
        return f"latitude/longitude ({lat}, {lon}) is not finite"
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        return f"latitude/longitude ({lat}, {lon}) is off the Earth (-90..90, -180..180)"
    if lat == 0.0 and lon == 0.0:
        return "latitude/longitude (0, 0): ArduPilot reads that as 'here', helixd refuses it"
    return None


def check_latlon(where: str, lat: float, lon: float) -> list[str]:
    p = _latlon_problem(lat, lon)
    return [] if p is None else [f"{where}: {p}"]


def mission_name(stem: str) -> str:
    """A valid Mission.name from a file name."""
    name = re.sub(r"[^A-Za-z0-9_.\- ]+", "_", stem).strip()[:80]
    return name or "mission"


@dataclass(frozen=True, slots=True)
class Converted:
    mission: Mission
    skipped: tuple[str, ...]  # unsupported items left out (with --skip-unsupported)
    notes: tuple[str, ...]  # what was read but has no meaning for helixd


def items_to_mission(
    gcs: GcsMission,
    *,
    name: str,
    mode: MotionMode,
    skip_unsupported: bool = False,
    source: str = "",
    route_keep_outs: bool = False,
) -> Converted:
    """NAV_WAYPOINT items (global frames) become a ``global`` mission; anything else is
    reported by sequence number and refused unless ``skip_unsupported``. The mission's keep-in
    fence is the file's one inclusion polygon, if it has exactly one. With ``route_keep_outs``
    (helixd.planning will route the legs around the exclusion zones) a leg crossing one is
    not refused; a waypoint inside one still is."""
    prefix = f"{source}: " if source else ""
    unsupported: list[str] = []
    problems: list[str] = []
    notes: list[str] = []
    points: list[tuple[float, float]] = []
    labels: list[str] = []
    for it in gcs.items:
        label = f"item {it.seq}" + (f" ({it.where})" if it.where else "")
        if it.command != MAV_CMD_NAV_WAYPOINT:
            unsupported.append(f"{label}: {command_name(it.command)} cannot be flown by helixd")
            continue
        if it.frame not in GLOBAL_FRAMES:
            unsupported.append(
                f"{label}: NAV_WAYPOINT in frame {it.frame} (only global lat/lon frames "
                f"{sorted(GLOBAL_FRAMES)} are understood)"
            )
            continue
        bad = check_latlon(label, it.x, it.y)
        if bad:
            problems.extend(bad)
            continue
        if math.isfinite(it.param1) and it.param1 > 0:
            notes.append(
                f"{label}: hold time {it.param1:g} s (param1) ignored: helixd does not hold"
            )
        if math.isfinite(it.param2) and it.param2 > 0:
            notes.append(
                f"{label}: acceptance radius {it.param2:g} m (param2) ignored: helixd reaches "
                "waypoints within control.waypoint_tolerance_m or the mission's tolerance_m"
            )
        if points and _same_point(points[-1], (it.x, it.y)):
            notes.append(f"{label}: same place as the item before; dropped")
            continue
        points.append((it.x, it.y))
        labels.append(label)
    if points:
        problems.extend(keep_out_problems(gcs, points, labels, legs=not route_keep_outs))
    if unsupported and not skip_unsupported:
        problems.extend(
            f"{u} (use --skip-unsupported to fly the waypoints without it)" for u in unsupported
        )
    if not points and not problems:
        problems.append("no NAV_WAYPOINT items with a latitude/longitude: nothing to fly")
    if problems:
        raise FormatError([prefix + p for p in problems[:20]] + _more(problems, 20, prefix))
    fence: tuple[tuple[float, float], ...] = ()
    inclusions = [p for p in gcs.polygons if p.inclusion]
    circles = [c for c in gcs.circles if c.inclusion]
    if len(inclusions) == 1 and not circles:
        fence = inclusions[0].vertices_latlon_deg
    elif len(circles) == 1 and not inclusions:
        fence = circle_polygon(circles[0])
    elif inclusions or circles:
        notes.append(
            f"{len(inclusions)} inclusion polygons and {len(circles)} inclusion circles: none "
            "used as the mission fence (helixd keeps one keep-in polygon)"
        )
    data: dict[str, object] = {
        "name": name,
        "mode": mode.value,
        "frame": MissionFrameKind.GLOBAL.value,
        "waypoints": [{"lat": a, "lon": b} for a, b in points],
    }
    if fence:
        data["geofence_polygon"] = [list(v) for v in fence]
    if gcs.time_limit_s is not None:
        data["time_limit_s"] = gcs.time_limit_s
    if gcs.cruise_speed_mps is not None:
        notes.append(
            f"cruiseSpeed {gcs.cruise_speed_mps:g} m/s ignored: helixd flies at "
            "control.max_speed_mps (or a YAML mission's speed_mps)"
        )
    try:
        mission = Mission.model_validate(data)
    except ValidationError as exc:
        raise FormatError(format_validation_error(source or "mission", exc, Mission)) from None
    return Converted(mission, tuple(prefix + u for u in unsupported), tuple(notes))


CIRCLE_FENCE_VERTICES = 64


def circle_polygon(circle: FenceCircle) -> tuple[tuple[float, float], ...]:
    """An inclusion circle as a keep-in polygon: the inscribed 64-gon (never outside it)."""
    lat0, lon0 = circle.centre_latlon_deg
    return tuple(
        ne_to_latlon(
            circle.radius_m * math.cos(2 * math.pi * k / CIRCLE_FENCE_VERTICES),
            circle.radius_m * math.sin(2 * math.pi * k / CIRCLE_FENCE_VERTICES),
            lat0,
            lon0,
        )
        for k in range(CIRCLE_FENCE_VERTICES)
    )


def keep_out_problems(
    gcs: GcsMission, points: list[tuple[float, float]], labels: list[str], legs: bool = True
) -> list[str]:
    """Waypoints inside, or legs through, the file's exclusion polygons/circles (keep-outs).

    Checked in the EKF map around the first waypoint (the same geometry as in flight, to well
    under a millimetre over a survey). helixd flies straight legs: a leg through a keep-out is
    refused, not routed around."""
    from shapely.geometry import LineString, Point, Polygon

    origin = points[0]
    ne = [latlon_to_ne(a, b, *origin) for a, b in points]
    zones: list[tuple[str, Any]] = []  # shapely geometries
    for k, poly in enumerate(p for p in gcs.polygons if not p.inclusion):
        shape = Polygon([latlon_to_ne(a, b, *origin) for a, b in poly.vertices_latlon_deg])
        zones.append((f"exclusion polygon {k}", shape if shape.is_valid else shape.buffer(0)))
    for k, circle in enumerate(c for c in gcs.circles if not c.inclusion):
        centre = Point(latlon_to_ne(*circle.centre_latlon_deg, *origin))
        zones.append(
            (f"exclusion circle {k} ({circle.radius_m:g} m)", centre.buffer(circle.radius_m))
        )
    out: list[str] = []
    for name, zone in zones:
        for label, p in zip(labels, ne, strict=True):
            if zone.intersects(Point(p)):
                out.append(f"{label}: inside the geofence's {name}")
        for i in range(1, len(ne) if legs else 1):
            leg = LineString([ne[i - 1], ne[i]])
            if zone.intersects(leg) and not any(
                zone.intersects(Point(q)) for q in (ne[i - 1], ne[i])
            ):
                out.append(
                    f"leg {labels[i - 1].split(' (')[0]} → {labels[i].split(' (')[0]} crosses "
                    f"the geofence's {name} (helixd flies straight legs)"
                )
    return out


def _more(problems: list[str], shown: int, prefix: str) -> list[str]:
    return [f"{prefix}… and {len(problems) - shown} more"] if len(problems) > shown else []


def _same_point(a: tuple[float, float], b: tuple[float, float]) -> bool:
    n, e = latlon_to_ne(b[0], b[1], a[0], a[1])
    return math.hypot(n, e) < 0.01


def waypoint_item(seq: int, lat_deg: float, lon_deg: float) -> MissionItem:
    """A plain NAV_WAYPOINT at lat/lon, altitude relative to home, no yaw (param4 NaN)."""
    return MissionItem(
        seq=seq,
        frame=MAV_FRAME_GLOBAL_RELATIVE_ALT,
        command=MAV_CMD_NAV_WAYPOINT,
        param4=math.nan,
        x=lat_deg,
        y=lon_deg,
    )


def mission_to_items(
    mission: Mission, home: tuple[float, float, float] | None = None
) -> GcsMission:
    """A ``global`` mission as NAV_WAYPOINT items (seq 1..N; home = ``home`` (lat, lon, alt),
    e.g. the one the source file had, else waypoint 1's place)."""
    if mission.frame is not MissionFrameKind.GLOBAL:
        raise FormatError(
            [
                f"mission {mission.name!r} is in the '{mission.frame.value}' frame: only global "
                "(lat/lon) missions can be written for a ground station (their north/east or "
                "x/y have no place on the map until the rover's EKF origin is known)"
            ]
        )
    pts = mission.points()
    items = tuple(waypoint_item(i + 1, lat, lon) for i, (lat, lon) in enumerate(pts))
    polygons: tuple[FencePolygon, ...] = (
        (FencePolygon(mission.geofence_polygon, inclusion=True),)
        if mission.geofence_polygon
        else ()
    )
    # keep-out areas are the geofence's exclusion polygons for a ground station
    polygons += tuple(FencePolygon(p, inclusion=False) for p in mission.keep_out_polygons)
    return GcsMission(
        items=items,
        home_latlon_deg=pts[0] if home is None else (home[0], home[1]),
        polygons=polygons,
        home_alt_m=None if home is None else home[2],
        time_limit_s=mission.time_limit_s,
    )


@dataclass(frozen=True, slots=True)
class ObstacleCircle:
    centre_ne_m: tuple[float, float]
    radius_m: float


@dataclass(frozen=True, slots=True)
class FenceNe:
    """A .plan geofence in local north/east metres from the EKF origin (plain numbers): the
    planner's keep-out obstacles and the keep-in boundary."""

    inclusion_polygons: tuple[tuple[tuple[float, float], ...], ...]
    exclusion_polygons: tuple[tuple[tuple[float, float], ...], ...]
    inclusion_circles: tuple[ObstacleCircle, ...]
    exclusion_circles: tuple[ObstacleCircle, ...]


def fence_ne(gcs: GcsMission, origin_latlon_deg: tuple[float, float]) -> FenceNe:
    """Every fence polygon/circle of ``gcs`` as (north_m, east_m) around the EKF origin."""

    def poly(p: FencePolygon) -> tuple[tuple[float, float], ...]:
        return tuple(latlon_to_ne(a, b, *origin_latlon_deg) for a, b in p.vertices_latlon_deg)

    def circle(c: FenceCircle) -> ObstacleCircle:
        return ObstacleCircle(latlon_to_ne(*c.centre_latlon_deg, *origin_latlon_deg), c.radius_m)

    return FenceNe(
        inclusion_polygons=tuple(poly(p) for p in gcs.polygons if p.inclusion),
        exclusion_polygons=tuple(poly(p) for p in gcs.polygons if not p.inclusion),
        inclusion_circles=tuple(circle(c) for c in gcs.circles if c.inclusion),
        exclusion_circles=tuple(circle(c) for c in gcs.circles if not c.inclusion),
    )
