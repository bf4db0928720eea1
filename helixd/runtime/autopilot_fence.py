"""The autopilot's own fence, read in preflight and judged against the route (before arming).

ArduPilot acts on its fence by itself (``FENCE_ACTION``: HOLD, RTL, …; a run then ends as
``autopilot_fence``). A route that leaves one of its inclusion polygons or circles, or enters
one of its exclusion zones, would be stopped there: preflight refuses it (exit 3), naming the
point or leg and the shape, as ``helixd serve`` judges the fence it downloads. AC_Fence's
default is checked: the rover must stay inside *every* inclusion shape (``FENCE_OPTIONS``'
union of inclusions is not read). A fence stored while ``FENCE_ENABLE`` is 0 does not act: its
problems are a warning.

:func:`route_fence_problems` is pure; :func:`autopilot_fence_check` reads the autopilot.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import structlog

from helixd.base.polygon import leg_leaves_polygon, point_in_polygon
from helixd.link.connection import Autopilot
from helixd.link.services.mission_transfer import MissionTransferError
from helixd.mission.formats.items import FenceNe, ObstacleCircle, fence_ne
from helixd.mission.formats.wire import wire_to_gcs

log = structlog.get_logger(__name__)

Point = tuple[float, float]  # (north_m, east_m) from the EKF origin


def _segment_distance_m(a: Point, b: Point, p: Point) -> float:
    """Distance from ``p`` to the segment a→b."""
    dn, de = b[0] - a[0], b[1] - a[1]
    length2 = dn * dn + de * de
    t = 0.0 if length2 == 0.0 else ((p[0] - a[0]) * dn + (p[1] - a[1]) * de) / length2
    t = min(1.0, max(0.0, t))
    return math.hypot(a[0] + t * dn - p[0], a[1] + t * de - p[1])


def _in_circle(p: Point, c: ObstacleCircle) -> bool:
    return math.hypot(p[0] - c.centre_ne_m[0], p[1] - c.centre_ne_m[1]) <= c.radius_m


def _at(p: Point) -> str:
    return f"(N {p[0]:.1f} m, E {p[1]:.1f} m)"


def route_fence_problems(
    fence: FenceNe, points: Sequence[Point], labels: Sequence[str]
) -> list[str]:
    """Every point outside an inclusion shape or inside an exclusion zone, and every leg
    between consecutive points that leaves an inclusion shape or crosses an exclusion zone
    (pure). ``labels`` name the points."""
    out: list[str] = []
    for p, label in zip(points, labels, strict=True):
        for i, poly in enumerate(fence.inclusion_polygons, 1):
            if not point_in_polygon(p[0], p[1], poly):
                out.append(f"{label} {_at(p)} is outside the autopilot's inclusion polygon {i}")
        for i, c in enumerate(fence.inclusion_circles, 1):
            if not _in_circle(p, c):
                out.append(f"{label} {_at(p)} is outside the autopilot's inclusion circle {i}")
        for i, poly in enumerate(fence.exclusion_polygons, 1):
            if point_in_polygon(p[0], p[1], poly):
                out.append(f"{label} {_at(p)} is inside the autopilot's exclusion polygon {i}")
        for i, c in enumerate(fence.exclusion_circles, 1):
            if _in_circle(p, c):
                out.append(f"{label} {_at(p)} is inside the autopilot's exclusion circle {i}")
    if out:
        return out  # a point already outside: its legs say nothing more
    for k in range(len(points) - 1):
        a, b = points[k], points[k + 1]
        leg = f"the leg {labels[k]} → {labels[k + 1]}"
        for i, poly in enumerate(fence.inclusion_polygons, 1):
            if leg_leaves_polygon(a, b, poly):
                out.append(f"{leg} leaves the autopilot's inclusion polygon {i}")
        for i, poly in enumerate(fence.exclusion_polygons, 1):
            if leg_leaves_polygon(a, b, poly):
                out.append(f"{leg} crosses the autopilot's exclusion polygon {i}")
        for i, c in enumerate(fence.exclusion_circles, 1):
            if _segment_distance_m(a, b, c.centre_ne_m) <= c.radius_m:
                out.append(f"{leg} crosses the autopilot's exclusion circle {i}")
        # an inclusion circle is convex: a leg between two points inside it stays inside
    return out


async def autopilot_fence_check(
    ap: Autopilot,
    origin_latlon_deg: tuple[float, float] | None,
    points: Sequence[Point],
    labels: Sequence[str],
) -> tuple[list[str], list[str]]:
    """Read the autopilot's fence and judge the route: (problems that refuse the run,
    warnings). A fence that cannot be read or placed is a warning, not a refusal."""
    try:
        items = await ap.mission.download_fence()
    except MissionTransferError as exc:
        return [], [f"the autopilot's fence could not be read ({exc}): not judged"]
    if not items:
        return [], []
    gcs, notes = wire_to_gcs((), items)
    warnings = [f"the autopilot's fence: {n}" for n in notes]
    if not gcs.polygons and not gcs.circles:
        return [], warnings
    if origin_latlon_deg is None:
        return [], [*warnings, "no EKF origin: the autopilot's fence is not judged"]
    problems = route_fence_problems(fence_ne(gcs, origin_latlon_deg), points, labels)
    log.info(
        "autopilot_fence_judged",
        polygons=len(gcs.polygons),
        circles=len(gcs.circles),
        problems=len(problems),
    )
    if not problems:
        return [], warnings
    enabled = await ap.param.get("FENCE_ENABLE")
    if enabled is not None and enabled == 0:
        off = "the autopilot's fence is off (FENCE_ENABLE 0), else it would stop the rover: "
        return [], [*warnings, *(off + p for p in problems)]
    return problems, warnings
