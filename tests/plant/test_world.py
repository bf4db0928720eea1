"""A media map placed on the plant's ground (helixd.plant.world.media_ne): around the world's
origin, the configured terrain outside every area unless the map names its own, nothing for
the skid plant or without a map, and a file never read behind the shell's back."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.frames import latlon_to_ne
from helixd.base.media import MediaArea, MediaFrame, MediaMap, Medium
from helixd.files.bathymetry import Bathymetry
from helixd.plant.ground import Terrain
from helixd.plant.plant_config import Plant, PlantConfig
from helixd.plant.world import bathymetry_ne, media_ne

SQUARE_NE = ((-5.0, -5.0), (-5.0, 5.0), (5.0, 5.0), (5.0, -5.0))
POND = MediaMap(MediaFrame.LOCAL_NED, (MediaArea(Medium.WATER, SQUARE_NE),))


def test_without_a_map_there_is_nothing_to_place() -> None:
    assert media_ne(PlantConfig()) is None


def test_the_skid_plant_has_no_terrain_so_no_media() -> None:
    assert media_ne(PlantConfig(media=POND, plant=Plant.SITL_SKID)) is None


def test_a_local_map_lies_as_drawn_with_the_configured_terrain_around_it() -> None:
    placed = media_ne(PlantConfig(media=POND, terrain=Terrain.MUD))
    assert placed is not None
    assert placed.medium_at(0.0, 0.0) is Medium.WATER
    assert placed.medium_at(20.0, 0.0) is Medium.MUD


def test_a_map_naming_its_default_medium_keeps_it() -> None:
    sandy = MediaMap(POND.frame, POND.areas, default_medium=Medium.SAND)
    placed = media_ne(PlantConfig(media=sandy, terrain=Terrain.MUD))
    assert placed is not None and placed.medium_at(20.0, 0.0) is Medium.SAND


def test_a_lat_lon_map_is_placed_around_the_worlds_origin() -> None:
    cfg = PlantConfig()
    lat0, lon0 = cfg.origin_lat_deg, cfg.origin_lon_deg
    # a water square about 100..110 m north of the origin, given in degrees
    ring = tuple(
        (lat0 + dn / 111_320.0, lon0 + de / 66_000.0)
        for dn, de in ((100.0, -5.0), (100.0, 5.0), (110.0, 5.0), (110.0, -5.0))
    )
    lakeside = MediaMap(MediaFrame.GLOBAL, (MediaArea(Medium.WATER, ring),))
    placed = media_ne(cfg.model_copy(update={"media": lakeside}))
    assert placed is not None
    north, east = latlon_to_ne(lat0 + 105.0 / 111_320.0, lon0, lat0, lon0)
    assert placed.medium_at(north, east) is Medium.WATER
    assert placed.medium_at(0.0, 0.0) is Medium.HARD  # the start: the configured terrain
    moved = cfg.model_copy(update={"media": lakeside, "origin_lat_deg": lat0 + 0.01})
    placed_elsewhere = media_ne(moved)
    assert placed_elsewhere is not None
    assert placed_elsewhere.medium_at(north, east) is Medium.HARD  # the map stayed where it is


def test_a_media_file_not_yet_read_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="read by the shell"):
        media_ne(PlantConfig(media_file=tmp_path / "pond.geojson"))


def test_the_ponds_bottom_is_placed_around_the_worlds_origin() -> None:
    assert bathymetry_ne(PlantConfig()) is None
    cfg = PlantConfig()
    lat0, lon0 = cfg.origin_lat_deg, cfg.origin_lon_deg
    bottom = Bathymetry.model_validate(
        {
            "format": "helixd-bathymetry/1",
            "south_west": {"lat_deg": lat0 - 1e-4, "lon_deg": lon0 - 1e-4},
            "cell_m": 5.0,
            "depth_m": [[2.0] * 6] * 4 + [[None] * 6],
        }
    )
    placed = bathymetry_ne(cfg.model_copy(update={"bathymetry": bottom}))
    assert placed is not None
    assert placed.depth_at(0.0, 0.0) == pytest.approx(2.0)
    assert placed.depth_at(500.0, 0.0) is None  # off the grid: dry
