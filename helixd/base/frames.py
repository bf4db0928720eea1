"""Frame conversions, done once at the edge between MAVLink (NED) and the mission frame.

MAVLink's LOCAL_POSITION_NED is North-East-Down from the EKF origin and ATTITUDE yaw is
clockwise from North. The control core works in a right-handed planar frame with yaw
counter-clockwise (the thesis's ROS/ENU convention). Mission frames:

* ``start``: x forward, y left, origin and heading taken from the pose at mission start.
* ``local_ned`` and ``global``: x = East, y = North (ENU) from the EKF origin; yaw CCW from East.
  Waypoints written as north/east (or lat/lon) are converted into this frame when loaded.

Total: every conversion raises :class:`helixd.base.geometry.NonFiniteError` on a non-finite input
(a pose with a NaN has no place in any frame); finite in, finite out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from helixd.base.angles import wrap_pi
from helixd.base.geometry import Pose2D, require_finite

EARTH_RADIUS_M = 6_378_137.0  # WGS-84 equatorial radius, as ArduPilot's location code uses


@dataclass(frozen=True, slots=True)
class NedPose:
    """Pose as MAVLink reports it: metres from the EKF origin, yaw clockwise from North."""

    north_m: float
    east_m: float
    yaw_ned_rad: float


@dataclass(frozen=True, slots=True)
class MissionFrame:
    """Maps NED poses into a mission frame and mission points back to NED.

    ``origin`` is the NED pose that becomes (0, 0, 0) in a ``start`` frame; for the ENU frames
    (``local_ned``/``global``) it is None.
    """

    origin: NedPose | None = None

    @staticmethod
    def enu() -> MissionFrame:
        return MissionFrame(origin=None)

    @staticmethod
    def start_at(pose: NedPose) -> MissionFrame:
        return MissionFrame(origin=pose)

    def to_mission(self, pose: NedPose) -> Pose2D:
        require_finite("NED pose", pose.north_m, pose.east_m, pose.yaw_ned_rad)
        if self.origin is None:
            return Pose2D(
                x_m=pose.east_m, y_m=pose.north_m, yaw_rad=wrap_pi(math.pi / 2 - pose.yaw_ned_rad)
            )
        o = self.origin
        require_finite("frame origin", o.north_m, o.east_m, o.yaw_ned_rad)
        dn = pose.north_m - o.north_m
        de = pose.east_m - o.east_m
        c, s = math.cos(o.yaw_ned_rad), math.sin(o.yaw_ned_rad)
        return Pose2D(
            x_m=dn * c + de * s,
            y_m=dn * s - de * c,
            yaw_rad=wrap_pi(-(pose.yaw_ned_rad - o.yaw_ned_rad)),
        )

    def to_ned(self, x_m: float, y_m: float) -> tuple[float, float]:
        """Mission-frame point → (north_m, east_m)."""
        require_finite("mission point", x_m, y_m)
        if self.origin is None:
            return y_m, x_m
        o = self.origin
        c, s = math.cos(o.yaw_ned_rad), math.sin(o.yaw_ned_rad)
        return o.north_m + x_m * c + y_m * s, o.east_m + x_m * s - y_m * c

    def yaw_to_ned(self, yaw_rad: float) -> float:
        if self.origin is None:
            return wrap_pi(math.pi / 2 - yaw_rad)
        return wrap_pi(self.origin.yaw_ned_rad - yaw_rad)


def latlon_to_ne(
    lat_deg: float, lon_deg: float, origin_lat_deg: float, origin_lon_deg: float
) -> tuple[float, float]:
    """Equirectangular projection around the EKF origin (metres north, metres east).

    Accurate to centimetres over the few hundred metres a Helix mission spans.
    """
    require_finite("lat/lon", lat_deg, lon_deg, origin_lat_deg, origin_lon_deg)
    north_m = math.radians(lat_deg - origin_lat_deg) * EARTH_RADIUS_M
    east_m = (
        math.radians(lon_deg - origin_lon_deg)
        * EARTH_RADIUS_M
        * math.cos(math.radians(origin_lat_deg))
    )
    return north_m, east_m


def ne_to_latlon(
    north_m: float, east_m: float, origin_lat_deg: float, origin_lon_deg: float
) -> tuple[float, float]:
    require_finite("north/east", north_m, east_m, origin_lat_deg, origin_lon_deg)
    lat = origin_lat_deg + math.degrees(north_m / EARTH_RADIUS_M)
    lon = origin_lon_deg + math.degrees(
        east_m / (EARTH_RADIUS_M * math.cos(math.radians(origin_lat_deg)))
    )
    return lat, lon
