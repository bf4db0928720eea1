"""Plane polygons: keep-in geofence sanity and the point-in-polygon test. Pure: numbers in.

Vertices are (north_m, east_m) pairs, as in ``safety.geofence_polygon_ne_m``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

MIN_POLYGON_AREA_M2 = 1.0  # a keep-in area smaller than the rover's own footprint is a typo

Point = tuple[float, float]


def signed_area_m2(poly: Sequence[Point]) -> float:
    """Shoelace area; positive when the vertices run counter-clockwise in (north, east)."""
    total = 0.0
    n = len(poly)
    for i in range(n):
        (a0, a1), (b0, b1) = poly[i], poly[(i + 1) % n]
        total += a0 * b1 - b0 * a1
    return total / 2.0


def _orient(a: Point, b: Point, c: Point) -> float:
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def _on_segment(a: Point, b: Point, p: Point) -> bool:
    return min(a[0], b[0]) <= p[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= p[1] <= max(a[1], b[1])


def segments_intersect(a: Point, b: Point, c: Point, d: Point) -> bool:
    """True if segment ab and segment cd share at least one point (touching counts)."""
    o1, o2, o3, o4 = _orient(a, b, c), _orient(a, b, d), _orient(c, d, a), _orient(c, d, b)
    if ((o1 > 0 > o2) or (o1 < 0 < o2)) and ((o3 > 0 > o4) or (o3 < 0 < o4)):
        return True
    return (
        (o1 == 0 and _on_segment(a, b, c))
        or (o2 == 0 and _on_segment(a, b, d))
        or (o3 == 0 and _on_segment(c, d, a))
        or (o4 == 0 and _on_segment(c, d, b))
    )


def polygon_problems(poly: Sequence[Point]) -> list[str]:
    """Why ``poly`` cannot be a keep-in fence; empty when it can. Total: never raises."""
    n = len(poly)
    if n < 3:
        return [f"a polygon needs at least 3 vertices, got {n}"]
    for i, (north_m, east_m) in enumerate(poly):
        if not (math.isfinite(north_m) and math.isfinite(east_m)):
            return [f"vertex {i} ({north_m}, {east_m}) is not a finite (north_m, east_m) pair"]
    problems: list[str] = []
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        if a == b:
            problems.append(f"vertices {i} and {(i + 1) % n} are the same point {a}")
    if problems:
        return problems
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        for j in range(i + 1, n):
            if j == i + 1 or (i == 0 and j == n - 1):
                continue  # neighbouring edges share a vertex
            c, d = poly[j], poly[(j + 1) % n]
            if segments_intersect(a, b, c, d):
                return [
                    f"edges {i}-{(i + 1) % n} and {j}-{(j + 1) % n} cross or touch: the polygon "
                    "must not intersect itself"
                ]
    area = abs(signed_area_m2(poly))
    if area < MIN_POLYGON_AREA_M2:
        problems.append(
            f"area {area:.3g} m² is below {MIN_POLYGON_AREA_M2} m² (degenerate or collinear)"
        )
    # a vertex lying on a non-adjacent edge is caught above as touching; collinear
    # neighbouring edges folding back on themselves make the area test fail.
    return problems


def leg_leaves_polygon(a: Point, b: Point, poly: Sequence[Point]) -> bool:
    """True if the straight leg a→b crosses the boundary of ``poly`` (both ends inside)."""
    n = len(poly)
    return any(segments_intersect(a, b, poly[i], poly[(i + 1) % n]) for i in range(n))


def point_in_polygon(north_m: float, east_m: float, poly: Sequence[tuple[float, float]]) -> bool:
    """Even-odd ray casting; vertices as (north_m, east_m)."""
    inside = False
    n = len(poly)
    for i in range(n):
        (n1, e1), (n2, e2) = poly[i], poly[(i + 1) % n]
        if (e1 > east_m) != (e2 > east_m):
            n_cross = n1 + (east_m - e1) * (n2 - n1) / (e2 - e1)
            if north_m < n_cross:
                inside = not inside
    return inside
