"""helixd export: the planned path and the flown track of a run, in lat/lon."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from helixd.base.frames import MissionFrame, NedPose, latlon_to_ne, ne_to_latlon
from helixd.cli.app import app
from helixd.config.load import config_to_yaml
from helixd.config.root import HelixdConfig
from helixd.mission.formats import mission_to_yaml
from helixd.mission.model import Mission
from helixd.recorder.export import ExportError, build_export, load_run_export, to_geojson, to_kml
from helixd.recorder.rows import COLUMNS, CSV_COMMENT, FlightRow, RowFormatter, nan_row
from helixd.recorder.summary import SummaryBuilder

ORIGIN = (53.52325, -113.52632)


def global_mission() -> Mission:
    pts = [ne_to_latlon(n, e, *ORIGIN) for n, e in [(8.0, 0.0), (8.0, 8.0), (0.0, 8.0)]]
    fence = [ne_to_latlon(n, e, *ORIGIN) for n, e in [(-5, -5), (-5, 15), (15, 15), (15, -5)]]
    return Mission.model_validate(
        {
            "name": "sq",
            "mode": "roll",
            "frame": "global",
            "waypoints": [{"lat": a, "lon": b} for a, b in pts],
            "geofence_polygon": [list(v) for v in fence],
        }
    )


def track(n: int = 200) -> dict[str, np.ndarray]:
    t = np.linspace(0.0, 1.0, n)
    north = np.concatenate([8.0 * t, np.full(n, 8.0)])
    east = np.concatenate([np.zeros(n), 8.0 * t])
    north[5] = math.nan  # a row without a pose is skipped
    return {"north_m": north, "east_m": east}


def test_flown_track_goes_through_the_ekf_map_and_is_decimated() -> None:
    data = build_export(global_mission(), ORIGIN, track(), min_step_m=0.5)
    assert data.planned == tuple(global_mission().points())
    assert 30 <= len(data.flown) <= 40  # 16 m at 0.5 m steps, plus the last pose
    n, e = latlon_to_ne(*data.flown[-1], *ORIGIN)
    assert (n, e) == pytest.approx((8.0, 8.0), abs=1e-6)
    assert len(data.fence) == 4


def test_waypoints_are_numbered_from_1_and_via_points_marked() -> None:
    msn = global_mission()
    wps = list(msn.waypoints)
    wps[1] = wps[1].model_copy(update={"via": True})
    island = [ne_to_latlon(n, e, *ORIGIN) for n, e in [(2, 2), (2, 4), (4, 4), (4, 2)]]
    msn = msn.model_copy(update={"waypoints": tuple(wps), "keep_out_polygons": (tuple(island),)})
    data = build_export(msn, ORIGIN, track())
    doc = json.loads(to_geojson(data))
    points = [f["properties"] for f in doc["features"] if f["geometry"]["type"] == "Point"]
    assert [(p["name"], p["kind"], p["number"]) for p in points] == [
        ("waypoint 1", "waypoint", 1),
        ("via → 2", "via", 2),
        ("waypoint 2", "waypoint", 2),
    ]
    kinds = [f["properties"]["kind"] for f in doc["features"]]
    assert kinds.count("keep_out") == 1
    assert "<name>waypoint 1</name>" in to_kml(data) and "keep-out 1" in to_kml(data)


def test_local_and_start_missions_are_placed_through_the_origin() -> None:
    local = Mission.model_validate(
        {"name": "l", "mode": "roll", "frame": "local_ned", "waypoints": [{"north": 3, "east": 4}]}
    )
    data = build_export(local, ORIGIN, track())
    assert latlon_to_ne(*data.planned[0], *ORIGIN) == pytest.approx((3.0, 4.0), abs=1e-6)
    start = Mission.model_validate(
        {"name": "s", "mode": "roll", "frame": "start", "waypoints": [{"x": 10, "y": 0}]}
    )
    pose0 = NedPose(north_m=2.0, east_m=1.0, yaw_ned_rad=math.pi / 2)  # facing east
    frame = MissionFrame.start_at(pose0)
    p = frame.to_mission(NedPose(2.5, 1.5, math.pi / 2 + 0.1))
    cols = {
        "north_m": np.array([2.5]),
        "east_m": np.array([1.5]),
        "yaw_ned_rad": np.array([math.pi / 2 + 0.1]),
        "x_m": np.array([p.x_m]),
        "y_m": np.array([p.y_m]),
        "yaw_rad": np.array([p.yaw_rad]),
    }
    data = build_export(start, ORIGIN, cols)
    # 10 m forward of a rover at N2 E1 facing east: N2 E11
    assert latlon_to_ne(*data.planned[0], *ORIGIN) == pytest.approx((2.0, 11.0), abs=1e-6)


def test_geojson_and_kml_are_readable() -> None:
    data = build_export(global_mission(), ORIGIN, track())
    doc = json.loads(to_geojson(data))
    kinds = [f["properties"]["kind"] for f in doc["features"]]
    assert kinds == ["planned", "flown", "waypoint", "waypoint", "waypoint", "geofence"]
    lon, lat = doc["features"][0]["geometry"]["coordinates"][0]
    assert (lat, lon) == pytest.approx(data.planned[0], abs=1e-8)
    ring = doc["features"][-1]["geometry"]["coordinates"][0]
    assert ring[0] == ring[-1]
    root = ET.fromstring(to_kml(data))
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    marks = root.findall(".//k:Placemark", ns)
    assert len(marks) == 6
    coords = marks[0].find(".//k:coordinates", ns)
    assert coords is not None and coords.text is not None
    lon_s, lat_s, _ = coords.text.split()[0].split(",")
    assert (float(lat_s), float(lon_s)) == pytest.approx(data.planned[0], abs=1e-8)


def write_run(run_dir: Path, mission: Mission, origin: tuple[float, float] | None) -> None:
    run_dir.mkdir()
    (run_dir / "mission.yaml").write_text(mission_to_yaml(mission))
    (run_dir / "config.yaml").write_text(config_to_yaml(HelixdConfig()))
    b = SummaryBuilder(mission.name, "roll", len(mission.waypoints))
    if origin is not None:
        b.set_origin(*origin)
    (run_dir / "summary.json").write_text(b.build(True, None, 0).to_json())
    fmt = RowFormatter()
    rows = [nan_row(north_m=float(k), east_m=0.0) for k in range(9)]
    header = CSV_COMMENT + "\n" + ",".join(COLUMNS) + "\n"
    (run_dir / "flight.csv").write_text(header + "".join(fmt.line(r) for r in rows))


def test_export_command(tmp_path: Path) -> None:
    run = tmp_path / "run"
    write_run(run, global_mission(), ORIGIN)
    res = CliRunner().invoke(app, ["export", str(run), "--kml"])
    assert res.exit_code == 0, res.output
    assert "flown track 9 points" in res.output  # N 0..8 m read back from flight.csv
    assert (run / "track.kml").exists()
    res = CliRunner().invoke(app, ["export", str(run), "--geojson", "-o", str(tmp_path / "t.json")])
    assert res.exit_code == 0, res.output
    assert json.loads((tmp_path / "t.json").read_text())["type"] == "FeatureCollection"


def test_export_without_a_format_writes_geojson(tmp_path: Path) -> None:
    """Before: `helixd export RUN` exited 2 asking for a format; GeoJSON is the default, KML
    for an --out ending in .kml."""
    run = tmp_path / "run"
    write_run(run, global_mission(), ORIGIN)
    res = CliRunner().invoke(app, ["export", str(run)])
    assert res.exit_code == 0, res.output
    assert json.loads((run / "track.geojson").read_text())["type"] == "FeatureCollection"
    res = CliRunner().invoke(app, ["export", str(run), "-o", str(tmp_path / "t.kml")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "t.kml").read_text().lstrip().startswith("<?xml")


def test_no_recorded_origin_says_so_and_exits_2(tmp_path: Path) -> None:
    run = tmp_path / "run"
    write_run(run, global_mission(), None)
    with pytest.raises(ExportError, match="no EKF origin was recorded"):
        load_run_export(run)
    res = CliRunner().invoke(app, ["export", str(run), "--geojson"])
    assert res.exit_code == 2
    assert "no EKF origin was recorded" in res.output
    res = CliRunner().invoke(app, ["export", str(run), "--geojson", "--kml"])
    assert res.exit_code == 2 and "give one of --geojson or --kml" in res.output
    res = CliRunner().invoke(app, ["export", str(tmp_path / "nope"), "--kml"])
    assert res.exit_code == 2 and "not a directory" in res.output


def test_flight_row_is_still_the_schema_export_reads() -> None:
    names = FlightRow.__dataclass_fields__
    assert "north_m" in names and "east_m" in names
