"""Re-export of :mod:`helixd.base.frames` (the old import path; new code imports the base) and
of the true geodesics in :mod:`helixd.geodesy`."""

from helixd.base.frames import (
    ARDUPILOT_EARTH_RADIUS_M,
    EARTH_RADIUS_M,
    METRES_PER_DEGREE,
    MissionFrame,
    NedPose,
    latlon_to_ne,
    ne_to_latlon,
)
from helixd.geodesy import geodesic_latlon, geodesic_ne_m

__all__ = [
    "ARDUPILOT_EARTH_RADIUS_M",
    "EARTH_RADIUS_M",
    "METRES_PER_DEGREE",
    "MissionFrame",
    "NedPose",
    "geodesic_latlon",
    "geodesic_ne_m",
    "latlon_to_ne",
    "ne_to_latlon",
]
