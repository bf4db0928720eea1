"""The simulator's map: a raster of solid cells (helixd.plant.collisions.ObstacleRaster) that the
rover stops against, and what ``helixd run --sim --map`` hands the embedded simulator."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.plant.collisions import ObstacleRaster, SimObstacles, distance_m
from tests.support.simcore import (
    EmbeddedStart,
    assert_step_never_closer,
    capture_embedded_start,
    make_core,
    skid_north_contacts,
)

# 0.1 m cells from (north 0, east -5), 120 rows × 100 cols: north 0..12, east -5..5
RES = 0.1
ORIGIN = (0.0, -5.0)


def wall_raster() -> ObstacleRaster:
    occ = np.zeros((120, 100), dtype=bool)
    occ[80:90, 20:80] = True  # north 8.0..9.0, east -3.0..3.0
    return ObstacleRaster(ORIGIN[0], ORIGIN[1], RES, occ)


WALL_POLY = ((8.0, -3.0), (8.0, 3.0), (9.0, 3.0), (9.0, -3.0))


def test_raster_distance_is_the_distance_to_the_occupied_squares() -> None:
    obs = SimObstacles(raster=wall_raster())
    poly = SimObstacles(polygons_ne_m=(WALL_POLY,))
    assert distance_m(obs, 8.5, 0.0) == 0.0
    assert distance_m(obs, 7.7, 0.0) == pytest.approx(0.3)
    assert distance_m(obs, 8.5, 3.2) == pytest.approx(0.2)
    assert distance_m(obs, 0.0, 0.0) == math.inf  # beyond the contact reach: not measured
    assert distance_m(obs, 500.0, 500.0) == math.inf  # far off the raster
    for n, e in [(7.8, 0.1), (9.25, -3.1), (7.9, 3.05)]:
        assert distance_m(obs, n, e) == pytest.approx(distance_m(poly, n, e), abs=1e-9)


@settings(max_examples=300, deadline=None)
@given(st.floats(6.0, 11.0), st.floats(-5.0, 5.0))
def test_raster_matches_the_same_wall_as_a_polygon_within_reach(n: float, e: float) -> None:
    obs = SimObstacles(raster=wall_raster())
    poly = SimObstacles(polygons_ne_m=(WALL_POLY,))
    d_poly = distance_m(poly, n, e)
    d_raster = distance_m(obs, n, e)
    if d_poly <= obs.raster_reach_m - 1e-6:
        assert d_raster == pytest.approx(d_poly, abs=1e-6)
    else:
        assert d_raster >= obs.raster_reach_m - 1e-6


@pytest.mark.parametrize(("seed", "reach_m"), [(3, 0.5), (4, 0.1), (5, 2.0), (6, 10.0)])
def test_near_mask_is_the_brute_force_box_dilation(seed: int, reach_m: float) -> None:
    rng = np.random.default_rng(seed)
    occ = rng.random((23, 17)) > 0.97
    r = ObstacleRaster(0.0, 0.0, 0.25, occ)
    near = r.near_mask(reach_m)
    k = r.reach_cells(reach_m)
    brute = np.zeros_like(occ)
    for i, j in zip(*np.nonzero(occ), strict=True):
        brute[max(i - k, 0) : i + k + 1, max(j - k, 0) : j + k + 1] = True
    assert (near == brute).all()


def test_bad_rasters_are_refused() -> None:
    with pytest.raises(ValueError, match="2-D bool"):
        ObstacleRaster(0.0, 0.0, 0.1, np.zeros((3, 3), dtype=np.uint8))
    with pytest.raises(ValueError, match="finite"):
        ObstacleRaster(math.nan, 0.0, 0.1, np.zeros((3, 3), dtype=bool))
    with pytest.raises(ValueError, match="resolution"):
        ObstacleRaster(0.0, 0.0, 0.0, np.zeros((3, 3), dtype=bool))
    with pytest.raises(ValueError, match="cells"):
        ObstacleRaster(0.0, 0.0, 0.1, np.zeros((0, 3), dtype=bool))


@settings(max_examples=300, deadline=None)
@given(st.floats(6, 11), st.floats(-4, 4), st.floats(-0.3, 0.3), st.floats(-0.3, 0.3))
def test_a_step_never_brings_the_body_closer_to_the_map_once_touching(
    n: float, e: float, dn: float, de: float
) -> None:
    assert_step_never_closer(SimObstacles(raster=wall_raster()), n, e, dn, de)


def test_driving_into_the_map_wall_stops_the_rover_and_logs_the_contact() -> None:
    core = make_core(1, plant="sitl_skid", obstacles=SimObstacles(raster=wall_raster()))
    contacts = skid_north_contacts(core, 25.0)
    assert len(contacts) == 1
    assert 7.0 < core.phys.north_m <= 8.0 - 0.429 + 1e-9
    assert core.phys.speed_mps == 0.0


def _write_map(tmp_path: Path) -> Path:
    """map_server trinary map: 20 m × 20 m at 0.1 m from (-10, -2) (x east, y north); a wall
    at north 8..9, east -3..3 (black) and an unknown patch (grey) at north 14..15."""
    from PIL import Image

    rows, cols = 200, 200  # north -2..18, east -10..10
    px = np.full((rows, cols), 254, dtype=np.uint8)  # free
    px[100:110, 70:130] = 0  # occupied: north 8..9 (rows from the south), east -3..3
    px[160:170, 70:130] = 205  # unknown
    Image.fromarray(px[::-1], mode="L").save(tmp_path / "m.pgm")
    y = tmp_path / "m.yaml"
    y.write_text(
        "image: m.pgm\nresolution: 0.1\norigin: [-10.0, -2.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n",
        encoding="utf-8",
    )
    return y


def test_sim_world_takes_the_maps_occupied_cells_and_the_config_keep_outs(
    tmp_path: Path,
) -> None:
    from helixd.cli.simulated import sim_world
    from helixd.config.root import HelixdConfig
    from helixd.planning.mapfile import load_map

    occ = load_map(_write_map(tmp_path), 16_000_000)
    cfg = HelixdConfig.model_validate(
        {
            "planning": {
                "keep_out_polygons_ne_m": [[[20, 0], [20, 2], [22, 2]]],
                "keep_out_circles": [{"north_m": -5, "east_m": 0, "radius_m": 1}],
            }
        }
    )
    world = sim_world(cfg, occ)
    assert world.contact_radius_m == pytest.approx(0.429)
    assert len(world.polygons_ne_m) == 1 and len(world.circles) == 1
    assert distance_m(world, 8.5, 0.0) == 0.0  # the wall is solid
    assert distance_m(world, 14.5, 0.0) > 5.0  # unknown is not solid (the polygon: 5.5 m)
    assert distance_m(world, -5.0, 0.5) == 0.0  # the keep-out circle is
    assert bool(occ.blocked[165, 100]) and not bool(occ.solid[165, 100])  # planner: blocked


def test_run_sim_map_hands_the_world_to_the_embedded_simulator(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    seen = capture_embedded_start(monkeypatch)
    from helixd.cli.app import main

    mission = tmp_path / "across.yaml"
    mission.write_text(
        "name: t\nmode: roll\nframe: local_ned\nwaypoints:\n- north: 16.0\n  east: 0.0\n",
        encoding="utf-8",
    )
    with pytest.raises(EmbeddedStart):
        main(["run", "--sim", "--mission", str(mission), "--map", str(_write_map(tmp_path))])
    (cfg,) = seen
    assert cfg.obstacles.raster is not None
    assert distance_m(cfg.obstacles, 8.5, 0.0) == 0.0
    assert "leg start → wp 1" in capsys.readouterr().out  # and the legs were planned


def test_the_simulator_loads_nothing_of_planning() -> None:
    code = (
        "import sys, helixd.sim, helixd.plant.collisions, helixd.sim.server;"
        "bad = sorted(m for m in sys.modules if m.startswith(('helixd.planning', "
        "'helixd.control')));"
        "print(bad); assert not bad"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert res.returncode == 0, res.stdout + res.stderr
