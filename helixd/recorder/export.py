"""``helixd export RUN_DIR --geojson|--kml``: the planned path and the flown track in lat/lon.

The run directory holds ``mission.yaml``, ``config.yaml``, ``flight.csv`` (NED pose from the
EKF origin per control step) and ``summary.json`` (the EKF origin the autopilot reported at
preflight, recorded for every run where it had one). Without a recorded origin the NED track
has no place on the Earth: the export says so and exits 2. Waypoints are numbered from 1 (the
operator's, as a ground station numbers them); the planner's via points are marked ``via``.
Points go through the same EKF map as in flight
(:func:`helixd.base.frames.ne_to_latlon`), so the track lands where the autopilot's GPS put it.

Pure core (:func:`build_export`, :func:`to_geojson`, :func:`to_kml`); the CLI reads and writes.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape

import numpy as np
import numpy.typing as npt

from helixd.base.frames import MissionFrame, NedPose, ne_to_latlon
from helixd.base.plan import MissionFrameKind, Numbering, operator_numbers
from helixd.base.run_files import (
    CONFIG_FILE,
    FLIGHT_FILE,
    MISSION_FILE,
    SUMMARY_FILE,
)
from helixd.config.load import load_config
from helixd.config.root import HelixdConfig
from helixd.files.models import ConfigFileError
from helixd.mission.model import Mission, load_mission
from helixd.recorder.resume_dir import run_numbering
from helixd.recorder.rows import read_flight_columns
from helixd.recorder.summary import RunSummary

LatLon = tuple[float, float]
DEFAULT_MIN_STEP_M = 0.1  # the flown track keeps a point each time the rover moved this far
COORD_DECIMALS = 8  # 1e-8 degree ~ 1 mm


class ExportError(Exception):
    """The run cannot be exported; the message says why (one line)."""


@dataclass(frozen=True, slots=True)
class ExportData:
    name: str
    planned: tuple[LatLon, ...]
    flown: tuple[LatLon, ...]
    fence: tuple[LatLon, ...]
    origin: LatLon
    numbers: tuple[int, ...] = ()  # per planned point: the operator's number (1-based)
    vias: tuple[bool, ...] = ()  # per planned point: a via point the planner inserted
    keep_outs: tuple[tuple[LatLon, ...], ...] = ()


def _start_frame(cols: dict[str, npt.NDArray[Any]]) -> MissionFrame | None:
    """The start frame, recovered from the first row with both poses (x, y, yaw = f(NED))."""
    keys = ("north_m", "east_m", "yaw_ned_rad", "x_m", "y_m", "yaw_rad")
    if not all(k in cols for k in keys):
        return None
    for i in range(len(cols["north_m"])):
        n, e, yn, x, y, yaw = (float(cols[k][i]) for k in keys)
        if all(math.isfinite(v) for v in (n, e, yn, x, y, yaw)):
            oyaw = yn + yaw
            c, s = math.cos(oyaw), math.sin(oyaw)
            return MissionFrame.start_at(
                NedPose(north_m=n - (x * c + y * s), east_m=e - (x * s - y * c), yaw_ned_rad=oyaw)
            )
    return None


def build_export(
    mission: Mission,
    origin: LatLon,
    cols: dict[str, npt.NDArray[Any]],
    min_step_m: float = DEFAULT_MIN_STEP_M,
    numbering: Numbering | None = None,
) -> ExportData:
    """Planned waypoints and the flown track (decimated to ``min_step_m``) in lat/lon;
    ``numbering``: the run's (a resumed run continues the mission's count)."""
    north = np.asarray(cols.get("north_m", []), dtype=np.float64)
    east = np.asarray(cols.get("east_m", []), dtype=np.float64)
    flown: list[LatLon] = []
    last: tuple[float, float] | None = None
    for n, e in zip(north, east, strict=True):
        if not (math.isfinite(n) and math.isfinite(e)):
            continue
        if last is not None and math.hypot(n - last[0], e - last[1]) < min_step_m:
            continue
        last = (float(n), float(e))
        flown.append(ne_to_latlon(float(n), float(e), *origin))
    if last is not None and len(north) and math.isfinite(north[-1]) and math.isfinite(east[-1]):
        end = ne_to_latlon(float(north[-1]), float(east[-1]), *origin)
        if flown[-1] != end:
            flown.append(end)
    pts = mission.points()
    keep_outs: list[tuple[LatLon, ...]] = []
    if mission.frame is MissionFrameKind.GLOBAL:
        planned = [(a, b) for a, b in pts]
        fence = list(mission.geofence_polygon)
        keep_outs = [tuple(p) for p in mission.keep_out_polygons]
    elif mission.frame is MissionFrameKind.LOCAL_NED:
        planned = [ne_to_latlon(a, b, *origin) for a, b in pts]
        fence = [ne_to_latlon(a, b, *origin) for a, b in mission.geofence_polygon]
        keep_outs = [
            tuple(ne_to_latlon(a, b, *origin) for a, b in p) for p in mission.keep_out_polygons
        ]
    else:
        frame = _start_frame(cols)
        if frame is None:
            raise ExportError("start-frame mission but no row with a pose: cannot place the plan")
        planned = [ne_to_latlon(*frame.to_ned(x, y), *origin) for x, y in pts]
        fence = [ne_to_latlon(*frame.to_ned(x, y), *origin) for x, y in mission.geofence_polygon]
    vias = [w.via for w in mission.waypoints]
    return ExportData(
        mission.name,
        tuple(planned),
        tuple(flown),
        tuple(fence),
        origin,
        numbering.numbers if numbering is not None else operator_numbers(vias),
        numbering.vias if numbering is not None else tuple(vias),
        tuple(keep_outs),
    )


def _number(data: ExportData, i: int) -> int:
    return data.numbers[i] if i < len(data.numbers) else i + 1


def _is_via(data: ExportData, i: int) -> bool:
    return i < len(data.vias) and data.vias[i]


def _point_name(data: ExportData, i: int) -> str:
    """``waypoint 3`` (the operator's number), ``via → 3`` for a via point on the leg to it."""
    number = _number(data, i)
    return f"via → {number}" if _is_via(data, i) else f"waypoint {number}"


def _pos(p: LatLon) -> list[float]:
    return [round(p[1], COORD_DECIMALS), round(p[0], COORD_DECIMALS)]  # GeoJSON: lon, lat


def to_geojson(data: ExportData) -> str:
    """RFC 7946 FeatureCollection: planned LineString, flown LineString, waypoints, fence."""
    feats: list[dict[str, object]] = [
        {
            "type": "Feature",
            "properties": {"name": f"{data.name} planned", "kind": "planned"},
            "geometry": {"type": "LineString", "coordinates": [_pos(p) for p in data.planned]},
        }
    ]
    if len(data.flown) >= 2:
        feats.append(
            {
                "type": "Feature",
                "properties": {"name": f"{data.name} flown", "kind": "flown"},
                "geometry": {"type": "LineString", "coordinates": [_pos(p) for p in data.flown]},
            }
        )
    feats.extend(
        {
            "type": "Feature",
            "properties": {
                "name": _point_name(data, i),
                "kind": "via" if _is_via(data, i) else "waypoint",
                "number": _number(data, i),
            },
            "geometry": {"type": "Point", "coordinates": _pos(p)},
        }
        for i, p in enumerate(data.planned)
    )
    feats.extend(
        {
            "type": "Feature",
            "properties": {"name": f"{data.name} keep-out {k + 1}", "kind": "keep_out"},
            "geometry": {"type": "Polygon", "coordinates": [[_pos(p) for p in (*ring, ring[0])]]},
        }
        for k, ring in enumerate(data.keep_outs)
        if ring
    )
    if data.fence:
        ring = [_pos(p) for p in (*data.fence, data.fence[0])]
        feats.append(
            {
                "type": "Feature",
                "properties": {"name": f"{data.name} geofence", "kind": "geofence"},
                "geometry": {"type": "Polygon", "coordinates": [ring]},
            }
        )
    doc = {"type": "FeatureCollection", "features": feats}
    return json.dumps(doc, allow_nan=False) + "\n"


def _kml_coords(points: tuple[LatLon, ...] | list[LatLon]) -> str:
    return " ".join(
        f"{round(p[1], COORD_DECIMALS)},{round(p[0], COORD_DECIMALS)},0" for p in points
    )


def to_kml(data: ExportData) -> str:
    """KML 2.2 document: planned path (blue), flown track (red), waypoints, geofence."""
    name = escape(data.name)
    marks = [
        f"<Placemark><name>{name} planned</name><styleUrl>#planned</styleUrl><LineString>"
        f"<tessellate>1</tessellate><coordinates>{_kml_coords(data.planned)}</coordinates>"
        "</LineString></Placemark>"
    ]
    if len(data.flown) >= 2:
        marks.append(
            f"<Placemark><name>{name} flown</name><styleUrl>#flown</styleUrl><LineString>"
            f"<tessellate>1</tessellate><coordinates>{_kml_coords(data.flown)}</coordinates>"
            "</LineString></Placemark>"
        )
    marks.extend(
        f"<Placemark><name>{escape(_point_name(data, i))}</name><Point><coordinates>"
        f"{_kml_coords([p])}</coordinates></Point></Placemark>"
        for i, p in enumerate(data.planned)
    )
    marks.extend(
        f"<Placemark><name>{name} keep-out {k + 1}</name><Polygon><outerBoundaryIs><LinearRing>"
        f"<coordinates>{_kml_coords([*ring, ring[0]])}</coordinates></LinearRing>"
        "</outerBoundaryIs></Polygon></Placemark>"
        for k, ring in enumerate(data.keep_outs)
        if ring
    )
    if data.fence:
        ring = _kml_coords([*data.fence, data.fence[0]])
        marks.append(
            f"<Placemark><name>{name} geofence</name><Polygon><outerBoundaryIs><LinearRing>"
            f"<coordinates>{ring}</coordinates></LinearRing></outerBoundaryIs></Polygon>"
            "</Placemark>"
        )
    styles = (
        '<Style id="planned"><LineStyle><color>ffff0000</color><width>2</width></LineStyle>'
        "</Style>"
        '<Style id="flown"><LineStyle><color>ff0000ff</color><width>2</width></LineStyle></Style>'
    )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<kml xmlns="http://www.opengis.net/kml/2.2"><Document>'
        f"<name>{name}</name>{styles}{''.join(marks)}</Document></kml>\n"
    )


def load_run_export(run_dir: Path, min_step_m: float = DEFAULT_MIN_STEP_M) -> ExportData:
    """Read the run directory; raise :class:`ExportError` with the reason."""
    try:
        summary = RunSummary.from_json((run_dir / SUMMARY_FILE).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ExportError(
            f"{run_dir}: no {SUMMARY_FILE}, so no recorded EKF origin: the track cannot be "
            "placed in latitude/longitude"
        ) from None
    except (OSError, ValueError) as exc:
        raise ExportError(f"{run_dir / SUMMARY_FILE}: unreadable ({exc})") from None
    origin = summary.origin_latlon_deg
    if origin is None:
        raise ExportError(
            f"{run_dir}: no EKF origin was recorded in {SUMMARY_FILE} (the autopilot reported "
            "none at preflight, or an older helixd recorded it for global missions only): the "
            "track cannot be placed in latitude/longitude"
        )
    try:
        cfg = load_config(run_dir / CONFIG_FILE)
    except ConfigFileError:
        cfg = HelixdConfig()
    try:
        mission = load_mission(run_dir / MISSION_FILE, cfg.mission)
    except ConfigFileError as exc:
        raise ExportError("; ".join(exc.problems)) from None
    flight = run_dir / FLIGHT_FILE
    cols = read_flight_columns(flight) if flight.exists() else {}
    numbering = run_numbering(run_dir, [w.via for w in mission.waypoints])
    return build_export(mission, origin, cols, min_step_m, numbering)
