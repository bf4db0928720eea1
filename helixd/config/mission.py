"""Missions and the paths around what is in the way (``mission``, ``planning``)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import AfterValidator, Field

from helixd.config.fields import ConfigSection, finite_ne_point, sane_polygon

# ---------------------------------------------------------------------------------------------
# Missions


class MissionLimits(ConfigSection):
    max_range_m: float = Field(500.0, gt=0.0, le=10_000.0)
    """waypoints farther than this from origin refused (m)"""
    max_start_distance_m: float = Field(100.0, gt=0.0, le=10_000.0)
    """first waypoint farther than this from the rover is refused at preflight (m)"""
    ground_station_mode: Literal["roll", "scroll", "omni"] | None = Field(None)
    """motion mode for .plan/.waypoints missions (they carry none); None = the --mode option is
    required"""


# ---------------------------------------------------------------------------------------------
# Planning (helixd.planning): paths around what is in the way


class KeepOutCircleConfig(ConfigSection):
    north_m: float = Field(ge=-1e5, le=1e5)
    """centre, north of EKF origin (m)"""
    east_m: float = Field(ge=-1e5, le=1e5)
    """centre, east of EKF origin (m)"""
    radius_m: float = Field(gt=0.0, le=10_000.0)
    """radius (m)"""


class PlanningConfig(ConfigSection):
    """Grid path planning between consecutive waypoints (local_ned missions).

    Obstacles (a map_server map given with ``--map``, the keep-out shapes below, and everything
    outside ``safety.geofence_polygon_ne_m``) are inflated by the rover's half-width
    (``vehicle.ly_m / 2 + vehicle.scroll_radius_m``) plus ``margin_m``.
    """

    enabled: bool = Field(True)
    """plan around obstacles when any are given"""
    margin_m: float = Field(0.5, ge=0.0, le=20.0)
    """clearance added to the rover's half-width (m)"""
    resolution_m: float = Field(0.1, ge=0.02, le=5.0)
    """grid cell size when no map gives one (m)"""
    pad_m: float = Field(20.0, ge=0.0, le=1000.0)
    """grid extends this far beyond waypoints/shapes (m)"""
    max_cells: int = Field(16_000_000, ge=10_000, le=100_000_000)
    """largest grid (or map) accepted (cells)"""
    via_tolerance_m: float = Field(0.3, gt=0.05, le=5.0)
    """arrival radius of inserted intermediate waypoints (m)"""
    start_ne_m: Annotated[tuple[float, float], AfterValidator(finite_ne_point)] = Field((0.0, 0.0))
    """where the first leg is planned from, (north_m, east_m)"""
    keep_out_polygons_ne_m: tuple[
        Annotated[tuple[tuple[float, float], ...], AfterValidator(sane_polygon)], ...
    ] = Field((), max_length=1000)
    """keep-out polygons, (north_m, east_m) vertices from the EKF origin"""
    keep_out_circles: tuple[KeepOutCircleConfig, ...] = Field((), max_length=10_000)
    """keep-out circles (north_m, east_m, radius_m)"""
