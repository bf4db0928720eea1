"""Ground-station missions in ArduPilot's terms: mission items, fences, and their conversion
to and from helixd's :class:`~helixd.mission.model.Mission`. Pure: no I/O.

A :class:`~helixd.mav.mission_item.MissionItem` is what MISSION_ITEM_INT carries (seq, frame,
command, param1..4, x/y/z with x/y in degrees for a place), so the MAVLink mission download
feeds :func:`items_to_mission` the same way the file readers do. Sequence numbers follow the
autopilot's: 0 is home (ArduPilot keeps home in slot 0), the mission's items start at 1. Every
item becomes a mission entry and back (:func:`item_entry`, :func:`entry_item`) with all it
carries: command, frame, parameters (NaN as unset), place (lat/lon 0, 0 as "where the rover
is"), altitude, autocontinue.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

from pydantic import ValidationError

from helixd.base.frames import latlon_to_ne, ne_to_latlon
from helixd.base.plan import MissionFrameKind, MotionMode
from helixd.base.problems import Problems
from helixd.files.models import format_validation_error
from helixd.mav.constants import (
    GLOBAL_FRAMES,
    MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION,
    MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    MAV_CMD_NAV_FENCE_RETURN_POINT,
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
)
from helixd.mav.mission_item import MissionItem
from helixd.mission.commands import MAX_PARAMS, command_name, command_spec
from helixd.mission.model import Mission, WaypointSpec

# AP_Mission::mavlink_int_to_mission_cmd also reads a place in MAV_FRAME_MISSION (2) as
# lat/lon (absolute altitude)
PLACE_FRAMES = GLOBAL_FRAMES | {2}
MAX_ITEMS = 100_000  # as many as a helixd YAML mission may hold in practice


class FormatError(Problems, ValueError):
    """A ground-station file or item list cannot become a mission; one line per problem."""


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
class FenceRow:
    """One fence item, wherever it came from (a fence file's row, the autopilot's fence)."""

    seq: int
    command: int  # MAV_CMD_NAV_FENCE_* (5000..5004)
    param1: float  # polygon vertex count, or circle radius (m)
    lat: float
    lon: float
    where: str


def fence_shapes(
    rows: list[FenceRow],
) -> tuple[list[FencePolygon], list[FenceCircle], list[str]]:
    """Fence items → polygons (consecutive vertices of one kind, param1 = their count) and
    circles (param1 = radius), as ArduPilot's AC_PolyFence_loader reads them; a return point
    is reported, not kept. FormatError naming the item for what is not whole."""
    polygons: list[FencePolygon] = []
    circles: list[FenceCircle] = []
    notes: list[str] = []
    problems: list[str] = []
    i = 0
    while i < len(rows):
        it = rows[i]
        bad = check_latlon(it.where, it.lat, it.lon)
        if it.command in _POLY_CMDS:
            n = round(it.param1) if math.isfinite(it.param1) else 0
            run = rows[i : i + n]
            if n < 3 or len(run) < n or any(v.command != it.command for v in run):
                problems.append(
                    f"{it.where}: a polygon of {it.param1:g} vertices that is not whole"
                )
                i += 1
                continue
            for v in run:
                problems += check_latlon(v.where, v.lat, v.lon)
            polygons.append(
                FencePolygon(tuple((v.lat, v.lon) for v in run), _POLY_CMDS[it.command])
            )
            i += n
            continue
        if it.command in _CIRCLE_CMDS:
            if not (math.isfinite(it.param1) and it.param1 > 0):
                problems.append(f"{it.where}: circle radius {it.param1:g} m is not > 0")
            problems += bad
            circles.append(FenceCircle((it.lat, it.lon), it.param1, _CIRCLE_CMDS[it.command]))
        elif it.command == MAV_CMD_NAV_FENCE_RETURN_POINT:
            notes.append(f"{it.where}: fence return point ({it.lat:.7f}, {it.lon:.7f}) not kept")
        else:
            notes.append(f"{it.where}: fence command {it.command} not understood; left out")
        i += 1
    if problems:
        raise FormatError(problems[:20])
    return polygons, circles, notes


_POLY_CMDS = {
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION: True,
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION: False,
}
_CIRCLE_CMDS = {
    MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION: True,
    MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION: False,
}


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
    media_map: str | None = None  # the same: the mission's media map (relative: to the file)
    notes: tuple[str, ...] = ()  # what the reader left out or made up, for the operator


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
    notes: tuple[str, ...]  # what was read but has no meaning for helixd, or was made up


def _label(it: MissionItem) -> str:
    return f"item {it.seq}" + (f" ({it.where})" if it.where else "")


def _params(values: list[float]) -> list[float | None]:
    return [None if math.isnan(v) else v for v in values]


def item_entry(it: MissionItem) -> tuple[dict[str, object] | None, list[str]]:
    """One ground-station item as a mission entry (a dict for :class:`WaypointSpec`), with
    every value it carries, or the problems naming it. Lat/lon 0, 0 on a place is ArduPilot's
    "where the rover is" (``Location::sanitize``): the entry gets no coordinates."""
    spec = command_spec(it.command)
    label = _label(it)
    raw = [it.param1, it.param2, it.param3, it.param4]
    entry: dict[str, object] = {"command": it.command}
    if spec.has_place:
        here = it.x == 0.0 and it.y == 0.0
        if not here:
            if it.frame not in PLACE_FRAMES:
                return None, [
                    f"{label}: {spec.name} in frame {it.frame}: ArduPilot refuses the frame "
                    f"(MAV_MISSION_UNSUPPORTED_FRAME; lat/lon frames are "
                    f"{sorted(PLACE_FRAMES)})"
                ]
            bad = check_latlon(label, it.x, it.y)
            if bad:
                return None, bad
            entry["lat"], entry["lon"] = it.x, it.y
        values = raw
    else:
        values = [*raw, it.x, it.y][:MAX_PARAMS]
        if not all(math.isfinite(v) for v in values[4:]):
            return None, [f"{label}: x/y of {spec.name} are not finite"]
    params = _params(values)
    if tuple(params) != spec.defaults():
        entry["params"] = params
    if math.isfinite(it.z) and it.z != 0.0:
        entry["z"] = it.z
    if it.frame != spec.default_frame():
        entry["frame"] = it.frame
    if not it.autocontinue:
        entry["autocontinue"] = False
    return entry, []


HERE_NOTE = (
    "item 1: NAV_WAYPOINT at latitude/longitude 0, 0, the mission's only item: 'here' to "
    "ArduPilot Rover, which reaches it at once and completes the mission; helixd flies it as a "
    "waypoint where the rover starts (frame start, x 0, y 0), done at once"
)


def _here_only(
    gcs: GcsMission, entries: list[dict[str, object]], name: str, mode: MotionMode
) -> Mission | None:
    """A file whose only item is a NAV_WAYPOINT at 0, 0 without a hold ("here",
    Location::sanitize):
    the start-frame mission of one waypoint at the rover (completed at once, as Rover
    completes it); None for anything else (a fence, a hold, more items)."""
    helixd_keys = gcs.time_limit_s is not None or gcs.media_map is not None
    if len(entries) != 1 or gcs.polygons or gcs.circles or helixd_keys:
        return None
    (entry,) = entries
    params = entry.get("params")
    hold_s = params[0] if isinstance(params, list) and params else 0.0
    if entry.get("command") != MAV_CMD_NAV_WAYPOINT or "lat" in entry or hold_s != 0.0:
        return None  # a place, or a hold there: not "done at once"
    return Mission.model_validate(
        {"name": name, "mode": mode.value, "frame": "start",
         "waypoints": [{"x": 0.0, "y": 0.0}]}
    )  # fmt: skip


def items_to_mission(
    gcs: GcsMission,
    *,
    name: str,
    mode: MotionMode,
    source: str = "",
    route_keep_outs: bool = False,
    here_completes: bool = False,
) -> Converted:
    """Every item of the file, in order, becomes an entry of a ``global`` mission (commands
    included, nothing dropped: what ArduPilot Rover skips or helixd cannot fly is decided by
    :mod:`helixd.mission.expand` when the mission is checked). The mission's keep-in fence is
    the file's one inclusion polygon, if it has exactly one; its home is the file's. With
    ``route_keep_outs`` (helixd.planning will route the legs around the exclusion zones) a leg
    crossing one is not refused; a waypoint inside one still is."""
    prefix = f"{source}: " if source else ""
    read = _ItemEntries.of(gcs)
    problems, notes = read.problems, read.notes
    if read.points:
        problems.extend(keep_out_problems(gcs, read.points, read.labels, legs=not route_keep_outs))
    at_once = _here_only(gcs, read.entries, name, mode) if here_completes and not problems else None
    if at_once is not None:
        return Converted(at_once, (*gcs.notes, *(prefix + n for n in notes), prefix + HERE_NOTE))
    if not read.points and not problems:
        problems.append(_nothing_to_fly(gcs))
    if problems:
        raise FormatError([prefix + p for p in problems[:20]] + _more(problems, 20, prefix))
    data = _mission_data(gcs, name, mode, read.entries, notes)
    try:
        mission = Mission.model_validate(data)
    except ValidationError as exc:
        raise FormatError(format_validation_error(source or "mission", exc, Mission)) from None
    return Converted(mission, (*gcs.notes, *(prefix + n for n in notes)))


@dataclass
class _ItemEntries:
    """The file's items read as mission entries, with the places the rover drives to (and
    their items' labels), the problems and the notes."""

    entries: list[dict[str, object]] = field(default_factory=list)
    points: list[tuple[float, float]] = field(default_factory=list)
    labels: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @classmethod
    def of(cls, gcs: GcsMission) -> _ItemEntries:
        """Each item in order; a plain waypoint at the place of the plain waypoint before it
        is dropped."""
        read = cls()
        previous_plain: tuple[float, float] | None = None
        for it in gcs.items:
            entry, bad = item_entry(it)
            if entry is None:
                read.problems.extend(bad)
                continue
            if it.command == MAV_CMD_NAV_WAYPOINT and math.isfinite(it.param2) and it.param2 > 0:
                read.notes.append(
                    f"{_label(it)}: acceptance radius {it.param2:g} m (param2) ignored: helixd "
                    "reaches waypoints within control.waypoint_tolerance_m or the mission's "
                    "tolerance_m"
                )
            place = (entry.get("lat"), entry.get("lon"))
            plain = (
                it.command == MAV_CMD_NAV_WAYPOINT
                and place[0] is not None
                and "params" not in entry
            )
            if plain and previous_plain is not None:
                here = (float(str(place[0])), float(str(place[1])))
                if _same_point(previous_plain, here):
                    read.notes.append(f"{_label(it)}: same place as the item before; dropped")
                    continue
            if place[0] is not None and command_spec(it.command).role.value in (
                "waypoint", "loiter_time", "loiter_turns", "loiter_unlim",
            ):  # fmt: skip
                read.points.append((float(str(place[0])), float(str(place[1]))))
                read.labels.append(_label(it))
            previous_plain = (float(str(place[0])), float(str(place[1]))) if plain else None
            read.entries.append(entry)
        return read


def _nothing_to_fly(gcs: GcsMission) -> str:
    """The problem of a file with no place to drive to, naming its navigation items."""
    navs = [
        f"{_label(it)} {command_name(it.command)}"
        for it in gcs.items
        if command_spec(it.command).nav
    ]
    return (
        "no item with a latitude/longitude to go to"
        + (f" ({', '.join(navs[:5])}: none drives anywhere)" if navs else "")
        + ": nothing to fly"
    )


def _mission_data(
    gcs: GcsMission,
    name: str,
    mode: MotionMode,
    entries: list[dict[str, object]],
    notes: list[str],
) -> dict[str, object]:
    """The ``global`` mission's fields: its entries, the file's keep-in fence, time limit,
    media map and home (``notes``: what of the file is not used)."""
    fence, why_none = keep_in_of(gcs)
    if why_none:
        notes.append(
            f"{why_none}: none used as the mission fence (helixd keeps one keep-in polygon)"
        )
    data: dict[str, object] = {
        "name": name,
        "mode": mode.value,
        "frame": MissionFrameKind.GLOBAL.value,
        "waypoints": entries,
    }
    if fence:
        data["geofence_polygon"] = [list(v) for v in fence]
    if gcs.time_limit_s is not None:
        data["time_limit_s"] = gcs.time_limit_s
    if gcs.media_map is not None:
        data["media_map"] = gcs.media_map
    if gcs.cruise_speed_mps is not None:
        notes.append(
            f"cruiseSpeed {gcs.cruise_speed_mps:g} m/s ignored: helixd flies at "
            "control.max_speed_mps (or a YAML mission's speed_mps)"
        )
    if gcs.home_latlon_deg is not None:
        data["home"] = list(gcs.home_latlon_deg)
        if gcs.home_alt_m is not None and math.isfinite(gcs.home_alt_m) and gcs.home_alt_m:
            data["home_alt_m"] = gcs.home_alt_m
    return data


CIRCLE_FENCE_VERTICES = 64


def keep_in_of(gcs: GcsMission) -> tuple[tuple[tuple[float, float], ...], str]:
    """The one keep-in polygon of a fence: its one inclusion polygon, or its one inclusion
    circle as a polygon; none (and why, "" when it has no inclusion at all) otherwise."""
    inclusions = [p for p in gcs.polygons if p.inclusion]
    circles = [c for c in gcs.circles if c.inclusion]
    if len(inclusions) == 1 and not circles:
        return inclusions[0].vertices_latlon_deg, ""
    if len(circles) == 1 and not inclusions:
        return circle_polygon(circles[0]), ""
    if inclusions or circles:
        return (), f"{len(inclusions)} inclusion polygons and {len(circles)} inclusion circles"
    return (), ""


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


def waypoint_item(seq: int, lat_deg: float, lon_deg: float, where: str = "") -> MissionItem:
    """A plain NAV_WAYPOINT at lat/lon, altitude relative to home, no yaw (param4 NaN);
    ``where`` names where it came from, for messages."""
    return MissionItem(
        seq=seq,
        frame=MAV_FRAME_GLOBAL_RELATIVE_ALT,
        command=MAV_CMD_NAV_WAYPOINT,
        param4=math.nan,
        x=lat_deg,
        y=lon_deg,
        where=where,
    )


def entry_item(seq: int, wp: WaypointSpec) -> MissionItem:
    """A mission entry as the item a ground station holds (the reverse of :func:`item_entry`)."""
    spec = wp.spec
    p = [wp.param(i) for i in range(MAX_PARAMS)]
    if spec.has_place:
        x = wp.lat if wp.lat is not None else 0.0
        y = wp.lon if wp.lon is not None else 0.0
    else:
        x, y = p[4], p[5]
    return MissionItem(
        seq=seq,
        frame=wp.frame if wp.frame is not None else spec.default_frame(),
        command=wp.command,
        param1=p[0],
        param2=p[1],
        param3=p[2],
        param4=p[3],
        x=x,
        y=y,
        z=wp.z or 0.0,
        autocontinue=wp.autocontinue,
    )


def mission_to_items(
    mission: Mission, home: tuple[float, float, float] | None = None
) -> GcsMission:
    """A ``global`` mission as ground-station items (seq 1..N, every entry; home = ``home``
    (lat, lon, alt), e.g. the one the source file had, else the mission's home, else waypoint
    0's place)."""
    if mission.frame is not MissionFrameKind.GLOBAL:
        raise FormatError(
            [
                f"mission {mission.name!r} is in the '{mission.frame.value}' frame: only global "
                "(lat/lon) missions can be written for a ground station (their north/east or "
                "x/y have no place on the map until the rover's EKF origin is known)"
            ]
        )
    items = tuple(entry_item(i + 1, wp) for i, wp in enumerate(mission.waypoints))
    polygons: tuple[FencePolygon, ...] = (
        (FencePolygon(mission.geofence_polygon, inclusion=True),)
        if mission.geofence_polygon
        else ()
    )
    # keep-out areas are the geofence's exclusion polygons for a ground station
    polygons += tuple(FencePolygon(p, inclusion=False) for p in mission.keep_out_polygons)
    if home is not None:
        home_latlon: tuple[float, float] = (home[0], home[1])
    else:
        home_latlon = mission.home if mission.home is not None else mission.points()[0]
    return GcsMission(
        items=items,
        home_latlon_deg=home_latlon,
        polygons=polygons,
        home_alt_m=mission.home_alt_m if home is None else home[2],
        time_limit_s=mission.time_limit_s,
        media_map=None if mission.media_map is None else str(mission.media_map),
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
