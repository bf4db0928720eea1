#!/usr/bin/env python3
"""Generate the shipped pond survey's area and the simulator's pond bottom.

From ``config/maps/pond-media.geojson``:

* ``config/areas/pond-water.geojson``: the pond's open water, the surveyed area: the water
  polygon less the berm island's muddy shore (a hole) and the pontoon (cut from the west bank);
* ``config/maps/pond-bathymetry.yaml`` (:mod:`helixd.files.bathymetry`): a bowl 2.5 m deep at
  its deepest, 0.3 m at the water's edge (the pond's banks are steep), with a shoal of 0.8 m
  rising towards the island and a 0.5 m hollow in the south-east; nodes every metre within
  1.5 m of the water (so the depth is defined up to the shore), dry (null) on the island.

Usage: python tools/make_bathymetry.py (writes both files in place)
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
from pathlib import Path

from shapely.geometry import Point, Polygon, mapping

from helixd.base.frames import latlon_to_ne, ne_to_latlon
from helixd.base.media import Medium
from helixd.files.media import read_media_map

ROOT = Path(__file__).resolve().parent.parent
MEDIA = ROOT / "config" / "maps" / "pond-media.geojson"
AREA_OUT = ROOT / "config" / "areas" / "pond-water.geojson"
BATHY_OUT = ROOT / "config" / "maps" / "pond-bathymetry.yaml"
# another bottom for the same pond (tools/bench_survey.py --bathymetry): a slope and a channel
CHANNEL_OUT = ROOT / "config" / "maps" / "pond-bathymetry-channel.yaml"
CELL_M = 1.0
EDGE_DEPTH_M = 0.3
DEEPEST_M = 2.5


def _polygons() -> tuple[Polygon, Polygon, Polygon, tuple[float, float]]:
    """(water, island shore, pontoon) in north/east metres around the water's first vertex,
    and that origin (lat, lon)."""
    media = read_media_map(MEDIA)
    water_ll = next(a for a in media.areas if a.medium is Medium.WATER).outer
    origin = water_ll[0]

    def ne(ring: tuple[tuple[float, float], ...]) -> Polygon:
        return Polygon([latlon_to_ne(lat, lon, *origin)[::-1] for lat, lon in ring])  # x=e

    water = ne(water_ll)
    shore = ne(media.areas[2].outer)  # the berm island's muddy shore
    pontoon = ne(media.areas[4].outer)
    return water, shore, pontoon, origin


def depth_m(east_m: float, north_m: float, cx: float, cy: float, ax: float, ay: float) -> float:
    """The bowl with its shoal and hollow (x east, y north, metres)."""
    r2 = ((east_m - cx) / ax) ** 2 + ((north_m - cy) / ay) ** 2
    bowl = EDGE_DEPTH_M + (DEEPEST_M - EDGE_DEPTH_M) * max(0.0, 1.0 - r2)
    shoal = -0.8 * math.exp(-((east_m - (cx - 5.0)) ** 2 + (north_m - (cy + 6.5)) ** 2) / 30.0)
    hollow = 0.5 * math.exp(-((east_m - (cx + 6.0)) ** 2 + (north_m - (cy - 9.0)) ** 2) / 20.0)
    return max(EDGE_DEPTH_M, bowl + shoal + hollow)


def channel_depth_m(
    east_m: float, north_m: float, cx: float, cy: float, ax: float, ay: float
) -> float:
    """A bottom sloping from 0.4 m at the north shore to 2.8 m at the south, cut by a 1.2 m
    deep channel running south-west to north-east."""
    slope = 0.4 + 2.4 * (cy + ay - north_m) / (2.0 * ay)
    across = ((east_m - cx) - (north_m - cy) * 0.6) / 3.0
    channel = 1.2 * math.exp(-(across**2))
    return max(EDGE_DEPTH_M, slope + channel)


def write_bathymetry(path: Path, header: str, depth: Callable[..., float]) -> None:
    """Nodes every metre within 1.5 m of the water, dry on the island."""
    water, shore, _, origin = _polygons()
    minx, miny, maxx, maxy = water.bounds
    cx, cy = (minx + maxx) / 2.0, (miny + maxy) / 2.0
    ax, ay = (maxx - minx) / 2.0, (maxy - miny) / 2.0
    wet = water.buffer(1.5)
    island = shore.buffer(-0.3)
    x0, y0 = math.floor(minx) - 2.0, math.floor(miny) - 2.0
    cols = math.ceil(maxx - x0 + 2.0) + 1
    rows = math.ceil(maxy - y0 + 2.0) + 1
    lines = []
    for i in range(rows):
        row = []
        for j in range(cols):
            x, y = x0 + j * CELL_M, y0 + i * CELL_M
            p = Point(x, y)
            dry = not wet.contains(p) or island.contains(p)
            row.append("null" if dry else f"{depth(x, y, cx, cy, ax, ay):.3f}")
        lines.append("  - [" + ", ".join(row) + "]")
    sw_lat, sw_lon = ne_to_latlon(y0, x0, *origin)
    path.write_text(
        header + "# Format: docs/survey.md (helixd.files.bathymetry).\n"
        "format: helixd-bathymetry/1\n"
        f"south_west: {{lat_deg: {sw_lat:.8f}, lon_deg: {sw_lon:.8f}}}\n"
        f"cell_m: {CELL_M}\n"
        "depth_m:  # rows south -> north, each west -> east; null: no water\n"
        + "\n".join(lines)
        + "\n"
    )
    print(f"{path.relative_to(ROOT)}: {rows} x {cols} nodes, {CELL_M} m")


def main() -> int:
    water, shore, pontoon, origin = _polygons()
    area = water.difference(shore.union(pontoon))
    ring = [ne_to_latlon(y, x, *origin) for x, y in area.exterior.coords]
    holes = [[ne_to_latlon(y, x, *origin) for x, y in h.coords] for h in area.interiors]
    feature = {
        "type": "Feature",
        "properties": {"name": "the pond's open water (less the island and the pontoon)"},
        "geometry": {
            "type": "Polygon",
            "coordinates": [
                [[round(lon, 8), round(lat, 8)] for lat, lon in r] for r in [ring, *holes]
            ],
        },
    }
    assert mapping(area)["type"] == "Polygon"
    AREA_OUT.write_text(
        json.dumps({"type": "FeatureCollection", "features": [feature]}, indent=None) + "\n"
    )
    write_bathymetry(
        BATHY_OUT,
        "# The example pond's bottom (the built-in simulator's, --sim-bathymetry), generated by\n"
        "# tools/make_bathymetry.py from config/maps/pond-media.geojson: a bowl 2.5 m deep, 0.3 m\n"
        "# at the water's edge, a shoal towards the berm island, a hollow in the south-east.\n",
        depth_m,
    )
    write_bathymetry(
        CHANNEL_OUT,
        "# Another bottom for the example pond (tools/bench_survey.py --bathymetry), generated by\n"
        "# tools/make_bathymetry.py: a slope, 0.4 m (north) to 2.8 m (south), and a channel.\n",
        channel_depth_m,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
