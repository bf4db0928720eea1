"""Survey areas: one polygon (lat/lon) with holes, read from a QGroundControl ``.plan``, GeoJSON
or KML file. Every file is hostile input: size-capped, no XML DTD/entities, finite coordinates
on the Earth, bounded vertex counts; a problem names the file and the element.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from helixd.files.kml import KmlRefused, kml_root, local_name
from helixd.files.yamlio import YamlFileError, clip, read_text_capped
from helixd.mission.formats.items import FormatError, check_latlon
from helixd.mission.formats.qgc_plan import load_plan_json, parse_plan_text

MAX_VERTICES = 10_000  # per ring
MAX_HOLES = 1_000
CIRCLE_SEGMENTS = 64  # an exclusion circle becomes a 64-gon (inscribed polygon grown to cover)

Ring = tuple[tuple[float, float], ...]  # (lat, lon) vertices, not closed


@dataclass(frozen=True, slots=True)
class SurveyArea:
    """The area to cover: an outer ring and holes (lat/lon degrees); exclusion circles are
    kept as (centre, radius_m) and cut out by the survey in metres."""

    outer: Ring
    holes: tuple[Ring, ...] = ()
    hole_circles: tuple[tuple[tuple[float, float], float], ...] = ()
    source: str = ""


def _ring(points: list[tuple[float, float]], where: str) -> Ring:
    if len(points) > MAX_VERTICES + 1:
        raise FormatError([f"{where}: more than {MAX_VERTICES} vertices"])
    problems: list[str] = []
    for k, (lat, lon) in enumerate(points):
        problems += check_latlon(f"{where}.{k}", lat, lon)
    if problems:
        raise FormatError(problems[:10])
    if len(points) > 1 and points[0] == points[-1]:
        points = points[:-1]  # GeoJSON/KML rings repeat the first vertex
    if len(points) < 3:
        raise FormatError([f"{where}: a polygon needs at least 3 vertices, got {len(points)}"])
    return tuple(points)


def area_from_plan(text: str, src: str) -> SurveyArea:
    """The Survey item's polygon if the plan has exactly one, else its one inclusion geofence
    polygon; exclusion polygons and circles of the geofence are holes."""
    gcs = parse_plan_text(text, src, areas_only=True)  # a hand-written Survey: its polygon
    inclusions = [p for p in gcs.polygons if p.inclusion]
    if len(gcs.survey_polygons) == 1:
        outer = gcs.survey_polygons[0]
        where = "the Survey item's polygon"
    elif len(inclusions) == 1 and not gcs.survey_polygons:
        outer = inclusions[0].vertices_latlon_deg
        where = "the inclusion geofence polygon"
    else:
        raise FormatError(
            [
                f"{src}: {len(gcs.survey_polygons)} Survey polygons and {len(inclusions)} "
                "inclusion geofence polygons: need exactly one Survey polygon, or no Survey and "
                "exactly one inclusion polygon"
            ]
        )
    return SurveyArea(
        outer=_ring(list(outer), f"{src}: {where}"),
        holes=tuple(
            _ring(list(p.vertices_latlon_deg), f"{src}: exclusion polygon {i}")
            for i, p in enumerate(gcs.polygons)
            if not p.inclusion
        ),
        hole_circles=tuple(
            (c.centre_latlon_deg, c.radius_m) for c in gcs.circles if not c.inclusion
        ),
        source=src,
    )


def _lonlat_ring(raw: Any, where: str) -> Ring:
    if not isinstance(raw, list):
        raise FormatError([f"{where}: expected a list of [lon, lat] positions"])
    if len(raw) > MAX_VERTICES + 1:
        raise FormatError([f"{where}: more than {MAX_VERTICES} vertices"])
    pts: list[tuple[float, float]] = []
    for k, pos in enumerate(raw):
        if (
            not isinstance(pos, list)
            or len(pos) not in (2, 3)
            or not all(type(v) in (int, float) for v in pos)
        ):
            raise FormatError([f"{where}.{k}: expected [lon, lat] numbers, got {clip(pos)}"])
        pts.append((float(pos[1]), float(pos[0])))  # GeoJSON is lon, lat
    return _ring(pts, where)


def _geojson_polygons(obj: Any, where: str, out: list[tuple[Any, str]]) -> None:
    if not isinstance(obj, dict):
        raise FormatError([f"{where}: expected a GeoJSON object, got {type(obj).__name__}"])
    kind = obj.get("type")
    if kind == "FeatureCollection":
        feats = obj.get("features")
        if not isinstance(feats, list):
            raise FormatError([f"{where}.features: expected a list"])
        for i, f in enumerate(feats[:MAX_HOLES]):
            _geojson_polygons(f, f"{where}.features.{i}", out)
    elif kind == "Feature":
        _geojson_polygons(obj.get("geometry"), f"{where}.geometry", out)
    elif kind == "Polygon":
        out.append((obj.get("coordinates"), f"{where}.coordinates"))
    elif kind == "MultiPolygon":
        coords = obj.get("coordinates")
        if not isinstance(coords, list):
            raise FormatError([f"{where}.coordinates: expected a list"])
        out.extend((c, f"{where}.coordinates.{i}") for i, c in enumerate(coords))
    else:
        raise FormatError(
            [
                f"{where}.type: {clip(kind)}; allowed: Polygon, MultiPolygon, Feature, "
                "FeatureCollection"
            ]
        )


def area_from_geojson(text: str, src: str) -> SurveyArea:
    """Exactly one Polygon (RFC 7946, [lon, lat]); its interior rings are holes."""
    raw = load_plan_json(text, src)
    polys: list[tuple[Any, str]] = []
    _geojson_polygons(raw, src, polys)
    if len(polys) != 1:
        raise FormatError([f"{src}: {len(polys)} polygons; a survey area is exactly one"])
    rings, where = polys[0]
    if not isinstance(rings, list) or not rings or len(rings) > MAX_HOLES + 1:
        raise FormatError([f"{where}: expected a list of rings (outer first, then holes)"])
    return SurveyArea(
        outer=_lonlat_ring(rings[0], f"{where}.0"),
        holes=tuple(_lonlat_ring(r, f"{where}.{i}") for i, r in enumerate(rings[1:], start=1)),
        source=src,
    )


def _kml_coords(text: str | None, where: str) -> Ring:
    tokens = (text or "").split()
    if len(tokens) > MAX_VERTICES + 1:
        raise FormatError([f"{where}: more than {MAX_VERTICES} vertices"])
    pts: list[tuple[float, float]] = []
    for k, tok in enumerate(tokens):
        parts = tok.split(",")
        try:
            if len(parts) not in (2, 3) or any(len(p) > 40 for p in parts):
                raise ValueError
            lon, lat = float(parts[0]), float(parts[1])
        except ValueError:
            raise FormatError([f"{where}.{k}: {clip(tok, 60)} is not lon,lat[,alt]"]) from None
        if not (math.isfinite(lat) and math.isfinite(lon)):
            raise FormatError([f"{where}.{k}: {clip(tok, 60)} is not finite"])
        pts.append((lat, lon))
    return _ring(pts, where)


def area_from_kml(text: str, src: str) -> SurveyArea:
    """Exactly one ``<Polygon>``: outerBoundaryIs and innerBoundaryIs LinearRings. DOCTYPE and
    entity declarations are refused before parsing (no entity expansion can happen)."""
    try:
        root = kml_root(text, src)
    except KmlRefused as exc:
        raise FormatError([str(exc)]) from None
    polys = [el for el in root.iter() if local_name(el.tag) == "Polygon"]
    if len(polys) != 1:
        raise FormatError([f"{src}: {len(polys)} <Polygon> elements; a survey area is exactly one"])
    outer: Ring | None = None
    holes: list[Ring] = []
    for child in polys[0]:
        name = local_name(child.tag)
        if name not in ("outerBoundaryIs", "innerBoundaryIs"):
            continue
        coords = [el for el in child.iter() if local_name(el.tag) == "coordinates"]
        if len(coords) != 1:
            raise FormatError([f"{src}: {name} needs one LinearRing with <coordinates>"])
        if name == "outerBoundaryIs":
            if outer is not None:
                raise FormatError([f"{src}: two outerBoundaryIs in one Polygon"])
            outer = _kml_coords(coords[0].text, f"{src}: outerBoundaryIs")
        else:
            holes.append(_kml_coords(coords[0].text, f"{src}: innerBoundaryIs {len(holes)}"))
    if outer is None:
        raise FormatError([f"{src}: the Polygon has no outerBoundaryIs"])
    return SurveyArea(outer=outer, holes=tuple(holes), source=src)


def read_area(path: Path) -> SurveyArea:
    """A survey polygon from ``.plan``, ``.geojson``/``.json`` or ``.kml``."""
    try:
        text = read_text_capped(path).removeprefix("\ufeff")  # Windows tools write a BOM
    except YamlFileError as exc:
        raise FormatError([exc.message.replace("YAML file", "polygon file")]) from None
    src = str(path)
    suffix = path.suffix.lower()
    if suffix == ".plan":
        return area_from_plan(text, src)
    if suffix in (".geojson", ".json"):
        return area_from_geojson(text, src)
    if suffix == ".kml":
        return area_from_kml(text, src)
    raise FormatError(
        [
            f"{src}: unknown polygon file type {suffix or '(none)'!r}; allowed: .plan, .geojson, "
            ".json, .kml"
        ]
    )
