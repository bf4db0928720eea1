"""A file's :class:`GcsMission` (:mod:`helixd.mission.formats.items`: NaN for "unset", fence as
shapes, home apart) ⇄ the item lists the mission protocol carries (finite params, home in slot
0, one list per mission type). Both hold :class:`helixd.mav.mission_item.MissionItem`, x/y in
degrees for a place; the int32 degE7 form exists only at the wire's edge. Pure: no I/O.

Mission (MAV_MISSION_TYPE_MISSION), as QGroundControl uploads to ArduPilot: seq 0 is home (the
plan's planned home, else the first item's place; ArduPilot keeps its own home there and reads
its own back), the file's items follow from seq 1. A parameter QGC leaves unset (NaN, JSON
``null``) goes out as 0: ArduPilot refuses a non-finite parameter (MAV_MISSION_ERROR).

Fence (MAV_MISSION_TYPE_FENCE), as QGC's GeoFenceManager writes it for ArduPilot
(``AC_PolyFence_loader``/``MissionItemProtocol_Fence``): each polygon vertex is one item,
MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION (5001) or _EXCLUSION (5002) with param1 = the
polygon's vertex count; each circle one item, MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION (5003) or
_EXCLUSION (5004) with param1 = radius (m); frame MAV_FRAME_GLOBAL. A downloaded fence is
read back into polygons and circles; a return point (5000) has no place in a file and is
reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from helixd.mav.constants import (
    MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION,
    MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL,
    MAV_MISSION_TYPE_FENCE,
    MAV_MISSION_TYPE_MISSION,
)
from helixd.mav.mission_item import PLACE_COMMANDS, MissionItem, wire_xy, xy_in_degrees
from helixd.mission.formats.items import (
    FenceCircle,
    FencePolygon,
    FenceRow,
    FormatError,
    GcsMission,
    check_latlon,
    fence_shapes,
)

__all__ = [
    "WireMission",
    "gcs_to_wire",
    "wire_to_gcs",
]

DEG_E7 = 1e7
INT32_MAX = 2**31 - 1
INT32_MIN = -(2**31)


@dataclass(frozen=True, slots=True)
class WireMission:
    """What goes over (or came over) the mission protocol: one item list per mission type."""

    mission: tuple[MissionItem, ...]
    fence: tuple[MissionItem, ...]


def _finite_or_zero(v: float) -> float:
    return v if math.isfinite(v) else 0.0


def _deg(deg: float, where: str) -> float:
    """A latitude/longitude that fits MISSION_ITEM_INT's degE7, as it is (FormatError if not)."""
    if not math.isfinite(deg):
        raise FormatError([f"{where}: x/y {deg} is not finite"])
    v = round(deg * DEG_E7)
    if not INT32_MIN <= v <= INT32_MAX:
        raise FormatError([f"{where}: x/y {deg} does not fit MISSION_ITEM_INT"])
    return deg


def _raw_int(v: float, where: str) -> float:
    """x/y that are not a place (e.g. a DO_JUMP's): sent as the integer they hold."""
    if not math.isfinite(v):
        return 0.0
    r = round(v)
    if not INT32_MIN <= r <= INT32_MAX:
        raise FormatError([f"{where}: x/y {v} does not fit MISSION_ITEM_INT"])
    return float(r)


def _label(it: MissionItem) -> str:
    return f"item {it.seq}" + (f" ({it.where})" if it.where else "")


def _mission_item(it: MissionItem, seq: int) -> MissionItem:
    where = _label(it)
    if it.command in PLACE_COMMANDS:  # AP_Mission::cmd_has_location: x/y are lat/lon
        x, y = _deg(it.x, where), _deg(it.y, where)
    else:
        x, y = _raw_int(it.x, where), _raw_int(it.y, where)
    if not 0 <= it.command <= 65535 or not 0 <= it.frame <= 255:
        raise FormatError([f"{where}: command/frame out of range"])
    return MissionItem(
        seq=seq,
        frame=it.frame,
        command=it.command,
        autocontinue=int(bool(it.autocontinue)),
        param1=_finite_or_zero(it.param1),
        param2=_finite_or_zero(it.param2),
        param3=_finite_or_zero(it.param3),
        param4=_finite_or_zero(it.param4),
        x=x,
        y=y,
        z=_finite_or_zero(it.z),
        mission_type=MAV_MISSION_TYPE_MISSION,
    )


def _home(gcs: GcsMission) -> tuple[float, float]:
    if gcs.home_latlon_deg is not None:
        return gcs.home_latlon_deg
    for it in gcs.items:
        if it.command in PLACE_COMMANDS and not check_latlon("", it.x, it.y):
            return (it.x, it.y)
    raise FormatError(["no home position and no item with a latitude/longitude to stand for it"])


def gcs_to_wire(gcs: GcsMission) -> WireMission:
    """The file's items (home as seq 0) and its fence, as the mission protocol sends them."""
    if not gcs.items:
        raise FormatError(["no mission items to upload"])
    home_lat, home_lon = _home(gcs)
    home = MissionItem(
        seq=0,
        frame=MAV_FRAME_GLOBAL,
        command=MAV_CMD_NAV_WAYPOINT,
        x=_deg(home_lat, "home"),
        y=_deg(home_lon, "home"),
        mission_type=MAV_MISSION_TYPE_MISSION,
    )
    mission = [home] + [_mission_item(it, i + 1) for i, it in enumerate(gcs.items)]
    return WireMission(tuple(mission), fence_items(gcs))


def fence_items(gcs: GcsMission) -> tuple[MissionItem, ...]:
    """The file's fence polygons and circles as MAV_MISSION_TYPE_FENCE items (seq 0..n-1)."""
    out: list[MissionItem] = []

    def add(command: int, param1: float, lat: float, lon: float, where: str) -> None:
        out.append(
            MissionItem(
                seq=len(out),
                frame=MAV_FRAME_GLOBAL,
                command=command,
                autocontinue=0,
                param1=param1,
                x=_deg(lat, where),
                y=_deg(lon, where),
                mission_type=MAV_MISSION_TYPE_FENCE,
            )
        )

    for k, poly in enumerate(gcs.polygons):
        cmd = (
            MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
            if poly.inclusion
            else MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION
        )
        n = len(poly.vertices_latlon_deg)
        if n < 3:
            raise FormatError([f"fence polygon {k}: {n} vertices (at least 3)"])
        for lat, lon in poly.vertices_latlon_deg:
            add(cmd, float(n), lat, lon, f"fence polygon {k}")
    for k, circle in enumerate(gcs.circles):
        cmd = (
            MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION
            if circle.inclusion
            else MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
        )
        if not (math.isfinite(circle.radius_m) and circle.radius_m > 0):
            raise FormatError([f"fence circle {k}: radius {circle.radius_m} m is not > 0"])
        add(cmd, circle.radius_m, *circle.centre_latlon_deg, f"fence circle {k}")
    return tuple(out)


def _wire_latlon(it: MissionItem) -> tuple[float, float]:
    """The item's x/y as latitude/longitude, whatever its command (as home and fence are)."""
    if xy_in_degrees(it.command, it.mission_type):
        return it.x, it.y
    x, y = wire_xy(it)
    return x / DEG_E7, y / DEG_E7


def _from_wire(it: MissionItem) -> MissionItem:
    return replace(
        it,
        current=0,
        autocontinue=bool(it.autocontinue),
        mission_type=MAV_MISSION_TYPE_MISSION,
        where=f"autopilot mission item {it.seq}",
    )


def _fence_from_wire(
    fence: tuple[MissionItem, ...] | list[MissionItem],
) -> tuple[list[FencePolygon], list[FenceCircle], list[str]]:
    rows = [
        FenceRow(it.seq, it.command, it.param1, *_wire_latlon(it), f"autopilot fence item {it.seq}")
        for it in fence
    ]
    return fence_shapes(rows)


def wire_to_gcs(
    mission: tuple[MissionItem, ...] | list[MissionItem],
    fence: tuple[MissionItem, ...] | list[MissionItem] = (),
) -> tuple[GcsMission, list[str]]:
    """What the autopilot holds → a :class:`GcsMission` (seq 0 = home; fence polygons and
    circles) and notes on what has no place in it."""
    home: tuple[float, float] | None = None
    items: list[MissionItem] = []
    for it in mission:
        if it.seq == 0:
            lat, lon = _wire_latlon(it)
            if not check_latlon("home", lat, lon):
                home = (lat, lon)
            continue
        items.append(_from_wire(it))
    polygons, circles, notes = _fence_from_wire(fence)
    gcs = GcsMission(
        items=tuple(items),
        home_latlon_deg=home,
        polygons=tuple(polygons),
        circles=tuple(circles),
    )
    return gcs, notes
