"""QGroundControl ``.plan`` files (JSON, ``fileType: Plan``), read and written.

Read: SimpleItems, the mission items a Survey / CorridorScan ComplexItem already holds
(``TransectStyleComplexItem.Items``, which QGC saves with the plan; without them, a waypoint at
each of its ``VisualTransectPoints``), the planned home, and the geofence's inclusion/exclusion
polygons and circles. Format as QGC writes it (src/MissionManager/MissionController.cc,
SimpleMissionItem.cc, MissionItem.cc, GeoFenceController.cc, QGCMapPolygon.cc,
TransectStyleComplexItem.cc; "Plan File Format" in the QGC developer guide), in every layout
QGC still opens (``MissionItem::load`` converts them): items with 7 ``params``; the older
4 ``params`` + ``coordinate`` [lat, lon, alt]; the oldest ``type: missionItem`` with
``param1``..``param4`` keys; a version 1 geofence (one ``polygon``); and the older ``.mission``
file (the mission object at the top level, no ``fileType``). A landing pattern (a plane's) is
skipped, as ArduPilot Rover skips landing; a structure scan is refused (it circles a structure
at heights).

Hostile input: the size is capped before parsing; NaN/Infinity literals, duplicate keys, numbers
that overflow to infinity, nesting deeper than :data:`MAX_DEPTH`, and more than
``MAX_ITEMS`` items are refused; every value is type- and range-checked by pydantic (strict:
``true`` is not a number) and a problem names the file, the JSON path and the field.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from helixd.files.jsonio import JsonTextError, load_json_text
from helixd.files.models import format_validation_error
from helixd.files.yamlio import clip
from helixd.mav.mission_item import MissionItem
from helixd.mission.formats.items import (
    MAX_ITEMS,
    FenceCircle,
    FencePolygon,
    FormatError,
    GcsMission,
    check_latlon,
    waypoint_item,
)

MAX_DEPTH = 24  # a .plan nests 6 deep (plan → mission → items → complex → transect → items)

# strict JSON types: a list is a list (pydantic's strict mode takes no list for a tuple)
LatLon = Annotated[list[float], Field(min_length=2, max_length=2)]


class _Json(BaseModel):
    """QGC writes many keys helixd has no use for: ignored, but what is read is strict."""

    model_config = ConfigDict(extra="ignore", frozen=True, strict=True, allow_inf_nan=False)


class SimpleItemJson(_Json):
    type: Literal["SimpleItem", "missionItem"]
    command: int = Field(ge=0, le=65535)
    frame: int = Field(ge=0, le=255)
    params: list[float | None] | None = Field(None, min_length=4, max_length=7)
    coordinate: list[float | None] | None = Field(None, min_length=3, max_length=3)
    param1: float | None = None  # the oldest layout (MissionItem::_convertJsonV1ToV2)
    param2: float | None = None
    param3: float | None = None
    param4: float | None = None
    autoContinue: bool = True
    doJumpId: int | None = Field(None, ge=0)

    @model_validator(mode="after")
    def _layout(self) -> SimpleItemJson:
        """The 7 values MissionItem::load ends up with, whichever layout."""
        if self.params is None:
            if None in (self.param1, self.param2, self.param3, self.param4) and not (
                self.coordinate is not None
            ):
                raise ValueError(
                    "params: missing (QGroundControl's layouts: 7 params; 4 params with a "
                    "coordinate [lat, lon, alt]; param1..param4 with a coordinate)"
                )
        elif self.coordinate is None and len(self.params) != 7:
            raise ValueError(
                f"params: {len(self.params)} values; QGroundControl reads 7, or 4 with a "
                "coordinate [lat, lon, alt]"
            )
        elif self.coordinate is not None and len(self.params) != 4:
            raise ValueError(
                f"params: {len(self.params)} values with a coordinate; QGroundControl reads 4 "
                "params with a coordinate [lat, lon, alt]"
            )
        return self

    def values(self) -> list[float | None]:
        if self.params is not None and self.coordinate is None:
            return list(self.params)
        head = (
            list(self.params)
            if self.params is not None
            else [self.param1, self.param2, self.param3, self.param4]
        )
        return [*head, *(self.coordinate or [0.0, 0.0, 0.0])]


class TransectJson(_Json):
    Items: list[SimpleItemJson] = Field(default_factory=list, max_length=MAX_ITEMS)
    VisualTransectPoints: list[LatLon] = Field(default_factory=list, max_length=MAX_ITEMS)


class ComplexItemJson(_Json):
    type: Literal["ComplexItem"]
    complexItemType: str = Field(max_length=64)
    polygon: list[LatLon] = Field(default_factory=list, max_length=10_000)
    TransectStyleComplexItem: TransectJson | None = None


class MissionJson(_Json):
    items: list[Annotated[SimpleItemJson | ComplexItemJson, Field(discriminator="type")]] = Field(
        max_length=MAX_ITEMS
    )
    plannedHomePosition: list[float | None] | None = Field(None, min_length=2, max_length=3)
    cruiseSpeed: float | None = Field(None, ge=0.0, le=1000.0)
    version: int = 2


class PolygonJson(_Json):
    polygon: list[LatLon] = Field(min_length=3, max_length=10_000)
    inclusion: bool = True


class CircleSpec(_Json):
    center: LatLon
    radius: float = Field(gt=0.0, le=100_000.0)


class CircleJson(_Json):
    circle: CircleSpec
    inclusion: bool = True


class GeoFenceJson(_Json):
    polygons: list[PolygonJson] = Field(default_factory=list, max_length=1000)
    circles: list[CircleJson] = Field(default_factory=list, max_length=1000)
    polygon: list[LatLon] = Field(default_factory=list, max_length=10_000)  # version 1

    def all_polygons(self) -> list[PolygonJson]:
        """Version 2's polygons, and version 1's one (an inclusion) when it has vertices."""
        if len(self.polygon) >= 3:
            return [*self.polygons, PolygonJson(polygon=self.polygon, inclusion=True)]
        return list(self.polygons)


class HelixdJson(_Json):
    """What helixd keeps in a .plan that QGC has no key for (QGC ignores unknown keys)."""

    time_limit_s: float | None = Field(None, gt=0.0, le=86_400.0)
    media_map: str | None = Field(None, min_length=1, max_length=4096)


class PlanJson(_Json):
    fileType: Literal["Plan"]
    version: int = 1
    mission: MissionJson
    geoFence: GeoFenceJson = Field(default_factory=GeoFenceJson)
    helixd: HelixdJson | None = None  # written by helixd


def load_plan_json(text: str, source: Path | str, kind: str = "") -> Any:
    """:func:`helixd.files.jsonio.load_json_text`, its one-line error as a :class:`FormatError`."""
    try:
        return load_json_text(text, source, kind=kind, max_depth=MAX_DEPTH)
    except JsonTextError as exc:
        raise FormatError([exc.message]) from None


def parse_plan_text(text: str, source: Path | str, areas_only: bool = False) -> GcsMission:
    """A .plan's (or an older .mission's) text → :class:`GcsMission`; raise
    :class:`FormatError` naming file and field. ``areas_only``: read for its polygons
    (``helixd mission survey``): a Survey written by hand, with no generated items, is then
    its polygon alone, not a refusal."""
    src = str(source)
    raw = load_plan_json(text, source, kind=".plan")
    if not isinstance(raw, dict):
        raise FormatError([f"{src}: (top level): expected a JSON object, got {type(raw).__name__}"])
    if "fileType" not in raw and "items" in raw:  # a .mission: the mission object alone
        raw = {"fileType": "Plan", "mission": raw}
    try:
        plan = PlanJson.model_validate(raw)
    except ValidationError as exc:
        raise FormatError(format_validation_error(src, exc, PlanJson)[:20]) from None
    return _to_gcs(plan, src, areas_only)


LANDING_PATTERNS = frozenset({"fwLandingPattern", "vtolLandingPattern"})


def _item(sj: SimpleItemJson, seq: int, where: str) -> MissionItem:
    p = [math.nan if v is None else float(v) for v in sj.values()]
    return MissionItem(
        seq=seq,
        frame=sj.frame,
        command=sj.command,
        param1=p[0],
        param2=p[1],
        param3=p[2],
        param4=p[3],
        x=p[4],
        y=p[5],
        z=p[6],
        autocontinue=sj.autoContinue,
        where=where,
    )


def _to_gcs(plan: PlanJson, src: str, areas_only: bool = False) -> GcsMission:
    items: list[MissionItem] = []
    surveys: list[tuple[tuple[float, float], ...]] = []
    notes: list[str] = []
    for i, entry in enumerate(plan.mission.items):
        where = f"mission.items.{i}"
        seq = len(items) + 1  # home is 0 on ArduPilot; QGC numbers the uploaded items from 1
        if isinstance(entry, SimpleItemJson):
            items.append(_item(entry, seq, where))
            continue
        if entry.complexItemType in LANDING_PATTERNS:
            notes.append(
                f"{src}: {where}: ComplexItem {entry.complexItemType} skipped, as ArduPilot "
                "Rover skips landing (a plane's landing pattern)"
            )
            continue
        if entry.polygon:
            surveys.append(tuple((a, b) for a, b in entry.polygon))
        items += _complex_items(entry, seq, where, src, areas_only, notes)
        if len(items) > MAX_ITEMS:
            raise FormatError([f"{src}: more than {MAX_ITEMS} mission items; refused"])
    problems = _place_problems(plan, src)
    if problems:
        raise FormatError(problems[:20])
    home, home_alt = _planned_home(plan)
    fence = plan.geoFence
    return GcsMission(
        items=tuple(items),
        home_latlon_deg=home,
        polygons=tuple(
            FencePolygon(tuple((a, b) for a, b in pj.polygon), pj.inclusion)
            for pj in fence.all_polygons()
        ),
        circles=tuple(
            FenceCircle((cj.circle.center[0], cj.circle.center[1]), cj.circle.radius, cj.inclusion)
            for cj in fence.circles
        ),
        survey_polygons=tuple(surveys),
        home_alt_m=home_alt,
        # a plan helixd wrote carries the mission's speed itself; QGC's cruiseSpeed is noted
        cruise_speed_mps=None if plan.helixd is not None else plan.mission.cruiseSpeed,
        time_limit_s=None if plan.helixd is None else plan.helixd.time_limit_s,
        media_map=None if plan.helixd is None else plan.helixd.media_map,
        notes=tuple(notes),
    )


def _complex_items(
    entry: ComplexItemJson, seq: int, where: str, src: str, areas_only: bool, notes: list[str]
) -> list[MissionItem]:
    """A complex item's mission items, numbered from ``seq``: the items QGroundControl
    generated, else its VisualTransectPoints as waypoints (noted), else none (``areas_only``:
    its polygon is all that is read) or refused."""
    kind = entry.complexItemType
    transect = entry.TransectStyleComplexItem
    if transect is not None and transect.Items:
        return [
            _item(sub, seq + k, f"{where} {kind} item {k}") for k, sub in enumerate(transect.Items)
        ]
    if transect is not None and transect.VisualTransectPoints:
        points = transect.VisualTransectPoints
        notes.append(
            f"{src}: {where}: ComplexItem {clip(kind, 40)}: flown through its "
            f"{len(points)} VisualTransectPoints (it holds no "
            "generated items, so no camera triggers)"
        )
        return [
            waypoint_item(seq + k, lat, lon, f"{where} {kind} VisualTransectPoints.{k}")
            for k, (lat, lon) in enumerate(points)
        ]
    if areas_only:
        return []
    raise FormatError(
        [
            f"{src}: {where}: ComplexItem {clip(kind, 40)} holds no mission items "
            "(TransectStyleComplexItem.Items) and no VisualTransectPoints"
            + (
                ": a structure scan circles a structure at heights, which a rover cannot"
                if kind == "StructureScan"
                else "; open and save the plan in QGroundControl so it writes them"
            )
        ]
    )


def _place_problems(plan: PlanJson, src: str) -> list[str]:
    """The complex items' polygons and the geofence's places that are off the Earth."""
    problems: list[str] = []
    for i, entry in enumerate(plan.mission.items):
        if isinstance(entry, ComplexItemJson):
            for k, (a, b) in enumerate(entry.polygon):
                problems += check_latlon(f"{src}: mission.items.{i}.polygon.{k}", a, b)
    fence = plan.geoFence
    for i, pj in enumerate(fence.all_polygons()):
        for k, (a, b) in enumerate(pj.polygon):
            problems += check_latlon(f"{src}: geoFence.polygons.{i}.polygon.{k}", a, b)
    for i, cj in enumerate(fence.circles):
        problems += check_latlon(f"{src}: geoFence.circles.{i}.circle.center", *cj.circle.center)
    return problems


def _planned_home(plan: PlanJson) -> tuple[tuple[float, float] | None, float | None]:
    """QGroundControl's plannedHomePosition (lat, lon; altitude) when it is a place."""
    hp = plan.mission.plannedHomePosition
    if hp is None or hp[0] is None or hp[1] is None or check_latlon("home", hp[0], hp[1]):
        return None, None
    return (hp[0], hp[1]), hp[2] if len(hp) > 2 else None


def _num(v: float) -> float | None:
    return None if math.isnan(v) else v


def plan_to_text(gcs: GcsMission, cruise_speed_mps: float | None = None) -> str:
    """The .plan QGroundControl would save for these items (4-space JSON, as QGC writes)."""
    items = [
        {
            "AMSLAltAboveTerrain": None,
            "Altitude": it.z,
            "AltitudeMode": 1,
            "autoContinue": it.autocontinue,
            "command": it.command,
            "doJumpId": it.seq,
            "frame": it.frame,
            "params": [
                _num(v) for v in (it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z)
            ],
            "type": "SimpleItem",
        }
        for it in gcs.items
    ]
    home = gcs.home_latlon_deg or ((gcs.items[0].x, gcs.items[0].y) if gcs.items else (0.0, 0.0))
    doc = {
        "fileType": "Plan",
        "geoFence": {
            "circles": [
                {
                    "circle": {"center": list(c.centre_latlon_deg), "radius": c.radius_m},
                    "inclusion": c.inclusion,
                    "version": 1,
                }
                for c in gcs.circles
            ],
            "polygons": [
                {
                    "inclusion": p.inclusion,
                    "polygon": [list(v) for v in p.vertices_latlon_deg],
                    "version": 1,
                }
                for p in gcs.polygons
            ],
            "version": 2,
        },
        "groundStation": "QGroundControl",
        "mission": {
            "cruiseSpeed": cruise_speed_mps if cruise_speed_mps is not None else 0.6,
            "firmwareType": 3,  # MAV_AUTOPILOT_ARDUPILOTMEGA
            "globalPlanAltitudeMode": 1,
            "hoverSpeed": 5,
            "items": items,
            "plannedHomePosition": [home[0], home[1], gcs.home_alt_m or 0],
            "vehicleType": 10,  # MAV_TYPE_GROUND_ROVER
            "version": 2,
        },
        "rallyPoints": {"points": [], "version": 2},
        "version": 1,
        # what QGC has no key for (QGC ignores unknown keys); read back by helixd
        "helixd": {
            key: value
            for key, value in (("time_limit_s", gcs.time_limit_s), ("media_map", gcs.media_map))
            if value is not None
        },
    }
    return json.dumps(doc, indent=4, allow_nan=False) + "\n"
