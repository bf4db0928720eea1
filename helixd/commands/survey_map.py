"""``helixd survey-map``: the depth map a crew takes home from one or more survey runs.

The readings of the runs' ``payload.csv`` (one quantity, ``depth_m`` by default) are placed
in one north/east frame around a reference (the area's first vertex, else the first reading)
by ArduPilot's flat-earth map, gridded (:mod:`helixd.planning.depth_grid`: block means, then
a thin-plate spline through them), and written to the output directory:

* ``depth.tif``: the depth grid as a GeoTIFF (float32, EPSG:4326, north up, NaN = no value;
  GeoKeys written with tifffile, so GDAL, QGIS and rasterio read it placed);
* ``depth.csv``: one row per cell of the area or with data: x (east), y (north), lon, lat, z
  (the gridded depth), the cell's reading count, spread (standard deviation) and block mean;
* ``contours.geojson`` (LineStrings in lon/lat, property ``depth_m``) and ``map.png`` (the
  grid, the contours, the surveyed area, the media map and the holes);
* ``holes.yaml``: a global mission through the centre of every cell of the area without a
  reading (each row's run of holes one leg), for the crew to upload and fill them;
* ``survey-map.json``: the figures (samples, cells, coverage, holes, the mission's items).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import contourpy
import matplotlib

matplotlib.use("Agg")  # no display on the rover

import numpy as np
import tifffile
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from shapely.geometry import Polygon

from helixd.base.frames import METRES_PER_DEGREE, latlon_to_ne, ne_to_latlon
from helixd.base.media import MediaMap
from helixd.base.plan import MotionMode
from helixd.base.problems import Problems
from helixd.base.run_files import PAYLOAD_FILE
from helixd.mission.formats import write_mission_file
from helixd.mission.formats.areas import SurveyArea
from helixd.mission.model import Mission
from helixd.planning.depth_grid import (
    DepthGrid,
    GridError,
    HoleLeg,
    grid_depths,
    hole_legs,
    hole_waypoints,
)
from helixd.recorder.payload_log import PayloadCsvError, read_payload_quantity

DPI = 110
# GeoTIFF tags (GeoTIFF 1.0 / OGC 19-008r4)
MODEL_PIXEL_SCALE = 33550
MODEL_TIEPOINT = 33922
GEO_KEY_DIRECTORY = 34735
GDAL_NODATA = 42113
GT_MODEL_TYPE_GEOGRAPHIC = 2
GT_RASTER_PIXEL_IS_AREA = 1
EPSG_WGS84 = 4326
GEO_KEYS = (
    (1024, 0, 1, GT_MODEL_TYPE_GEOGRAPHIC),  # GTModelTypeGeoKey
    (1025, 0, 1, GT_RASTER_PIXEL_IS_AREA),  # GTRasterTypeGeoKey
    (2048, 0, 1, EPSG_WGS84),  # GeographicTypeGeoKey
)


class SurveyMapRefused(Problems, ValueError):
    """The map cannot be made; ``problems`` has one line each."""


@dataclass(frozen=True)
class SurveyMap:
    grid: DepthGrid
    reference_latlon: tuple[float, float]  # the north/east frame's origin
    area_ne: Polygon | None  # x east, y north
    legs: list[HoleLeg]
    quantity: str
    skipped: int  # rows of the quantity without place or value

    def to_latlon(self, north_m: float, east_m: float) -> tuple[float, float]:
        return ne_to_latlon(north_m, east_m, *self.reference_latlon)

    def holes_latlon(self) -> list[tuple[float, float]]:
        return [self.to_latlon(n, e) for n, e in hole_waypoints(self.legs)]


def payload_paths(runs: list[Path]) -> list[Path]:
    """Each run's payload.csv (a run directory, or the file itself)."""
    out: list[Path] = []
    missing: list[Path] = []
    for run in runs:
        path = run / PAYLOAD_FILE if run.is_dir() else run
        (out if path.is_file() else missing).append(path)
    if missing:
        raise SurveyMapRefused(
            [f"{p}: no such file (a run directory with {PAYLOAD_FILE}?)" for p in missing]
        )
    return out


def area_polygon(area: SurveyArea, reference: tuple[float, float]) -> Polygon:
    """The survey area (lat/lon rings) in north/east metres around ``reference`` (x east)."""

    def ring(r: tuple[tuple[float, float], ...]) -> list[tuple[float, float]]:
        return [latlon_to_ne(lat, lon, *reference)[::-1] for lat, lon in r]

    return Polygon(ring(area.outer), [ring(h) for h in area.holes])


def build_map(
    runs: list[Path], *, cell_m: float, area: SurveyArea | None, quantity: str = "depth_m"
) -> SurveyMap:
    """Read the runs' readings of ``quantity`` and grid them (:class:`SurveyMapRefused`)."""
    try:
        got = read_payload_quantity(payload_paths(runs), quantity)
    except PayloadCsvError as exc:
        raise SurveyMapRefused(exc.problems) from None
    if got.value.size == 0 and area is None:
        raise SurveyMapRefused([f"no {quantity} readings with a place in {len(runs)} run(s)"])
    if area is not None:
        reference = area.outer[0]
    else:
        reference = (float(got.lat_deg[0]), float(got.lon_deg[0]))
    pairs = zip(got.lat_deg, got.lon_deg, strict=True)
    ne = [latlon_to_ne(float(a), float(b), *reference) for a, b in pairs]
    north = np.array([p[0] for p in ne], dtype=float)
    east = np.array([p[1] for p in ne], dtype=float)
    poly = None if area is None else area_polygon(area, reference)
    try:
        grid = grid_depths(north, east, got.value, cell_m, poly)
    except GridError as exc:
        raise SurveyMapRefused([str(exc)]) from None
    return SurveyMap(grid, reference, poly, hole_legs(grid), quantity, got.skipped)


def write_geotiff(m: SurveyMap, path: Path) -> None:
    """The grid as a north-up float32 GeoTIFF in EPSG:4326 (pixel is area)."""
    fr = m.grid.frame
    lat_top, lon_left = m.to_latlon(fr.north0_m + fr.rows * fr.cell_m, fr.east0_m)
    lat_mid = m.reference_latlon[0]
    dlat = fr.cell_m / METRES_PER_DEGREE
    dlon = fr.cell_m / (METRES_PER_DEGREE * math.cos(math.radians(lat_mid)))
    keys = [1, 1, 0, len(GEO_KEYS)] + [v for key in GEO_KEYS for v in key]
    tifffile.imwrite(
        path,
        np.flipud(m.grid.depth_m).astype(np.float32),
        photometric="minisblack",
        extratags=[
            (MODEL_PIXEL_SCALE, "d", 3, (dlon, dlat, 0.0), True),
            (MODEL_TIEPOINT, "d", 6, (0.0, 0.0, 0.0, lon_left, lat_top, 0.0), True),
            (GEO_KEY_DIRECTORY, "H", len(keys), tuple(keys), True),
            (GDAL_NODATA, "s", 0, "nan", True),
        ],
    )


def write_cells_csv(m: SurveyMap, path: Path) -> int:
    """x y z per cell of the area or with data, with count, spread and block mean."""
    g = m.grid
    cn, ce = g.frame.centres()
    rows = 0
    lines = ["x_east_m,y_north_m,lon_deg,lat_deg,z_depth_m,count,spread_m,mean_m,in_area"]
    for i, j in zip(*np.nonzero(g.in_area | g.covered), strict=True):
        lat, lon = m.to_latlon(float(cn[i, j]), float(ce[i, j]))
        lines.append(
            f"{ce[i, j]:.3f},{cn[i, j]:.3f},{lon:.8f},{lat:.8f},{g.depth_m[i, j]:.3f},"
            f"{g.count[i, j]},{g.spread_m[i, j]:.3f},{g.mean_m[i, j]:.3f},{int(g.in_area[i, j])}"
        )
        rows += 1
    path.write_text("\n".join(lines).replace("nan", "") + "\n")
    return rows


def contour_lines(m: SurveyMap, step_m: float) -> list[tuple[float, list[np.ndarray]]]:
    """(level, [N×2 arrays of (east, north)]) of the grid's contours every ``step_m``."""
    z = m.grid.depth_m
    if not np.isfinite(z).any():
        return []
    cn, ce = m.grid.frame.centres()
    gen = contourpy.contour_generator(ce, cn, np.ma.masked_invalid(z), line_type="Separate")
    lo, hi = float(np.nanmin(z)), float(np.nanmax(z))
    levels = np.arange(math.ceil(lo / step_m) * step_m, hi + 1e-9, step_m)
    out: list[tuple[float, list[np.ndarray]]] = []
    for level in levels:
        parts = cast(list[np.ndarray], gen.lines(level))  # line_type Separate: N×2 arrays
        out.append((float(level), [ln for ln in parts if len(ln) > 1]))
    return out


def write_contours(m: SurveyMap, lines: list[tuple[float, list[np.ndarray]]], path: Path) -> int:
    features = []
    for level, parts in lines:
        for part in parts:
            coords = [list(m.to_latlon(float(n), float(e)))[::-1] for e, n in part]
            features.append(
                {
                    "type": "Feature",
                    "properties": {"depth_m": round(level, 3)},
                    "geometry": {"type": "LineString", "coordinates": coords},
                }
            )
    path.write_text(json.dumps({"type": "FeatureCollection", "features": features}) + "\n")
    return len(features)


def write_png(
    m: SurveyMap, lines: list[tuple[float, list[np.ndarray]]], media: MediaMap | None, path: Path
) -> None:
    """The grid, its contours, the area, the media map's outlines and the holes."""
    g = m.grid
    n_edges, e_edges = g.frame.edges()
    fig = Figure(figsize=(7.5, 7.0))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    mesh = ax.pcolormesh(e_edges, n_edges, np.ma.masked_invalid(g.depth_m), cmap="viridis_r")
    fig.colorbar(mesh, ax=ax, label=f"{m.quantity} (gridded)")
    for level, parts in lines:
        for part in parts:
            ax.plot(part[:, 0], part[:, 1], color="black", linewidth=0.7)
        if parts:
            mid = parts[0][len(parts[0]) // 2]
            ax.annotate(f"{level:g}", (mid[0], mid[1]), fontsize=7, ha="center")
    if media is not None:
        placed = media.to_ne(m.reference_latlon)
        for a in placed.areas:
            ring = np.array(a.outer_ne + a.outer_ne[:1])
            ax.plot(ring[:, 1], ring[:, 0], color="tab:brown", linewidth=0.8, linestyle=":")
    if m.area_ne is not None:
        for ring in [m.area_ne.exterior, *m.area_ne.interiors]:
            x, y = ring.xy
            ax.plot(x, y, color="tab:red", linewidth=1.2)
    cn, ce = g.frame.centres()
    holes = g.holes
    if holes.any():
        ax.scatter(ce[holes], cn[holes], marker="x", color="tab:red", s=14, label="no reading")
        ax.legend(loc="upper right", fontsize=8)
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    lat, lon = m.reference_latlon
    ax.set_title(
        f"{g.samples} readings, {g.frame.cell_m:g} m cells, coverage {g.coverage * 100:.1f} %"
        f"\nfrom {lat:.6f}, {lon:.6f}",
        fontsize=9,
    )
    fig.savefig(path, dpi=DPI)


def holes_mission(m: SurveyMap, name: str, mode: MotionMode) -> Mission | None:
    """The mission through every hole's centre (None: no holes)."""
    points = m.holes_latlon()
    if not points:
        return None
    data = {
        "name": name,
        "mode": mode.value,
        "frame": "global",
        "waypoints": [{"lat": lat, "lon": lon} for lat, lon in points],
    }
    return Mission.model_validate(data)


def _rounded(f: Callable[[Any], Any], values: np.ndarray, digits: int) -> float | None:
    """``f`` (a NaN-ignoring reduction) of ``values``, rounded; None when all are NaN."""
    return round(float(f(values)), digits) if np.isfinite(values).any() else None


@dataclass(frozen=True)
class Written:
    files: list[Path]
    figures: dict[str, float | int | str | None]


def write_map(
    m: SurveyMap,
    out: Path,
    *,
    contour_step_m: float,
    media: MediaMap | None,
    mode: MotionMode,
) -> Written:
    """Every output file in ``out`` (created); their paths and the figures."""
    out.mkdir(parents=True, exist_ok=True)
    files = [out / "depth.tif", out / "depth.csv", out / "contours.geojson", out / "map.png"]
    write_geotiff(m, files[0])
    write_cells_csv(m, files[1])
    lines = contour_lines(m, contour_step_m)
    n_contours = write_contours(m, lines, files[2])
    write_png(m, lines, media, files[3])
    g = m.grid
    mission = holes_mission(m, "holes", mode)
    if mission is not None:
        files.append(out / "holes.yaml")
        write_mission_file(mission, files[-1])
    figures: dict[str, float | int | str | None] = {
        "quantity": m.quantity,
        "samples": g.samples,
        "skipped": m.skipped,
        "cell_m": g.frame.cell_m,
        "area_cells": int(g.in_area.sum()),
        "covered_cells": int((g.in_area & g.covered).sum()),
        "coverage": round(g.coverage, 4),
        "holes": int(g.holes.sum()),
        "holes_mission_items": 0 if mission is None else len(mission.waypoints),
        "contours": n_contours,
        "depth_min_m": _rounded(np.nanmin, g.depth_m, 3),
        "depth_max_m": _rounded(np.nanmax, g.depth_m, 3),
        "spread_median_m": _rounded(np.nanmedian, g.spread_m, 4),
    }
    files.append(out / "survey-map.json")
    files[-1].write_text(json.dumps(figures, indent=2) + "\n")
    return Written(files, figures)
