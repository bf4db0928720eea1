"""Mission files (``config/missions/*.yaml``): what to fly, in which mode and frame.

Frames (see :mod:`helixd.base.frames`):

* ``start``: waypoints as ``x``/``y`` metres, x forward and y left of the pose at mission
  start; ``heading_deg`` counter-clockwise from the start heading.
* ``local_ned``: waypoints as ``north``/``east`` metres from the EKF origin; ``heading_deg`` is a
  compass heading (clockwise from North).
* ``global``: waypoints as ``lat``/``lon`` degrees; ``heading_deg`` compass, as above.

Mission-level safety overrides (a survey writes them): ``geofence_polygon`` (vertices in the
mission's own coordinates) replaces the config's keep-in polygon and radius,
``geofence_radius_m`` a radius, ``time_limit_s`` the time limit — see
:func:`helixd.mission.validate.apply_mission_limits`. Ground-station files (.plan, .waypoints)
are read into this model by :mod:`helixd.mission.formats`.
"""

from __future__ import annotations

import math
from pathlib import Path

from pydantic import Field, ValidationInfo, model_validator

from helixd.base.frames import latlon_to_ne
from helixd.base.plan import MissionFrameKind, MotionMode
from helixd.base.polygon import polygon_problems
from helixd.config import MissionLimits
from helixd.files.models import ConfigFileError, InputModel, load_yaml_model

DUPLICATE_EPSILON_M = 0.01  # consecutive points closer than this are the same point


_ALL_COORDS = ("x", "y", "north", "east", "lat", "lon")
_COORDS = {
    MissionFrameKind.START: ("x", "y"),
    MissionFrameKind.LOCAL_NED: ("north", "east"),
    MissionFrameKind.GLOBAL: ("lat", "lon"),
}


class WaypointSpec(InputModel):
    x: float | None = Field(None, description="metres forward of the start pose (start frame)")
    y: float | None = Field(None, description="metres left of the start pose (start frame)")
    north: float | None = Field(None, description="metres north of the EKF origin (local_ned)")
    east: float | None = Field(None, description="metres east of the EKF origin (local_ned)")
    lat: float | None = Field(None, ge=-90.0, le=90.0, description="latitude, degrees (global)")
    lon: float | None = Field(None, ge=-180.0, le=180.0, description="longitude, degrees (global)")
    heading_deg: float | None = Field(
        None, ge=-360.0, le=360.0, description="optional final heading at this waypoint (deg)"
    )
    tolerance_m: float | None = Field(
        None, gt=0.05, le=20.0, description="per-waypoint arrival radius override (m)"
    )
    via: bool = Field(
        False,
        description="an intermediate point the planner inserted on the way to the next "
        "waypoint, not one of the operator's waypoints (not numbered or counted as one)",
    )

    def given(self) -> set[str]:
        return {
            k for k in ("x", "y", "north", "east", "lat", "lon") if getattr(self, k) is not None
        }


class Mission(InputModel):
    name: str = Field(min_length=1, max_length=80, pattern=r"^[A-Za-z0-9_.\- ]+$")
    mode: MotionMode
    frame: MissionFrameKind = MissionFrameKind.START
    waypoints: tuple[WaypointSpec, ...] = Field(description="at least one waypoint")
    tolerance_m: float | None = Field(
        None, gt=0.05, le=20.0, description="arrival radius for every waypoint (m)"
    )
    speed_mps: float | None = Field(None, gt=0.0, le=3.0, description="speed cap override (m/s)")
    # Mission-level safety overrides (a survey carries its own fence and time budget):
    geofence_polygon: tuple[tuple[float, float], ...] = Field(
        (),
        max_length=1000,
        description="keep-in polygon in the mission's own coordinates (x/y, north/east or "
        "lat/lon pairs); replaces safety.geofence_polygon_ne_m and safety.geofence_radius_m",
    )
    geofence_radius_m: float | None = Field(
        None,
        gt=0.0,
        le=10_000.0,
        description="with geofence_polygon: also a radius around the start point (None = the "
        "polygon alone); without: replaces safety.geofence_radius_m (None = the config's)",
    )
    time_limit_s: float | None = Field(
        None, gt=0.0, le=86_400.0, description="replaces safety.mission_time_limit_s (s)"
    )
    keep_out_polygons: tuple[tuple[tuple[float, float], ...], ...] = Field(
        (),
        max_length=1000,
        description="areas the rover must not enter (islands, exclusion zones), each a polygon "
        "in the mission's own coordinates (north/east or lat/lon pairs; not in the start "
        "frame): legs are planned around them, a waypoint inside one is refused",
    )

    @model_validator(mode="after")
    def _check_points(self, info: ValidationInfo) -> Mission:
        if not self.waypoints:
            raise ValueError("waypoints: the list is empty; a mission needs at least one waypoint")
        wanted = _COORDS[self.frame]
        ka, kb = wanted
        o1, o2, o3, o4 = (k for k in _ALL_COORDS if k not in wanted)
        for i, wp in enumerate(self.waypoints):
            d = wp.__dict__  # plain attribute reads: this loop runs once per waypoint
            if (
                d[ka] is not None
                and d[kb] is not None
                and d[o1] is None
                and d[o2] is None
                and d[o3] is None
                and d[o4] is None
            ):
                continue
            got = wp.given()
            if got != set(wanted):
                raise ValueError(
                    f"waypoints.{i}: frame '{self.frame.value}' needs exactly "
                    f"{wanted[0]} and {wanted[1]}, got {sorted(got) or 'no coordinates'}"
                )
        pts = self.points()
        is_global = self.frame is MissionFrameKind.GLOBAL
        hypot = math.hypot
        for i in range(1, len(pts)):
            (a0, a1), (b0, b1) = pts[i - 1], pts[i]
            if is_global:
                dn, de = latlon_to_ne(b0, b1, a0, a1)
                gap = hypot(dn, de)
            else:
                gap = hypot(b0 - a0, b1 - a1)
            if gap < DUPLICATE_EPSILON_M:
                raise ValueError(
                    f"waypoints.{i}: same point as waypoints.{i - 1} "
                    f"({b0}, {b1}); consecutive waypoints must differ by >= "
                    f"{DUPLICATE_EPSILON_M} m"
                )
        fence_problems = self.fence_problems()
        if fence_problems:
            raise ValueError("\n".join(f"geofence_polygon: {p}" for p in fence_problems))
        keep_out_problems = self.keep_out_problems()
        if keep_out_problems:
            raise ValueError("\n".join(keep_out_problems))
        limits = (info.context or {}).get("limits") if info.context else None
        if isinstance(limits, MissionLimits) and self.frame is not MissionFrameKind.GLOBAL:
            for i, (a, b) in enumerate(pts):
                rng = math.hypot(a, b)
                if rng > limits.max_range_m:
                    raise ValueError(
                        f"waypoints.{i}: ({a}, {b}) is {rng:.1f} m from the origin; "
                        f"allowed at most mission.max_range_m = {limits.max_range_m} m"
                    )
        return self

    def keep_out_problems(self) -> list[str]:
        """Why ``keep_out_polygons`` cannot be used (empty when absent or usable)."""
        if not self.keep_out_polygons:
            return []
        if self.frame is MissionFrameKind.START:
            return [
                "keep_out_polygons: a start-frame mission moves with the rover; keep-out areas "
                "need a local_ned or global mission"
            ]
        out: list[str] = []
        for i, poly in enumerate(self.keep_out_polygons):
            if len(poly) > 1000:
                out.append(f"keep_out_polygons.{i}: {len(poly)} vertices; allowed at most 1000")
                continue
            out.extend(f"keep_out_polygons.{i}: {p}" for p in self._ring_problems(poly))
        return out[:5]

    def keep_outs_ne(
        self, origin_latlon_deg: tuple[float, float] | None = None
    ) -> list[tuple[tuple[float, float], ...]]:
        """``keep_out_polygons`` as (north_m, east_m) polygons: as written (``local_ned``), or
        around ``origin_latlon_deg`` (``global``; default: waypoint 0)."""
        if self.frame is not MissionFrameKind.GLOBAL:
            return [tuple(p) for p in self.keep_out_polygons]
        origin = origin_latlon_deg or self.points()[0]
        return [
            tuple(latlon_to_ne(a, b, *origin) for a, b in poly) for poly in self.keep_out_polygons
        ]

    def fence_problems(self) -> list[str]:
        """Why ``geofence_polygon`` cannot fence anything (empty when absent or usable)."""
        return self._ring_problems(self.geofence_polygon)

    def _ring_problems(self, poly: tuple[tuple[float, float], ...]) -> list[str]:
        """Why ``poly`` (mission coordinates) is no usable polygon (empty: none or usable)."""
        if not poly:
            return []
        if self.frame is MissionFrameKind.GLOBAL:
            bad = [
                f"vertex {i} ({a}, {b}) is not a latitude/longitude pair (-90..90, -180..180)"
                for i, (a, b) in enumerate(poly)
                if not (-90.0 <= a <= 90.0 and -180.0 <= b <= 180.0)
            ]
            if bad:
                return bad[:3]
            lat0, lon0 = poly[0]
            plane = [latlon_to_ne(a, b, lat0, lon0) for a, b in poly]
        else:
            plane = list(poly)
        return polygon_problems(plane)

    def points(self) -> list[tuple[float, float]]:
        """Raw coordinate pairs in the file's own frame: (x, y), (north, east) or (lat, lon)."""
        a, b = _COORDS[self.frame]
        return [(float(getattr(w, a)), float(getattr(w, b))) for w in self.waypoints]


def load_mission(path: Path | str, limits: MissionLimits | None = None) -> Mission:
    """Load and validate a mission file; raises ConfigFileError with one line per problem."""
    return load_yaml_model(path, Mission, context={"limits": limits or MissionLimits()})


__all__ = [
    "ConfigFileError",
    "Mission",
    "MissionFrameKind",
    "MotionMode",
    "WaypointSpec",
    "load_mission",
]
