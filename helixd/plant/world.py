"""The plant's world placed around its origin: the media map on the ground and the pond's
bottom under the water, both in north/east metres for the plant's step and its sonar.

The media map (:mod:`helixd.files.media`, read by the caller's shell) and the bathymetry
(:mod:`helixd.files.bathymetry`) are placed around the world's origin (the EKF origin, SITL's
``--home``) with ArduPilot's flat-earth map; outside every media area the configured
``terrain`` lies, unless the map names a default medium.
"""

from __future__ import annotations

from helixd.base.media import MediaMapNe, Medium
from helixd.plant.plant_config import Plant, PlantConfig
from helixd.plant.sonar import BathymetryNe


def media_ne(config: PlantConfig) -> MediaMapNe | None:
    """``config``'s media map placed around its EKF origin, the configured ``terrain`` outside
    every area unless the map names a default; None without a map (or for the sitl_skid plant,
    which has no terrain). The shell reads ``media_file`` into ``media`` first (the simulator:
    :func:`helixd.sim.server.with_media`)."""
    if config.media_file is not None and config.media is None:
        raise ValueError("media_file is read by the shell into media before the plant starts")
    if config.media is None or config.plant is not Plant.HELIX:
        return None
    return config.media.to_ne(
        (config.origin_lat_deg, config.origin_lon_deg), fallback=Medium(config.terrain.value)
    )


def bathymetry_ne(config: PlantConfig) -> BathymetryNe | None:
    """``config``'s pond bottom placed around its EKF origin, for the sonar; None without one."""
    if config.bathymetry is None:
        return None
    return BathymetryNe(config.bathymetry, config.origin_lat_deg, config.origin_lon_deg)
