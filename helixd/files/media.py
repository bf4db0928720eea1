"""Media map files: GeoJSON polygons tagged with the medium the rover is in there.

The format (RFC 7946 GeoJSON plus two optional top-level members)::

    {"type": "FeatureCollection",
     "frame": "global",            # optional: "global" (default) or "local_ned"
     "default_medium": "hard",     # optional: the medium outside every polygon
     "features": [
       {"type": "Feature", "properties": {"medium": "water"},
        "geometry": {"type": "Polygon", "coordinates": [[[lon, lat], ...]]}}, ...]}

* ``properties.medium``: one of hard, grass, sand, mud, water (other properties are kept out
  of the way: ``name`` and friends are allowed and ignored);
* geometry: Polygon or MultiPolygon; each ring closed (last position = first), at least 4
  positions; interior rings are holes;
* ``frame: global``: positions are GeoJSON's [lon, lat] (an altitude third is ignored);
  ``frame: local_ned``: positions are [east_m, north_m] from the EKF origin — x then y, in the
  same order as lon, lat;
* where polygons overlap, the later feature wins (:mod:`helixd.base.media`).

KML (``.kml``, lon,lat as Google Earth writes it) is read into the same checks: each
``<Placemark>`` is a feature, its medium in ``<ExtendedData>`` (:func:`media_map_from_kml`).

Hostile input: size-capped, parsed by :func:`helixd.files.jsonio.load_json_text`, bounded
counts, finite coordinates on the Earth (or within :data:`MAX_LOCAL_M`), every polygon at least
:data:`helixd.base.polygon.MIN_POLYGON_AREA_M2` and within :data:`MAX_EXTENT_M` of the map's
first vertex. Every problem is one line naming the file and the feature
(``pond.geojson: features.3.geometry.coordinates.0: ...``).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from helixd.base.frames import latlon_to_ne
from helixd.base.media import MediaArea, MediaFrame, MediaMap, Medium, Ring
from helixd.base.polygon import MIN_POLYGON_AREA_M2, signed_area_m2
from helixd.files.jsonio import JsonTextError, load_json_text
from helixd.files.kml import KmlRefused, kml_root, local_name
from helixd.files.yamlio import YamlFileError, clip, clip_line, read_text_capped

MAX_MEDIA_FILE_BYTES = 8 * 1024 * 1024
MAX_FEATURES = 1_000
MAX_POLYGONS = 2_000  # over all features (a MultiPolygon counts each part)
MAX_RINGS_PER_POLYGON = 101  # an outer ring and up to 100 holes
MAX_RING_VERTICES = 10_000
MAX_TOTAL_VERTICES = 100_000
MAX_LOCAL_M = 100_000.0  # |north|, |east| of a local_ned map
MAX_EXTENT_M = 100_000.0  # every vertex within this of the map's first: a site, not a country
MAX_PROBLEMS = 20
TOP_LEVEL_KEYS = frozenset({"type", "features", "frame", "default_medium", "name", "crs", "bbox"})
WGS84_CRS_NAMES = ("CRS84", "EPSG::4326", "EPSG:4326")
MEDIA = ", ".join(m.value for m in Medium)


class MediaMapError(ValueError):
    """The media map is unusable. ``problems``: one line each, naming the file and feature."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = [clip_line(p) for p in problems[:MAX_PROBLEMS]] or ["media map refused"]
        if len(problems) > MAX_PROBLEMS:
            self.problems.append(f"... and {len(problems) - MAX_PROBLEMS} more problems")
        self.message = self.problems[0]
        super().__init__("\n".join(self.problems))


class _Refused(Exception):
    """One problem in one feature: that feature is skipped, the others are still checked."""

    def __init__(self, line: str) -> None:
        self.line = line
        super().__init__(line)


class _Budget:
    def __init__(self) -> None:
        self.vertices = 0
        self.polygons = 0


def _is_number(v: Any) -> bool:
    return type(v) in (int, float)


def _position(raw: Any, where: str, frame: MediaFrame) -> tuple[float, float]:
    """A GeoJSON position → (lat, lon) or (north_m, east_m)."""
    if not isinstance(raw, list) or len(raw) not in (2, 3) or not all(map(_is_number, raw)):
        order = "[lon, lat]" if frame is MediaFrame.GLOBAL else "[east_m, north_m]"
        raise _Refused(f"{where}: expected a position {order} of numbers, got {clip(raw)}")
    x, y = float(raw[0]), float(raw[1])
    if not (math.isfinite(x) and math.isfinite(y)):
        raise _Refused(f"{where}: {clip(raw)} is not finite")
    if frame is MediaFrame.GLOBAL:
        if not (-180.0 <= x <= 180.0 and -90.0 <= y <= 90.0):
            raise _Refused(
                f"{where}: [lon, lat] {clip(raw)} is not on the Earth (lon -180..180, lat -90..90)"
            )
        return y, x
    if abs(x) > MAX_LOCAL_M or abs(y) > MAX_LOCAL_M:
        raise _Refused(f"{where}: [east_m, north_m] {clip(raw)} is beyond ±{MAX_LOCAL_M:.0f} m")
    return y, x


def _ring(raw: Any, where: str, frame: MediaFrame, budget: _Budget) -> Ring:
    if not isinstance(raw, list):
        raise _Refused(f"{where}: expected a ring (a list of positions), got {clip(raw)}")
    if len(raw) > MAX_RING_VERTICES + 1:
        raise _Refused(f"{where}: more than {MAX_RING_VERTICES} vertices in one ring")
    budget.vertices += len(raw)
    if budget.vertices > MAX_TOTAL_VERTICES:
        raise _Refused(f"{where}: more than {MAX_TOTAL_VERTICES} vertices in the map")
    pts = [_position(p, f"{where}.{k}", frame) for k, p in enumerate(raw)]
    if len(pts) < 4:
        raise _Refused(
            f"{where}: a ring needs at least 4 positions (3 corners and the first repeated), "
            f"got {len(pts)}"
        )
    if pts[0] != pts[-1]:
        raise _Refused(f"{where}: the ring is not closed (its last position must equal its first)")
    return tuple(pts[:-1])


def _ring_ne(ring: Ring, frame: MediaFrame, ref: tuple[float, float]) -> Ring:
    """The ring in metres around ``ref`` (the map's first vertex), to measure it."""
    if frame is MediaFrame.LOCAL_NED:
        return tuple((n - ref[0], e - ref[1]) for n, e in ring)
    return tuple(latlon_to_ne(lat, lon, ref[0], ref[1]) for lat, lon in ring)


def _hull_area_m2(ne: Ring) -> float:
    """The area of the ring's convex hull: zero only when every vertex is on one line."""
    from shapely.geometry import MultiPoint  # shapely loads only when a map is read

    return float(MultiPoint(ne).convex_hull.area)


def _refuse_self_intersection(rings: list[Ring], where: str, frame: MediaFrame) -> None:
    """A ring that crosses itself (a bow-tie, a figure of eight) or a hole crossing its outer
    ring: no inside can be told from outside there. Refused with where it crosses, in the
    file's own coordinates ([lon, lat] or [east_m, north_m]), from shapely's explain_validity."""
    from shapely.geometry import Polygon  # shapely loads only when a map is read
    from shapely.validation import explain_validity

    def xy(ring: Ring) -> list[tuple[float, float]]:  # the file's order: lon, lat / east, north
        return [(b, a) for a, b in ring]

    why = explain_validity(Polygon(xy(rings[0]), [xy(h) for h in rings[1:]]))
    if "self-intersection" not in why.lower():
        return
    at = why[why.find("[") + 1 : why.rfind("]")].split() if "[" in why else []
    order = "[lon, lat]" if frame is MediaFrame.GLOBAL else "[east_m, north_m]"
    place = f" at {order} [{', '.join(at)}]" if len(at) == 2 else ""
    raise _Refused(f"{where}: self-intersecting{place}: its edges cross ({why})")


def _polygon(
    raw: Any, where: str, frame: MediaFrame, budget: _Budget, ref: list[tuple[float, float]]
) -> tuple[Ring, tuple[Ring, ...]]:
    budget.polygons += 1
    if budget.polygons > MAX_POLYGONS:
        raise _Refused(f"{where}: more than {MAX_POLYGONS} polygons in the map")
    if not isinstance(raw, list) or not raw:
        raise _Refused(f"{where}: expected a list of rings (outer first, then holes)")
    if len(raw) > MAX_RINGS_PER_POLYGON:
        raise _Refused(f"{where}: more than {MAX_RINGS_PER_POLYGON - 1} holes in one polygon")
    rings = [_ring(r, f"{where}.{i}", frame, budget) for i, r in enumerate(raw)]
    if not ref:
        ref.append(rings[0][0])
    areas: list[float] = []
    for i, ring in enumerate(rings):
        ne = _ring_ne(ring, frame, ref[0])
        far = max(math.hypot(n, e) for n, e in ne)
        if far > MAX_EXTENT_M:
            raise _Refused(
                f"{where}.{i}: a vertex {far / 1000:.0f} km from the map's first vertex; a media "
                f"map covers a site (at most {MAX_EXTENT_M / 1000:.0f} km)"
            )
        if _hull_area_m2(ne) < MIN_POLYGON_AREA_M2:
            raise _Refused(
                f"{where}.{i}: its vertices span less than {MIN_POLYGON_AREA_M2} m² "
                "(degenerate or collinear ring)"
            )
        areas.append(abs(signed_area_m2(ne)))
    _refuse_self_intersection(rings, where, frame)
    for i, area in enumerate(areas):
        if area < MIN_POLYGON_AREA_M2:
            raise _Refused(
                f"{where}.{i}: area {area:.3g} m² is below {MIN_POLYGON_AREA_M2} m² "
                "(degenerate or collinear ring)"
            )
    return rings[0], tuple(rings[1:])


def _medium(props: Any, where: str) -> Medium:
    if props is None or not isinstance(props, dict):
        raise _Refused(f"{where}.properties: expected an object with a 'medium' (one of {MEDIA})")
    value = props.get("medium")
    if not isinstance(value, str) or value not in Medium.__members__.values():
        raise _Refused(f"{where}.properties.medium: {clip(value)}; allowed: {MEDIA}")
    return Medium(value)


def _feature(
    raw: Any, index: int, src: str, frame: MediaFrame, budget: _Budget, ref: list[Any]
) -> list[MediaArea]:
    where = f"{src}: features.{index}"
    if not isinstance(raw, dict) or raw.get("type") != "Feature":
        raise _Refused(f"{where}: expected a GeoJSON Feature object, got {clip(raw)}")
    medium = _medium(raw.get("properties"), where)
    geom = raw.get("geometry")
    if not isinstance(geom, dict):
        raise _Refused(f"{where}.geometry: expected a Polygon or MultiPolygon, got {clip(geom)}")
    kind = geom.get("type")
    coords = geom.get("coordinates")
    gwhere = f"{where}.geometry.coordinates"
    if kind == "Polygon":
        parts = [(coords, gwhere)]
    elif kind == "MultiPolygon":
        if not isinstance(coords, list) or not coords:
            raise _Refused(f"{gwhere}: expected a non-empty list of polygons")
        parts = [(c, f"{gwhere}.{i}") for i, c in enumerate(coords[: MAX_POLYGONS + 1])]
    else:
        raise _Refused(f"{where}.geometry.type: {clip(kind)}; allowed: Polygon, MultiPolygon")
    areas: list[MediaArea] = []
    for part, pwhere in parts:
        outer, holes = _polygon(part, pwhere, frame, budget, ref)
        areas.append(MediaArea(medium, outer, holes, index))
    return areas


def _top_level(raw: Any, src: str) -> tuple[MediaFrame, Medium | None, list[Any]]:
    if not isinstance(raw, dict) or raw.get("type") != "FeatureCollection":
        got = raw.get("type") if isinstance(raw, dict) else type(raw).__name__
        raise MediaMapError([f"{src}: expected a GeoJSON FeatureCollection, got {clip(got)}"])
    unknown = sorted(set(raw) - TOP_LEVEL_KEYS)
    if unknown:
        raise MediaMapError(
            [
                f"{src}: unknown top-level member {clip(unknown[0], 40)}; allowed: "
                + ", ".join(sorted(TOP_LEVEL_KEYS))
            ]
        )
    frame_raw = raw.get("frame", MediaFrame.GLOBAL.value)
    if frame_raw not in MediaFrame.__members__.values():
        raise MediaMapError([f"{src}: frame: {clip(frame_raw)}; allowed: global, local_ned"])
    frame = MediaFrame(frame_raw)
    crs = raw.get("crs")
    if crs is not None:
        props = crs.get("properties") if isinstance(crs, dict) else None
        name = props.get("name") if isinstance(props, dict) else None
        names_wgs84 = isinstance(name, str) and any(n in name for n in WGS84_CRS_NAMES)
        if not names_wgs84 or frame is not MediaFrame.GLOBAL:
            raise MediaMapError(
                [f"{src}: crs: {clip(crs)}; a global media map is WGS 84 lon/lat (CRS84) only"]
            )
    default = raw.get("default_medium")
    if default is not None and default not in Medium.__members__.values():
        raise MediaMapError([f"{src}: default_medium: {clip(default)}; allowed: {MEDIA}"])
    feats = raw.get("features")
    if not isinstance(feats, list):
        raise MediaMapError([f"{src}: features: expected a list of Features"])
    if len(feats) > MAX_FEATURES:
        raise MediaMapError([f"{src}: {len(feats)} features; at most {MAX_FEATURES}"])
    return frame, None if default is None else Medium(default), feats


def media_map_from_obj(raw: Any, src: str) -> MediaMap:
    """A parsed GeoJSON object → :class:`MediaMap` (pure). Raises :class:`MediaMapError` with
    one line per refused feature (at most :data:`MAX_PROBLEMS`)."""
    frame, default, feats = _top_level(raw, src)
    budget = _Budget()
    ref: list[tuple[float, float]] = []
    areas: list[MediaArea] = []
    problems: list[str] = []
    for i, feat in enumerate(feats):
        try:
            areas.extend(_feature(feat, i, src, frame, budget, ref))
        except _Refused as exc:
            problems.append(exc.line)
            if budget.vertices > MAX_TOTAL_VERTICES or budget.polygons > MAX_POLYGONS:
                break
    if problems:
        raise MediaMapError(problems)
    if not areas and default is None:
        raise MediaMapError([f"{src}: no features and no default_medium: the map says nothing"])
    return MediaMap(frame=frame, areas=tuple(areas), default_medium=default, source=src)


def media_map_from_text(text: str, src: str) -> MediaMap:
    """GeoJSON text → :class:`MediaMap` (pure; hostile-input JSON rules)."""
    try:
        raw = load_json_text(text.removeprefix("\ufeff"), src, kind="GeoJSON media map")
    except JsonTextError as exc:
        raise MediaMapError([exc.message]) from None
    return media_map_from_obj(raw, src)


def _kml_ring(text: str | None) -> list[Any]:
    """``lon,lat[,alt]`` tuples → GeoJSON positions; a token that is not one is kept as its
    text, for the GeoJSON checks to name."""
    out: list[Any] = []
    for token in (text or "").split()[: MAX_RING_VERTICES + 2]:
        parts = token.split(",")
        try:
            if len(parts) not in (2, 3) or any(len(p) > 40 for p in parts):
                raise ValueError
            out.append([float(p) for p in parts[:2]])
        except ValueError:
            out.append(clip(token, 60))
    return out


def _kml_medium(placemark: ET.Element) -> Any:
    for el in placemark.iter():
        if local_name(el.tag) == "Data" and el.get("name") == "medium":
            value = next((c.text for c in el if local_name(c.tag) == "value"), None)
            return (value or "").strip()
        if local_name(el.tag) == "SimpleData" and el.get("name") == "medium":
            return (el.text or "").strip()
    return None


def _kml_polygon(polygon: ET.Element) -> list[Any]:
    outer: list[Any] = []
    holes: list[Any] = []
    for child in polygon:
        name = local_name(child.tag)
        if name not in ("outerBoundaryIs", "innerBoundaryIs"):
            continue
        coords = next((el.text for el in child.iter() if local_name(el.tag) == "coordinates"), None)
        (outer if name == "outerBoundaryIs" else holes).append(_kml_ring(coords))
    return outer[:1] + holes if len(outer) == 1 else []


def media_map_from_kml(text: str, src: str) -> MediaMap:
    """KML text → :class:`MediaMap` (pure; global frame). Each ``<Placemark>`` is a feature:
    its ``<Polygon>`` elements (also inside ``<MultiGeometry>``) and its medium in
    ``<ExtendedData>`` (``<Data name="medium"><value>water</value></Data>`` or a
    ``<SimpleData name="medium">``). DOCTYPE and entity declarations are refused before
    parsing (no entity expansion can happen). Problems name ``Placemark N`` (from 0)."""
    try:
        root = kml_root(text, src)
    except KmlRefused as exc:
        raise MediaMapError([str(exc)]) from None
    features: list[Any] = []
    for placemark in (el for el in root.iter() if local_name(el.tag) == "Placemark"):
        if len(features) > MAX_FEATURES:
            break
        polygons = [_kml_polygon(el) for el in placemark.iter() if local_name(el.tag) == "Polygon"]
        features.append(
            {
                "type": "Feature",
                "properties": {"medium": _kml_medium(placemark)},
                "geometry": {"type": "MultiPolygon", "coordinates": polygons},
            }
        )
    try:
        return media_map_from_obj({"type": "FeatureCollection", "features": features}, src)
    except MediaMapError as exc:
        raise MediaMapError(
            [
                p.replace(f"{src}: features.", f"{src}: Placemark ", 1)
                .replace(".geometry.coordinates", " Polygon", 1)
                .replace(".properties.medium", " ExtendedData medium", 1)
                for p in exc.problems
            ]
        ) from None


def read_media_map(path: Path | str) -> MediaMap:
    """Read a media map file (``.geojson``/``.json``, or ``.kml``)."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".geojson", ".json", ".kml"):
        raise MediaMapError(
            [
                f"{p}: unknown media map file type {p.suffix or '(none)'!r}; allowed: .geojson, "
                ".json, .kml"
            ]
        )
    try:
        text = read_text_capped(p, MAX_MEDIA_FILE_BYTES).removeprefix("\ufeff")
    except YamlFileError as exc:
        raise MediaMapError([exc.message.replace("YAML file", "media map")]) from None
    if suffix == ".kml":
        return media_map_from_kml(text, str(p))
    return media_map_from_text(text, str(p))


__all__ = [
    "MAX_FEATURES",
    "MAX_RING_VERTICES",
    "MediaMapError",
    "media_map_from_kml",
    "media_map_from_obj",
    "media_map_from_text",
    "read_media_map",
]
