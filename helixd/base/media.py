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

:func:`media_along` cuts a straight leg into runs of one medium each (for splitting a plan
where the medium changes).

The file reader is :mod:`helixd.files.media`.
"""

from __future__ import annotations

import itertools
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


MAX_EAST_BINS = 512  # per ring: a lookup tests the edges of one east bin only
EDGES_PER_BIN = 4
MAX_BIN_ENTRIES_PER_EDGE = 8  # long edges in many bins: fewer bins (a hostile ring stays small)


class RingIndex:
    """A ring's edges bucketed by east: the even-odd test and the on-edge test for a point need
    only the edges whose east span holds the point's east, all in the point's bin. A lookup on
    a 10 000-vertex shoreline costs tens of edges, not 10 000."""

    __slots__ = ("_bins", "_east_max", "_east_min", "_k", "_width", "ring")

    def __init__(self, ring: Ring) -> None:
        self.ring = ring
        n = len(ring)
        easts = [p[1] for p in ring]
        self._east_min, self._east_max = min(easts), max(easts)
        span = self._east_max - self._east_min
        k = max(1, min(MAX_EAST_BINS, n // EDGES_PER_BIN))
        while True:
            self._k, self._width = k, (span / k if span > 0.0 else 1.0)
            bins: list[list[int]] = [[] for _ in range(k)]
            total = 0
            for i in range(n):
                a, b = easts[i], easts[(i + 1) % n]
                lo, hi = self._bin(min(a, b)), self._bin(max(a, b))
                for j in range(lo, hi + 1):
                    bins[j].append(i)
                total += hi - lo + 1
            if k == 1 or total <= MAX_BIN_ENTRIES_PER_EDGE * n:
                break
            k //= 2
        self._bins = tuple(tuple(b) for b in bins)

    def _bin(self, east_m: float) -> int:
        j = int((east_m - self._east_min) / self._width)
        return min(max(j, 0), self._k - 1)

    def locate(self, north_m: float, east_m: float) -> tuple[bool, bool]:
        """(inside by the even-odd rule, on an edge) — as :func:`helixd.base.polygon.
        point_in_polygon` and :func:`on_ring` over the whole ring."""
        if not (self._east_min - 1e-9 <= east_m <= self._east_max + 1e-9):
            return False, False
        ring, n = self.ring, len(self.ring)
        inside = on = False
        p = (north_m, east_m)
        for i in self._bins[self._bin(east_m)]:
            (n1, e1), (n2, e2) = ring[i], ring[(i + 1) % n]
            if (e1 > east_m) != (e2 > east_m):
                n_cross = n1 + (east_m - e1) * (n2 - n1) / (e2 - e1)
                if north_m < n_cross:
                    inside = not inside
            if not on and on_segment(ring[i], ring[(i + 1) % n], p):
                on = True
        return inside, on


@dataclass(frozen=True, slots=True)
class MediaAreaNe:
    """A media area in north/east metres, with its bounding box for a cheap first test and
    its rings indexed by east (:class:`RingIndex`)."""

    medium: Medium
    outer_ne: Ring
    holes_ne: tuple[Ring, ...]
    feature_index: int
    bbox_ne: tuple[float, float, float, float]  # north_min, north_max, east_min, east_max
    _outer: RingIndex = field(init=False, repr=False, compare=False)
    _holes: tuple[RingIndex, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_outer", RingIndex(self.outer_ne))
        object.__setattr__(self, "_holes", tuple(RingIndex(h) for h in self.holes_ne))

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
        inside, on = self._outer.locate(north_m, east_m)
        if not (inside or on):
            return False
        for hole in self._holes:
            in_hole, on_hole = hole.locate(north_m, east_m)
            if in_hole and not on_hole:
                return False
        return True


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


@dataclass(frozen=True, slots=True)
class MediaRun:
    """A stretch of a straight leg in one medium: from ``start_ne`` to ``end_ne`` (north_m,
    east_m), the fractions of the leg where it starts and ends."""

    medium: Medium
    start_fraction: float
    end_fraction: float
    start_ne: Point
    end_ne: Point

    @property
    def length_m(self) -> float:
        return math.hypot(self.end_ne[0] - self.start_ne[0], self.end_ne[1] - self.start_ne[1])


MIN_RUN_FRACTION = 1e-9  # shorter stretches between two crossings are rounding, not a medium
MIN_LEG_M = 1e-9  # a shorter leg is a point


def _leg_crossings(a: Point, b: Point, ring: Ring) -> list[float]:
    """Fractions t ∈ [0, 1] of the leg a→b where it meets an edge of ``ring``."""
    rn, re = b[0] - a[0], b[1] - a[1]
    out: list[float] = []
    n = len(ring)
    for i in range(n):
        q, q2 = ring[i], ring[(i + 1) % n]
        sn, se = q2[0] - q[0], q2[1] - q[1]
        denom = rn * se - re * sn
        dn, de = q[0] - a[0], q[1] - a[1]
        if denom == 0.0:  # parallel: where a collinear edge's ends lie on the leg
            for end in (q, q2):
                if on_segment(a, b, end):
                    length2 = rn * rn + re * re
                    out.append(((end[0] - a[0]) * rn + (end[1] - a[1]) * re) / length2)
            continue
        t = (dn * se - de * sn) / denom
        u = (dn * re - de * rn) / denom
        if 0.0 <= t <= 1.0 and 0.0 <= u <= 1.0:
            out.append(t)
    return out


def media_along(media: MediaMapNe, start_ne: Point, end_ne: Point) -> tuple[MediaRun, ...]:
    """The media a straight leg from ``start_ne`` to ``end_ne`` crosses, in order: runs that
    cover the leg end to end (each starts where the one before ends), neighbours in different
    media (where a plan splits a leg). A leg shorter than 1 nm is one run."""
    (n0, e0), (n1, e1) = start_ne, end_ne
    if math.hypot(n1 - n0, e1 - e0) < MIN_LEG_M:
        return (MediaRun(media.medium_at(n0, e0), 0.0, 1.0, start_ne, end_ne),)
    lo_n, hi_n, lo_e, hi_e = min(n0, n1), max(n0, n1), min(e0, e1), max(e0, e1)
    cuts: set[float] = set()
    for area in media.areas:
        bn0, bn1, be0, be1 = area.bbox_ne
        if bn0 > hi_n or bn1 < lo_n or be0 > hi_e or be1 < lo_e:
            continue
        for ring in (area.outer_ne, *area.holes_ne):
            cuts.update(t for t in _leg_crossings(start_ne, end_ne, ring) if 0.0 < t < 1.0)
    ts = [0.0]
    for t in sorted(cuts):
        if t - ts[-1] >= MIN_RUN_FRACTION and 1.0 - t >= MIN_RUN_FRACTION:
            ts.append(t)
    ts.append(1.0)

    def at(t: float) -> Point:
        if t == 0.0:
            return start_ne
        if t == 1.0:
            return end_ne
        return (n0 + (n1 - n0) * t, e0 + (e1 - e0) * t)

    runs: list[MediaRun] = []
    for t0, t1 in itertools.pairwise(ts):
        medium = media.medium_at(*at((t0 + t1) / 2.0))
        if runs and runs[-1].medium is medium:
            last = runs.pop()
            runs.append(MediaRun(medium, last.start_fraction, t1, last.start_ne, at(t1)))
        else:
            runs.append(MediaRun(medium, t0, t1, at(t0), at(t1)))
    return tuple(runs)


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
    "MediaRun",
    "Medium",
    "RingIndex",
    "in_or_on_ring",
    "media_along",
    "on_ring",
    "on_segment",
]
