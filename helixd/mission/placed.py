"""A ``start`` or ``local_ned`` mission placed on the Earth: the same mission in ``global``
(lat/lon), for a ground station file or the autopilot's mission list.

A ``local_ned`` mission is north/east of the EKF origin: with the origin (GPS_GLOBAL_ORIGIN,
recorded in every run's summary.json, or asked of the autopilot) each point goes through
ArduPilot's own map (:func:`helixd.base.frames.ne_to_latlon`). A ``start`` mission is x
forward / y left of the rover's pose at mission start: it also needs that pose (north/east
from the origin and the heading). Headings become compass headings; the geofence polygon and
the keep-out areas are placed the same way. Pure.
"""

from __future__ import annotations

import math
from typing import Any

from helixd.base.frames import MissionFrame, NedPose, ne_to_latlon
from helixd.base.plan import MissionFrameKind
from helixd.mission.model import Mission


class PlacementError(ValueError):
    """The mission cannot be placed (a start mission without the start pose)."""


def placed_globally(
    mission: Mission,
    origin_latlon_deg: tuple[float, float],
    start_ned: NedPose | None = None,
) -> Mission:
    """``mission`` in the ``global`` frame: ``local_ned`` through the EKF origin, ``start``
    through the origin and the rover's start pose ``start_ned``; ``global`` unchanged."""
    if mission.frame is MissionFrameKind.GLOBAL:
        return mission
    if mission.frame is MissionFrameKind.START:
        if start_ned is None:
            raise PlacementError(
                f"mission {mission.name!r} is in the 'start' frame (x forward, y left of the "
                "rover at mission start): placing it needs the start pose as well as the origin"
            )
        frame = MissionFrame.start_at(start_ned)
    else:
        frame = MissionFrame.enu()

    def place(a: float, b: float) -> tuple[float, float]:
        north, east = (a, b) if mission.frame is MissionFrameKind.LOCAL_NED else frame.to_ned(a, b)
        return ne_to_latlon(north, east, *origin_latlon_deg)

    def compass(heading_deg: float | None) -> float | None:
        if heading_deg is None or mission.frame is MissionFrameKind.LOCAL_NED:
            return heading_deg  # local_ned headings are compass headings already
        assert start_ned is not None
        ccw_from_start = math.radians(heading_deg)
        deg = math.degrees(start_ned.yaw_ned_rad - ccw_from_start)
        return (deg + 180.0) % 360.0 - 180.0

    waypoints: list[dict[str, Any]] = []
    for wp, (a, b) in zip(mission.waypoints, mission.points(), strict=True):
        lat, lon = place(a, b)
        waypoints.append(
            {
                "lat": lat,
                "lon": lon,
                "heading_deg": compass(wp.heading_deg),
                "tolerance_m": wp.tolerance_m,
                "via": wp.via,
            }
        )
    data = mission.model_dump()
    data.update(
        frame=MissionFrameKind.GLOBAL,
        waypoints=waypoints,
        geofence_polygon=[place(a, b) for a, b in mission.geofence_polygon],
        keep_out_polygons=[[place(a, b) for a, b in poly] for poly in mission.keep_out_polygons],
    )
    return Mission.model_validate(data)


NO_ORIGIN = (
    "{name!r} is in the '{frame}' frame: a ground station needs lat/lon; give the EKF origin "
    "with --origin LAT,LON (every run records it in summary.json: origin_latlon_deg)"
)


def placed_with(
    mission: Mission, origin_latlon_deg: tuple[float, float] | None, start_heading_deg: float | None
) -> Mission:
    """``mission`` placed with an operator's ``--origin`` (a ``start`` mission: the rover
    starts there, facing ``start_heading_deg``, compass); ``global`` unchanged."""
    if mission.frame is MissionFrameKind.GLOBAL:
        return mission
    if origin_latlon_deg is None:
        raise PlacementError(NO_ORIGIN.format(name=mission.name, frame=mission.frame.value))
    start = None
    if mission.frame is MissionFrameKind.START:
        if start_heading_deg is None:
            raise PlacementError(
                f"{mission.name!r} is in the 'start' frame (x forward, y left of the rover at "
                "mission start): with --origin (where the rover starts) give its compass "
                "heading there with --start-heading-deg"
            )
        start = NedPose(0.0, 0.0, math.radians(start_heading_deg))
    return placed_globally(mission, origin_latlon_deg, start)


def parse_latlon(text: str) -> tuple[float, float]:
    """``"LAT,LON"`` degrees → (lat, lon); ValueError naming what is wrong."""
    parts = [p.strip() for p in text.split(",")]
    if len(parts) != 2:
        raise ValueError(f"{text!r}: expected LAT,LON in degrees, e.g. 53.52325,-113.52632")
    try:
        lat, lon = float(parts[0]), float(parts[1])
    except ValueError:
        raise ValueError(f"{text!r}: LAT and LON must be numbers (degrees)") from None
    if not (math.isfinite(lat) and math.isfinite(lon) and -90 <= lat <= 90 and -180 <= lon <= 180):
        raise ValueError(f"{text!r}: not a place (latitude -90..90, longitude -180..180)")
    return lat, lon


__all__ = ["PlacementError", "parse_latlon", "placed_globally", "placed_with"]
