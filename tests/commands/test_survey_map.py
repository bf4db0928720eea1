"""``helixd survey-map``: the files a crew takes home (helixd/commands/survey_map.py, cli)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
import tifffile

from helixd.base.frames import METRES_PER_DEGREE, ne_to_latlon
from helixd.mission.formats import load_mission_file
from helixd.recorder.payload_log import COLUMNS, CSV_COMMENT
from tests.support.cli import run_main

ROOT = Path(__file__).resolve().parents[2]
REF = (53.5234, -113.5262)


def depth(n: float, e: float) -> float:
    return 1.0 + 0.05 * n + 0.02 * e


def write_run(run: Path, points: list[tuple[float, float]]) -> Path:
    run.mkdir(parents=True)
    rows = []
    for k, (n, e) in enumerate(points):
        lat, lon = ne_to_latlon(n, e, *REF)
        rows.append(
            f"{k * 0.2:.3f},{n:.3f},{e:.3f},0.0,{lat:.9f},{lon:.9f},water,MANUAL,"
            f"DISTANCE_SENSOR,depth_m,{depth(n, e):.4f},0,0,{depth(n, e):.4f}"
        )
    (run / "payload.csv").write_text(
        CSV_COMMENT + "\n" + ",".join(COLUMNS) + "\n" + "\n".join(rows) + "\n"
    )
    return run


def area_file(tmp_path: Path, size_m: float) -> Path:
    ring = [
        ne_to_latlon(n, e, *REF)
        for n, e in ((0, 0), (0, size_m), (size_m, size_m), (size_m, 0), (0, 0))
    ]
    path = tmp_path / "area.geojson"
    coords = [[lon, lat] for lat, lon in ring]
    path.write_text(
        json.dumps(
            {
                "type": "FeatureCollection",
                "features": [
                    {
                        "type": "Feature",
                        "properties": {},
                        "geometry": {"type": "Polygon", "coordinates": [coords]},
                    }
                ],
            }
        )
    )
    return path


def lines(spacing: float, size: float, east_from: float = 0.0) -> list[tuple[float, float]]:
    return [
        (float(n), float(e))
        for e in np.arange(east_from + spacing / 2, size, spacing)
        for n in np.arange(0.1, size, 0.25)
    ]


def test_two_runs_grid_together_into_every_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    west = write_run(tmp_path / "run1", [p for p in lines(2.0, 20.0) if p[1] < 10.0])
    east = write_run(tmp_path / "run2", [p for p in lines(2.0, 20.0) if p[1] > 10.0])
    out = tmp_path / "map"
    code, stdout, _ = run_main(
        [
            "survey-map",
            str(west),
            str(east),
            "--area",
            str(area_file(tmp_path, 20.0)),
            "-o",
            str(out),
        ],
        capsys,
    )
    assert code == 0, stdout
    assert "coverage 100.0 %" in stdout and "0 cells without a reading" in stdout
    figures = json.loads((out / "survey-map.json").read_text())
    assert figures["samples"] == len(lines(2.0, 20.0)) and figures["holes_mission_items"] == 0
    assert not (out / "holes.yaml").exists()
    # the x y z CSV: one row per cell, the plane's depth at each centre (linear is exact)
    with (out / "depth.csv").open() as fh:
        cells = list(csv.DictReader(fh))
    assert len(cells) == 100
    for c in cells:
        assert float(c["z_depth_m"]) == pytest.approx(
            depth(float(c["y_north_m"]), float(c["x_east_m"])), abs=0.01
        )
        assert int(c["count"]) >= 8
    # the GeoTIFF: float32, north up, placed in EPSG:4326 at the grid's north-west corner
    with tifffile.TiffFile(out / "depth.tif") as tif:
        page = tif.pages[0]
        img = page.asarray()
        geo = tif.geotiff_metadata
        scale = page.tags["ModelPixelScaleTag"].value
        tie = page.tags["ModelTiepointTag"].value
    assert img.shape == (10, 10) and img.dtype == np.float32
    assert img[0, 0] > img[-1, 0]  # row 0 is the north (deeper: depth grows northwards)
    assert geo["GeographicTypeGeoKey"] == 4326
    assert scale[1] == pytest.approx(2.0 / METRES_PER_DEGREE)
    top_lat, left_lon = ne_to_latlon(20.0, 0.0, *REF)
    assert (tie[3], tie[4]) == (pytest.approx(left_lon, abs=1e-7), pytest.approx(top_lat, abs=1e-7))
    contours = json.loads((out / "contours.geojson").read_text())
    levels = {f["properties"]["depth_m"] for f in contours["features"]}
    assert {1.25, 1.5, 1.75} <= levels
    assert (out / "map.png").stat().st_size > 10_000


def test_a_gap_becomes_the_holes_mission_through_every_empty_cell(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    points = [p for p in lines(2.0, 20.0) if not (p[1] > 12.0 and p[0] > 14.0)]  # NE corner
    run = write_run(tmp_path / "run", points)
    code, stdout, _ = run_main(
        ["survey-map", str(run), "--area", str(area_file(tmp_path, 20.0)), "--mode", "roll"],
        capsys,
    )
    assert code == 0, stdout
    out = run / "survey-map"
    figures = json.loads((out / "survey-map.json").read_text())
    assert figures["holes"] == 12 and math.isclose(figures["coverage"], 0.88)
    holes = load_mission_file(out / "holes.yaml")
    assert holes.mission.mode.value == "roll"
    assert len(holes.mission.waypoints) == figures["holes_mission_items"] == 6


def test_no_payload_or_a_wrong_file_is_one_line_each(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, stderr = run_main(["survey-map", str(tmp_path)], capsys)
    assert code == 2 and "payload.csv: no such file" in stderr
    (tmp_path / "payload.csv").write_text("a,b\n1,2\n")
    code, _, stderr = run_main(["survey-map", str(tmp_path)], capsys)
    assert code == 2 and "not a payload.csv" in stderr
