"""Media maps: which medium (hard ground, grass, sand, mud, water) is where. Pure: numbers in.

A :class:`MediaMap` is what a media file says, in the file's own frame: lat/lon degrees
(``global``) or north/east metres from the EKF origin (``local_ned``). :meth:`MediaMap.to_ne`
places it once, at the edge, in the autopilot's north/east frame (ArduPilot's flat-earth map,
:func:`helixd.base.frames.latlon_to_ne`, the frame of LOCAL_POSITION_NED); the result, a
:class:`MediaMapNe`, answers :meth:`MediaMapNe.medium_at`.

Lookup rules:

* a point is in an area when it is inside or on the area's outer ring and not strictly inside
  one of its holes (a point on a hole's edge is on the area's boundary, so in the area);
* where areas overlap, the **last** area in the file wins (draw the pond, then the island);
* outside every area the map's ``default_medium`` applies, else the caller's ``fallback``.

The file reader is :mod:`helixd.files.media`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import StrEnum

from helixd.base.frames import latlon_to_ne
from helixd.base.polygon import point_in_polygon

Point = tuple[float, float]
Ring = tuple[Point, ...]  # not closed: the last vertex is not the first repeated


class Medium(StrEnum):
    """What the scrolls are in. The simulator's terrain table has one row per medium."""

    HARD = "hard"
    GRASS = "grass"
    SAND = "sand"
    MUD = "mud"
    WATER = "water"


class MediaFrame(StrEnum):
    GLOBAL = "global"  # GeoJSON positions [lon, lat] in degrees (WGS 84)
    LOCAL_NED = "local_ned"  # GeoJSON positions [east_m, north_m] from the EKF origin


@dataclass(frozen=True, slots=True)
class MediaArea:
    """One polygon of one medium, in its map's frame: ``outer`` and ``holes`` are rings of
    (lat_deg, lon_deg) for a ``global`` map and (north_m, east_m) for a ``local_ned`` one.
    ``feature_index`` is the GeoJSON feature it came from (for messages)."""

    medium: Medium
    outer: Ring
    holes: tuple[Ring, ...] = ()
    feature_index: int = 0


@dataclass(frozen=True, slots=True)
class MediaMap:
    """Media areas as read from a file, in the file's frame; later areas win overlaps."""

    frame: MediaFrame
    areas: tuple[MediaArea, ...]
    default_medium: Medium | None = None
    source: str = ""

    @property
    def needs_origin(self) -> bool:
        """True when placing the map needs the EKF origin (lat/lon coordinates)."""
        return self.frame is MediaFrame.GLOBAL

    def to_ne(
        self,
        origin_latlon_deg: tuple[float, float] | None = None,
        fallback: Medium = Medium.HARD,
    ) -> MediaMapNe:
        """The map in north/east metres around the EKF origin (needed for a ``global`` map;
        ignored for a ``local_ned`` one). ``fallback``: the medium outside every area when the
        file names no ``default_medium``. Raises ValueError for a global map without origin."""
        if self.frame is MediaFrame.GLOBAL:
            if origin_latlon_deg is None:
                raise ValueError(f"{self.source or 'media map'}: lat/lon areas need an origin")
            lat0, lon0 = origin_latlon_deg

            def place(ring: Ring) -> Ring:
                return tuple(latlon_to_ne(lat, lon, lat0, lon0) for lat, lon in ring)

        else:

            def place(ring: Ring) -> Ring:
                return ring

        return MediaMapNe(
            areas=tuple(
                MediaAreaNe.build(
                    a.medium, place(a.outer), tuple(place(h) for h in a.holes), a.feature_index
                )
                for a in self.areas
            ),
            default_medium=self.default_medium or fallback,
            source=self.source,
        )


@dataclass(frozen=True, slots=True)
class MediaAreaNe:
    """A media area in north/east metres, with its bounding box for a cheap first test."""

    medium: Medium
    outer_ne: Ring
    holes_ne: tuple[Ring, ...]
    feature_index: int
    bbox_ne: tuple[float, float, float, float]  # north_min, north_max, east_min, east_max

    @classmethod
    def build(
        cls, medium: Medium, outer_ne: Ring, holes_ne: tuple[Ring, ...], feature_index: int = 0
    ) -> MediaAreaNe:
        norths = [p[0] for p in outer_ne]
        easts = [p[1] for p in outer_ne]
        bbox = (min(norths), max(norths), min(easts), max(easts))
        return cls(medium, outer_ne, holes_ne, feature_index, bbox)

    def contains(self, north_m: float, east_m: float) -> bool:
        """Inside or on the outer ring and not strictly inside a hole."""
        n0, n1, e0, e1 = self.bbox_ne
        if not (n0 <= north_m <= n1 and e0 <= east_m <= e1):
            return False
        if not in_or_on_ring(north_m, east_m, self.outer_ne):
            return False
        return not any(
            in_or_on_ring(north_m, east_m, hole) and not on_ring(north_m, east_m, hole)
            for hole in self.holes_ne
        )


@dataclass(frozen=True, slots=True)
class MediaMapNe:
    """A media map placed in north/east metres: the lookup."""

    areas: tuple[MediaAreaNe, ...]
    default_medium: Medium = Medium.HARD
    source: str = ""
    _reversed: tuple[MediaAreaNe, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_reversed", tuple(reversed(self.areas)))

    def area_at(self, north_m: float, east_m: float) -> MediaAreaNe | None:
        """The area that decides the medium at this point (the last containing it), or None."""
        for area in self._reversed:
            if area.contains(north_m, east_m):
                return area
        return None

    def medium_at(self, north_m: float, east_m: float) -> Medium:
        """The medium at (north_m, east_m): the last area containing the point, else the
        map's default medium. A non-finite point is outside every area."""
        if not (math.isfinite(north_m) and math.isfinite(east_m)):
            return self.default_medium
        area = self.area_at(north_m, east_m)
        return self.default_medium if area is None else area.medium


def on_segment(a: Point, b: Point, p: Point) -> bool:
    """True if ``p`` lies on the closed segment ab (exactly, within rounding of 1e-9 m)."""
    cross = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    length = math.hypot(b[0] - a[0], b[1] - a[1])
    if abs(cross) > 1e-9 * max(length, 1.0):
        return False
    return (
        min(a[0], b[0]) - 1e-12 <= p[0] <= max(a[0], b[0]) + 1e-12
        and min(a[1], b[1]) - 1e-12 <= p[1] <= max(a[1], b[1]) + 1e-12
    )


def on_ring(north_m: float, east_m: float, ring: Sequence[Point]) -> bool:
    n = len(ring)
    p = (north_m, east_m)
    return any(on_segment(ring[i], ring[(i + 1) % n], p) for i in range(n))


def in_or_on_ring(north_m: float, east_m: float, ring: Sequence[Point]) -> bool:
    """Even-odd ray casting (:func:`helixd.base.polygon.point_in_polygon`), the boundary
    counting as inside."""
    return point_in_polygon(north_m, east_m, ring) or on_ring(north_m, east_m, ring)


__all__ = [
    "MediaArea",
    "MediaAreaNe",
    "MediaFrame",
    "MediaMap",
    "MediaMapNe",
    "Medium",
    "in_or_on_ring",
    "on_ring",
    "on_segment",
]
