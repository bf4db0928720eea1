"""Re-export of :mod:`helixd.base.frames` (the old import path; new code imports the base)."""

from helixd.base.frames import (
    EARTH_RADIUS_M,
    MissionFrame,
    NedPose,
    latlon_to_ne,
    ne_to_latlon,
)

__all__ = ["EARTH_RADIUS_M", "MissionFrame", "NedPose", "latlon_to_ne", "ne_to_latlon"]
