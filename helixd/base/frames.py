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

# ArduPilot's Location maths (libraries/AP_Common/Location.cpp, AP_Math/definitions.h):
# RADIUS_OF_EARTH 6378100 m, LOCATION_SCALING_FACTOR = 1e-7 * DEG_TO_RAD * RADIUS_OF_EARTH.
ARDUPILOT_EARTH_RADIUS_M = 6_378_100.0
METRES_PER_DEGREE = math.radians(1.0) * ARDUPILOT_EARTH_RADIUS_M  # 111 318.845 m
LONGITUDE_SCALE_MIN = 0.01  # Location::longitude_scale() clamps cos(lat) to [0.01, 1]


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


def _check_latlon(what: str, lat_deg: float, lon_deg: float) -> None:
    require_finite(what, lat_deg, lon_deg)
    if not (-90.0 <= lat_deg <= 90.0 and -180.0 <= lon_deg <= 180.0):
        raise ValueError(
            f"{what} ({lat_deg}, {lon_deg}) is not on the Earth: latitude must be in "
            "-90..90 and longitude in -180..180 degrees"
        )


def _longitude_scale(lat_deg: float) -> float:
    return min(max(math.cos(math.radians(lat_deg)), LONGITUDE_SCALE_MIN), 1.0)


def _wrap_lon_deg(lon_deg: float) -> float:
    """Longitude difference / value into [-180, 180) (ArduPilot's diff_longitude/wrap)."""
    return (lon_deg + 180.0) % 360.0 - 180.0


def latlon_to_ne(
    lat_deg: float, lon_deg: float, origin_lat_deg: float, origin_lon_deg: float
) -> tuple[float, float]:
    """(lat, lon) → (north_m, east_m) in the autopilot's EKF frame around ``origin``.

    This is the frame LOCAL_POSITION_NED is in: ArduPilot's EKF3 places each GPS fix at
    ``EKF_origin.get_distance_NE_ftype(gps_loc)`` (AP_NavEKF3_PosVelFusion /
    Location.cpp), a spherical flat-earth map (radius 6 378 100 m, longitude scaled by the
    cosine of the mean latitude). A waypoint must be converted with the *same* map, or the
    rover stops where the autopilot's pose says "there" while the GPS says elsewhere: the
    true WGS-84 geodesic (geographiclib) differs from this map by about 0.1–0.2 % of the
    distance (0.9 m north and 1.9 m east at 1 km at 49° N, see tests/unit/test_geodesy.py),
    which is the offset an exact-geodesy conversion would put into every global mission.
    Longitude differences wrap across ±180°. Raises ValueError off the Earth, NonFiniteError
    on NaN/inf.
    """
    _check_latlon("lat/lon", lat_deg, lon_deg)
    _check_latlon("origin lat/lon", origin_lat_deg, origin_lon_deg)
    north_m = (lat_deg - origin_lat_deg) * METRES_PER_DEGREE
    scale = _longitude_scale((lat_deg + origin_lat_deg) / 2.0)
    east_m = _wrap_lon_deg(lon_deg - origin_lon_deg) * METRES_PER_DEGREE * scale
    return north_m, east_m


def ne_to_latlon(
    north_m: float, east_m: float, origin_lat_deg: float, origin_lon_deg: float
) -> tuple[float, float]:
    """Inverse of :func:`latlon_to_ne` (ArduPilot's ``Location::offset_latlng``): the lat/lon
    of a LOCAL_POSITION_NED point. Exact inverse (mean-latitude scale both ways); latitude is
    clamped to ±90° and longitude wrapped into [-180, 180)."""
    require_finite("north/east", north_m, east_m)
    _check_latlon("origin lat/lon", origin_lat_deg, origin_lon_deg)
    dlat = north_m / METRES_PER_DEGREE
    lat = min(max(origin_lat_deg + dlat, -90.0), 90.0)
    scale = _longitude_scale((lat + origin_lat_deg) / 2.0)
    lon = _wrap_lon_deg(origin_lon_deg + east_m / (METRES_PER_DEGREE * scale))
    return lat, lon
