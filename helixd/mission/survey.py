"""Survey missions: boustrophedon transects over a polygon, holes cut out, with shapely.

Pure geometry: a :class:`~helixd.mission.formats.areas.SurveyArea` (lat/lon) is mapped into a
local plane in true metres (WGS-84 azimuthal-equidistant around the area's first vertex,
geographiclib), covered with parallel transects ``spacing_m`` apart at ``angle_deg`` (compass:
degrees clockwise from North, as QGroundControl's survey angle), each clipped to the area minus
its holes, and joined into one path. Transects are exactly ``spacing_m`` apart (measured
perpendicular to them, in true metres: the spacing asked for is the spacing flown), each
covering ``spacing_m / 2`` either side: ``ceil(width / spacing_m)`` of them, centred on the
width, so the outer bands reach at most half a spacing past the edges.

Joining: from the current end, the nearest unvisited transect piece is taken next (for a convex
area that is the classic back-and-forth; a non-convex area or a hole splits a line into pieces,
finished lobe by lobe). A connecting leg that would leave the area (cross a hole or a bay) is
routed along the shortest path inside it, on the visibility graph of the area's vertices, so
every leg stays inside the polygon.

Coverage = area of (path buffered by ``spacing_m / 2``) ∩ polygon / polygon area.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.ops import unary_union

from helixd.mission.formats.areas import CIRCLE_SEGMENTS, SurveyArea
from helixd.mission.geodesy import geodesic_latlon, geodesic_ne_m

XY = tuple[float, float]  # (east_m, north_m): shapely's x, y
MIN_GAP_M = 0.01  # consecutive waypoints closer than this are one
MAX_TRANSECTS = 5_000  # 50 km of width at 10 m; keeps planning to seconds
COVERAGE_GRID_M = 1e-3  # the coverage overlay snaps to this grid (robust noding; 1 mm)
PLACEMENTS = 7  # positions of the transect set across the width tried (besides centred)


class SurveyError(ValueError):
    """The survey cannot be planned (bad polygon, spacing larger than the area, ...)."""


@dataclass(frozen=True, slots=True)
class SurveyResult:
    waypoints_latlon_deg: tuple[tuple[float, float], ...]
    fence_latlon_deg: tuple[tuple[float, float], ...]
    path_length_m: float
    transects: int
    area_m2: float
    coverage: float  # fraction of the polygon's area within spacing/2 of the path
    # in the local plane, for tests and plots: (east_m, north_m)
    path_xy_m: tuple[XY, ...]
    area_xy: Polygon
    # the holes (islands, exclusion zones; circles as circumscribed polygons), which the
    # mission carries as keep-out areas
    keep_outs_latlon_deg: tuple[tuple[tuple[float, float], ...], ...] = ()
    spacing_m: float = 0.0  # between adjacent transects (the spacing asked for)


@dataclass(frozen=True)
class _Plane:
    """The area in the local plane: its outer ring, the holes, and what is left."""

    shell: Polygon
    holes: tuple[Polygon, ...]
    region: Polygon
    origin: tuple[float, float]


def _to_xy(area: SurveyArea) -> _Plane:
    origin = area.outer[0]

    def xy(ring: tuple[tuple[float, float], ...]) -> list[XY]:
        out = []
        for lat, lon in ring:
            n, e = geodesic_ne_m(lat, lon, *origin)
            out.append((e, n))
        return out

    shell = Polygon(xy(area.outer))
    if not shell.is_valid:
        raise SurveyError(
            f"{area.source}: the polygon is not valid: {shapely.is_valid_reason(shell)}"
        )
    cut: list[BaseGeometry] = []
    for i, h in enumerate(area.holes):
        hole = Polygon(xy(h))
        if not hole.is_valid:
            raise SurveyError(
                f"{area.source}: hole {i} is not a valid polygon: {shapely.is_valid_reason(hole)}"
            )
        cut.append(hole)  # a hole partly or wholly outside the area cuts only what it covers
    for (lat, lon), radius in area.hole_circles:
        n, e = geodesic_ne_m(lat, lon, *origin)
        # the polygon circumscribes the circle: its edges stay >= radius from the centre
        grow = 1.0 / math.cos(math.pi / (4 * (CIRCLE_SEGMENTS // 4)))
        cut.append(Point(e, n).buffer(radius * grow, quad_segs=CIRCLE_SEGMENTS // 4))
    region = shell.difference(unary_union(cut)) if cut else shell
    if region.is_empty or region.area <= 0:
        raise SurveyError(f"{area.source}: nothing left to survey once the holes are cut out")
    if region.geom_type == "MultiPolygon":
        raise SurveyError(
            f"{area.source}: the holes split the area into {len(region.geoms)} parts; survey "
            "each part on its own"
        )
    assert isinstance(region, Polygon)
    holes = tuple(h for h in cut if isinstance(h, Polygon) and h.intersects(shell))
    return _Plane(shell, holes, region, origin)


def _transect_pieces(region: Polygon, spacing_m: float, angle_deg: float) -> list[LineString]:
    """Transect pieces clipped to ``region``, ordered across the area."""
    theta = math.radians(angle_deg)
    d = (math.sin(theta), math.cos(theta))  # direction in (east, north)
    nrm = (d[1], -d[0])  # unit normal: offsets between lines
    pts = list(region.exterior.coords)
    along = [p[0] * d[0] + p[1] * d[1] for p in pts]
    across = [p[0] * nrm[0] + p[1] * nrm[1] for p in pts]
    lo, hi = min(across), max(across)
    a0, a1 = min(along) - 1.0, max(along) + 1.0
    # exactly spacing_m apart (the spacing asked for is the spacing flown), as few as cover the
    # width with spacing_m / 2 either side; where the set sits across the width is free within
    # the slack (the outer bands reach past the edges): of a few placements, the one with the
    # longest transects inside the area (centred on a tie) — a sliver's ends lose least
    count = max(1, math.ceil((hi - lo) / spacing_m - 1e-9))
    if count > MAX_TRANSECTS:
        raise SurveyError(
            f"{count} transects at {spacing_m} m across {hi - lo:.0f} m: more than "
            f"{MAX_TRANSECTS}; split the area or widen the spacing"
        )
    earliest = hi - (count - 1) * spacing_m - spacing_m / 2.0
    latest = lo + spacing_m / 2.0
    centred = (earliest + latest) / 2.0
    firsts = [centred] + [
        earliest + (latest - earliest) * k / (PLACEMENTS - 1) for k in range(PLACEMENTS)
    ]
    offsets = np.arange(count, dtype=np.float64) * spacing_m
    best: tuple[float, npt.NDArray[np.object_]] | None = None
    for first in firsts:
        off = first + offsets
        lines = shapely.linestrings(
            np.stack(
                [
                    np.stack([a0 * d[0] + off * nrm[0], a0 * d[1] + off * nrm[1]], axis=1),
                    np.stack([a1 * d[0] + off * nrm[0], a1 * d[1] + off * nrm[1]], axis=1),
                ],
                axis=1,
            )
        )
        clipped = shapely.intersection(region, lines)
        total = float(shapely.length(clipped).sum())
        if best is None or total > best[0] * (1.0 + 1e-9):
            best = (total, clipped)
    assert best is not None
    pieces: list[LineString] = []
    for piece in best[1]:
        for g in getattr(piece, "geoms", [piece]):
            if isinstance(g, LineString) and g.length > MIN_GAP_M:
                pieces.append(g)
    return pieces


ROUTING_VERTICES_MAX = 400  # visibility graph size: O(n²) inside-tests, ~1 s at 400


def _routing_vertices(region: Polygon) -> list[XY]:
    """The region's vertices, or (for a detailed outline) those of a slightly inset and
    simplified copy: at most :data:`ROUTING_VERTICES_MAX`, all inside the region. Every leg
    between them is still tested against the region itself."""

    def verts(poly: Polygon) -> list[XY]:
        out: list[XY] = [(x, y) for x, y, *_ in list(poly.exterior.coords)[:-1]]
        for ring in poly.interiors:
            out.extend((x, y) for x, y, *_ in list(ring.coords)[:-1])
        return out

    raw = verts(region)
    if len(raw) <= ROUTING_VERTICES_MAX:
        return raw
    for inset_m in (0.2, 0.5, 1.0, 2.0, 5.0, 10.0):
        inner = region.buffer(-inset_m).simplify(inset_m / 2)
        if isinstance(inner, Polygon) and not inner.is_empty:
            candidate = verts(inner)
            if len(candidate) <= ROUTING_VERTICES_MAX:
                return candidate
    return raw[:: math.ceil(len(raw) / ROUTING_VERTICES_MAX)]  # last resort: a subset


class _Router:
    """Shortest paths inside ``region`` on the visibility graph of its vertices."""

    def __init__(self, region: Polygon) -> None:
        self.inside = region.buffer(1e-4)
        shapely.prepare(self.inside)
        self.verts = _routing_vertices(region)
        self._edges: dict[int, list[tuple[int, float]]] | None = None

    def visible(self, a: XY, b: XY) -> bool:
        return bool(self.inside.covers(LineString([a, b])))

    def _graph(self) -> dict[int, list[tuple[int, float]]]:
        if self._edges is None:
            n = len(self.verts)
            edges: dict[int, list[tuple[int, float]]] = {i: [] for i in range(n)}
            for i in range(n):
                for j in range(i + 1, n):
                    if self.visible(self.verts[i], self.verts[j]):
                        w = math.dist(self.verts[i], self.verts[j])
                        edges[i].append((j, w))
                        edges[j].append((i, w))
            self._edges = edges
        return self._edges

    def route(self, a: XY, b: XY) -> list[XY]:
        """Intermediate points from a to b (empty when the straight leg stays inside)."""
        if self.visible(a, b):
            return []
        graph = self._graph()
        n = len(self.verts)
        start, goal = n, n + 1
        pts = [*self.verts, a, b]
        near = {
            i: [
                (j, math.dist(pts[i], self.verts[j]))
                for j in range(n)
                if self.visible(pts[i], self.verts[j])
            ]
            for i in (start, goal)
        }
        dist = {start: 0.0}
        prev: dict[int, int] = {}
        heap = [(0.0, start)]
        while heap:
            du, u = heapq.heappop(heap)
            if u == goal:
                break
            if du > dist.get(u, math.inf):
                continue
            nbrs = near[start] if u == start else list(graph[u])
            if u < n and any(j == u for j, _ in near[goal]):
                nbrs = [*nbrs, (goal, math.dist(self.verts[u], b))]
            for v, w in nbrs:
                if du + w < dist.get(v, math.inf):
                    dist[v] = du + w
                    prev[v] = u
                    heapq.heappush(heap, (du + w, v))
        if goal not in prev:
            raise SurveyError("no path inside the area between two transects")
        path: list[XY] = []
        node = prev[goal]
        while node != start:
            path.append(pts[node])
            node = prev[node]
        return path[::-1]


def _join(pieces: list[LineString], region: Polygon, entry: XY) -> list[XY]:
    router = _Router(region)
    ends = np.array(
        [[*p.coords[0][:2], *p.coords[-1][:2]] for p in pieces], dtype=np.float64
    )  # per piece: x0, y0, x1, y1
    left = np.ones(len(pieces), dtype=bool)
    path: list[XY] = []
    here = entry
    for _ in range(len(pieces)):
        d0 = np.hypot(ends[:, 0] - here[0], ends[:, 1] - here[1])
        d1 = np.hypot(ends[:, 2] - here[0], ends[:, 3] - here[1])
        d0[~left] = np.inf
        d1[~left] = np.inf
        i0, i1 = int(np.argmin(d0)), int(np.argmin(d1))
        i, rev = (i0, False) if d0[i0] <= d1[i1] else (i1, True)
        left[i] = False
        x0, y0, x1, y1 = (float(v) for v in ends[i])
        a, b = ((x1, y1), (x0, y0)) if rev else ((x0, y0), (x1, y1))
        if path:
            path.extend(router.route(here, a))
        path.extend([a, b])
        here = b
    dedup: list[XY] = []
    for p in path:
        if not dedup or math.dist(dedup[-1], p) >= MIN_GAP_M:
            dedup.append(p)
    return dedup


def _covered_m2(path: list[XY], half_width_m: float, region: Polygon) -> float:
    """Area of ``region`` within ``half_width_m`` of the path (flat ends, round joins). When
    GEOS cannot node the one buffer of a folded zigzag, each leg's band and each joint's disc
    on their own, then their union on a 1 mm grid (slower, robust)."""
    if len(path) < 2:
        return 0.0
    try:
        band = LineString(path).buffer(half_width_m, cap_style="flat")
        return float(band.intersection(region).area)
    except shapely.errors.GEOSException:  # a folded zigzag GEOS cannot node in one buffer
        return _covered_leg_by_leg_m2(path, half_width_m, region)


def _covered_leg_by_leg_m2(path: list[XY], half_width_m: float, region: Polygon) -> float:
    """:func:`_covered_m2` the robust way: each leg's band and each joint's disc, united on a
    1 mm grid."""
    pts = np.asarray(path, dtype=np.float64)
    legs = shapely.linestrings(np.stack([pts[:-1], pts[1:]], axis=1))
    bands = shapely.buffer(legs, half_width_m, cap_style="flat")
    joints = shapely.buffer(shapely.points(pts[1:-1]), half_width_m)
    covered = shapely.union_all(np.concatenate([bands, joints]), grid_size=COVERAGE_GRID_M)
    return float(shapely.intersection(covered, region, grid_size=COVERAGE_GRID_M).area)


FENCE_VERTICES_MAX = 1000  # Mission.geofence_polygon / safety.geofence_polygon_ne_m bound


def _fence(shell: Polygon, margin_m: float, source: str) -> Polygon:
    """The shell grown by ``margin_m``, simplified to at most :data:`FENCE_VERTICES_MAX`
    vertices by less than half the margin (so it still contains the shell)."""
    grown = shell.buffer(margin_m, join_style="mitre")
    for tol_m in (0.01, 0.1 * margin_m, 0.25 * margin_m, 0.45 * margin_m):
        fence = grown.simplify(tol_m) if tol_m > 0 else grown
        if (
            isinstance(fence, Polygon)
            and len(fence.exterior.coords) - 1 <= FENCE_VERTICES_MAX
            and fence.covers(shell)
        ):
            return fence
    raise SurveyError(
        f"{source}: the outline is too detailed for a {FENCE_VERTICES_MAX}-vertex fence at "
        f"margin {margin_m} m; use a larger --margin-m or a simpler polygon"
    )


def plan_survey(
    area: SurveyArea,
    *,
    spacing_m: float,
    angle_deg: float,
    margin_m: float,
    inset_m: float = 0.0,
    keep_out_inset_m: float | None = None,
) -> SurveyResult:
    """Transects over ``area``; the fence is the outer ring grown by ``margin_m``. The rover
    keeps ``inset_m`` inside the outer edge (a shoreline: its half-width keeps its body in the
    area) and ``keep_out_inset_m`` (default ``inset_m``) off the holes (islands, exclusion
    zones: the clearance a planner keeps from a keep-out): transects and legs use the area
    shrunk by them; coverage is still measured over the whole area. The holes come back as
    keep-out polygons for the mission to carry."""
    hole_inset_m = inset_m if keep_out_inset_m is None else keep_out_inset_m
    for name, v, lo, hi in (
        ("spacing_m", spacing_m, 0.1, 1000.0),
        ("angle_deg", angle_deg, -360.0, 360.0),
        ("margin_m", margin_m, 0.0, 1000.0),
        ("inset_m", inset_m, 0.0, 1000.0),
        ("keep_out_inset_m", hole_inset_m, 0.0, 1000.0),
    ):
        if not (math.isfinite(v) and lo <= v <= hi):
            raise SurveyError(f"{name} = {v}; allowed {lo} .. {hi}")
    plane = _to_xy(area)
    region, origin = plane.region, plane.origin
    driven = region
    if inset_m > 0 or (hole_inset_m > 0 and plane.holes):
        shrunk: BaseGeometry = plane.shell.buffer(-inset_m, join_style="mitre")
        if plane.holes:
            grown = unary_union([h.buffer(hole_inset_m, join_style="mitre") for h in plane.holes])
            shrunk = shrunk.difference(grown)
        if not isinstance(shrunk, Polygon) or shrunk.is_empty:
            raise SurveyError(
                f"{area.source}: {inset_m} m inside the edges and {hole_inset_m} m off the "
                "holes leaves "
                + ("nothing" if shrunk.is_empty else f"{len(getattr(shrunk, 'geoms', []))} parts")
                + "; use a smaller --inset-m"
            )
        driven = shrunk
    pieces = _transect_pieces(driven, spacing_m, angle_deg)
    if not pieces:
        raise SurveyError(
            f"{area.source}: no transect fits: the area is narrower than the spacing "
            f"{spacing_m} m at angle {angle_deg}°"
        )
    first = driven.exterior.coords[0]
    path = _join(pieces, driven, (first[0], first[1]))
    covered = _covered_m2(path, spacing_m / 2, region)
    coverage = covered / region.area
    fence_xy = _fence(Polygon(region.exterior.coords), margin_m, area.source)

    def ll(p: tuple[float, ...]) -> tuple[float, float]:
        return geodesic_latlon(p[1], p[0], *origin)

    keep_outs = tuple(tuple(ll(p) for p in list(h.exterior.coords)[:-1]) for h in plane.holes)

    return SurveyResult(
        waypoints_latlon_deg=tuple(ll(p) for p in path),
        fence_latlon_deg=tuple(ll(p) for p in list(fence_xy.exterior.coords)[:-1]),
        path_length_m=LineString(path).length if len(path) > 1 else 0.0,
        transects=len(pieces),
        area_m2=region.area,
        coverage=coverage,
        path_xy_m=tuple(path),
        area_xy=region,
        keep_outs_latlon_deg=keep_outs,
        spacing_m=spacing_m,
    )


__all__ = ["SurveyError", "SurveyResult", "plan_survey"]
