"""What is in the way, as plain shapes in the local NED plane (metres from the EKF origin).

Every obstacle source feeds these types: the config's ``planning`` section
(:func:`obstacles_from_config`), a QGC ``.plan`` geofence (exclusion polygons and circles; a
reader calls :func:`with_geofence`), and a map_server map (:mod:`helixd.planning.mapfile`,
kept apart as a raster). The inclusion polygon is the outer boundary: outside it is blocked.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from helixd.config.root import HelixdConfig

PointNE = tuple[float, float]  # (north_m, east_m)


@dataclass(frozen=True, slots=True)
class KeepOutCircle:
    north_m: float
    east_m: float
    radius_m: float


@dataclass(frozen=True, slots=True)
class Obstacles:
    """Keep-out polygons and circles, plus an optional keep-in (inclusion) polygon."""

    polygons_ne_m: tuple[tuple[PointNE, ...], ...] = ()
    circles: tuple[KeepOutCircle, ...] = ()
    inclusion_ne_m: tuple[PointNE, ...] = ()

    @property
    def empty(self) -> bool:
        return not (self.polygons_ne_m or self.circles or self.inclusion_ne_m)


class ObstacleError(ValueError):
    """A shape is unusable (non-finite vertex, too few vertices, non-positive radius)."""


def _checked_polygon(poly: Sequence[PointNE], what: str) -> tuple[PointNE, ...]:
    pts = tuple((float(n), float(e)) for n, e in poly)
    if len(pts) < 3:
        raise ObstacleError(f"{what}: a polygon needs at least 3 vertices, got {len(pts)}")
    for i, (n, e) in enumerate(pts):
        if not (math.isfinite(n) and math.isfinite(e)):
            raise ObstacleError(f"{what}: vertex {i} ({n}, {e}) is not finite")
    return pts


def _checked_circle(c: KeepOutCircle, what: str) -> KeepOutCircle:
    if (
        not (math.isfinite(c.north_m) and math.isfinite(c.east_m) and math.isfinite(c.radius_m))
        or c.radius_m <= 0.0
    ):
        raise ObstacleError(f"{what}: circle {c} needs a finite centre and a radius > 0 m")
    return c


def with_geofence(
    base: Obstacles,
    *,
    exclusion_polygons_ne_m: Iterable[Sequence[PointNE]] = (),
    exclusion_circles: Iterable[KeepOutCircle] = (),
    inclusion_ne_m: Sequence[PointNE] = (),
) -> Obstacles:
    """``base`` plus a geofence's exclusion shapes; an inclusion polygon replaces base's.

    The one entry point for a ``.plan`` geofence reader (``geoFence.polygons`` with
    ``inclusion: false`` → exclusion polygons, ``geoFence.circles`` likewise), after converting
    lat/lon to (north_m, east_m) from the EKF origin. Raises :class:`ObstacleError`.
    """
    polys = list(base.polygons_ne_m)
    for i, p in enumerate(exclusion_polygons_ne_m):
        polys.append(_checked_polygon(p, f"exclusion polygon {i}"))
    circles = list(base.circles)
    for i, c in enumerate(exclusion_circles):
        circles.append(_checked_circle(c, f"exclusion circle {i}"))
    inclusion = base.inclusion_ne_m
    if inclusion_ne_m:
        inclusion = _checked_polygon(inclusion_ne_m, "inclusion polygon")
    return Obstacles(tuple(polys), tuple(circles), inclusion)


def obstacles_from_config(cfg: HelixdConfig) -> Obstacles:
    """The config's keep-out shapes and the keep-in polygon (``safety.geofence_polygon_ne_m``)."""
    pl = cfg.planning
    return with_geofence(
        Obstacles(),
        exclusion_polygons_ne_m=[p for p in pl.keep_out_polygons_ne_m if p],
        exclusion_circles=[
            KeepOutCircle(c.north_m, c.east_m, c.radius_m) for c in pl.keep_out_circles
        ],
        inclusion_ne_m=cfg.safety.geofence_polygon_ne_m,
    )


def rover_half_width_m(cfg: HelixdConfig) -> float:
    """Half the rover's width across its direction of travel: half the left-right scroll
    spacing plus one scroll radius (the outer edge of the scrolls)."""
    return cfg.vehicle.ly_m / 2.0 + cfg.vehicle.scroll_radius_m


def clearance_m(cfg: HelixdConfig) -> float:
    """How far every planned leg stays from every obstacle: half-width + ``planning.margin_m``."""
    return rover_half_width_m(cfg) + cfg.planning.margin_m
