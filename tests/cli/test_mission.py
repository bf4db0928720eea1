"""The CLI with ground-station files: check --mode/--skip-unsupported, mission convert."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from helixd.base.frames import latlon_to_ne
from helixd.base.plan import MotionMode
from helixd.cli.app import app
from helixd.mission.formats import load_mission_file, read_gcs
from tests.support.paths import DATA_DIR, REPO_ROOT

DATA = DATA_DIR
MISSIONS = REPO_ROOT / "config" / "missions"
PLAN = DATA / "pond_survey.plan"
WPL = DATA / "square.waypoints"
runner = CliRunner()


def test_check_needs_a_mode_for_a_plan() -> None:
    res = runner.invoke(app, ["check", "-m", str(PLAN)])
    assert res.exit_code == 2
    assert "carries no motion mode: give --mode" in res.output


def test_check_shows_the_commands_where_they_are_flown() -> None:
    """The Survey's camera triggers and the closing RTL are flown, not refused: one line per
    step, the items under the step they start with."""
    res = runner.invoke(app, ["check", "-m", str(PLAN), "--mode", "scroll"])
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    (rtl,) = [ln for ln in lines if "NAV_RETURN_TO_LAUNCH →" in ln]
    assert any("NAV_RETURN_TO_LAUNCH shown going to the mission's home" in ln for ln in lines)
    assert rtl.split()[:2] == ["6", "8"]  # step 6 is item 8
    assert "→ home" in rtl
    assert any(ln.split()[:2] == ["3", "+"] and "DO_SET_CAM_TRIGG_DIST" in ln for ln in lines)


def test_check_with_a_config_mode(tmp_path: Path) -> None:
    cfg = tmp_path / "helixd.yaml"
    cfg.write_text(yaml.safe_dump({"mission": {"ground_station_mode": "omni"}}))
    res = runner.invoke(app, ["check", "-m", str(WPL), "-c", str(cfg)])
    assert res.exit_code == 0, res.output
    assert "DO_CHANGE_SPEED → 0.50 m/s" in res.output
    assert "mode=omni  frame=global" in res.output
    res = runner.invoke(app, ["check", "-m", str(WPL), "--mode", "roll"])
    assert "mode=roll" in res.output


def test_config_mode_is_for_ground_station_files_only(tmp_path: Path) -> None:
    cfg = tmp_path / "helixd.yaml"
    cfg.write_text(yaml.safe_dump({"mission": {"ground_station_mode": "omni"}}))
    msn = tmp_path / "m.yaml"
    msn.write_text("name: m\nmode: scroll\nwaypoints: [{x: 1, y: 0}]\n")
    res = runner.invoke(app, ["check", "-m", str(msn), "-c", str(cfg)])
    assert res.exit_code == 0, res.output
    assert "mode=scroll" in res.output  # the YAML's own mode
    res = runner.invoke(app, ["check", "-m", str(msn), "-c", str(cfg), "--mode", "roll"])
    assert "mode=roll" in res.output  # the flag overrides


def test_a_bare_name_finds_a_plan(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    missions = tmp_path / "config" / "missions"
    missions.mkdir(parents=True)
    (missions / "pond.plan").write_text(PLAN.read_text())
    monkeypatch.chdir(tmp_path)
    res = runner.invoke(app, ["check", "-m", "pond", "--mode", "scroll"])
    assert res.exit_code == 0, res.output
    assert "config/missions/pond.plan" in res.output


def test_convert_round_trip_and_what_is_lost(tmp_path: Path) -> None:
    out = tmp_path / "pond.waypoints"
    res = runner.invoke(app, ["mission", "convert", str(PLAN), str(out), "--mode", "scroll"])
    assert res.exit_code == 0, res.output
    assert "has no place for geofence_polygon" in res.output
    assert out.read_text().startswith("QGC WPL 110\n0\t1\t0\t16\t")
    back = tmp_path / "back.yaml"
    res = runner.invoke(app, ["mission", "convert", str(out), str(back), "--mode", "scroll"])
    assert res.exit_code == 0, res.output
    first = load_mission_file(PLAN, mode=MotionMode.SCROLL).mission
    again = load_mission_file(back).mission
    assert again.points() == first.points()
    # every item came through, commands included (what .waypoints cannot hold: NaN → 0)
    assert [w.command for w in again.waypoints] == [w.command for w in first.waypoints]


def test_convert_between_ground_station_files_needs_no_mode(tmp_path: Path) -> None:
    """.waypoints ↔ .plan: neither has a place for a mode, so none is asked for or lost."""
    out = tmp_path / "sq.plan"
    res = runner.invoke(app, ["mission", "convert", str(WPL), str(out)])
    assert res.exit_code == 0, res.output
    assert "warning" not in res.output
    back = tmp_path / "sq.waypoints"
    res = runner.invoke(app, ["mission", "convert", str(out), str(back)])
    assert res.exit_code == 0, res.output
    assert "warning" not in res.output


def test_convert_to_yaml_needs_a_mode_from_the_flag_or_the_config(tmp_path: Path) -> None:
    out = tmp_path / "pond.yaml"
    res = runner.invoke(app, ["mission", "convert", str(PLAN), str(out)])
    assert res.exit_code == 2 and not out.exists()
    (line,) = [ln for ln in res.output.splitlines() if "motion mode" in ln]
    assert "--mode roll|scroll|omni" in line and "mission.ground_station_mode" in line
    cfg = tmp_path / "helixd.yaml"
    cfg.write_text("mission:\n  ground_station_mode: scroll\n")
    res = runner.invoke(app, ["mission", "convert", str(PLAN), str(out), "--config", str(cfg)])
    assert res.exit_code == 0, res.output
    assert load_mission_file(out).mission.mode is MotionMode.SCROLL


def test_convert_errors(tmp_path: Path) -> None:
    res = runner.invoke(app, ["mission", "convert", str(PLAN), str(tmp_path / "x.kml")])
    assert res.exit_code == 2
    res = runner.invoke(
        app,
        ["mission", "convert", str(PLAN), str(tmp_path / "x.kml"), "--mode", "roll"],
    )  # fmt: skip
    assert res.exit_code == 2 and "unknown mission file type '.kml'" in res.output
    start = tmp_path / "s.yaml"
    start.write_text("name: s\nmode: roll\nwaypoints: [{x: 1, y: 0}]\n")
    res = runner.invoke(app, ["mission", "convert", str(start), str(tmp_path / "s.plan")])
    assert res.exit_code == 2 and "give the EKF origin with --origin LAT,LON" in res.output
    assert not (tmp_path / "s.plan").exists()
    res = runner.invoke(
        app, ["mission", "convert", str(start), str(tmp_path / "s.plan"), "--origin", "53.5,x"]
    )
    assert res.exit_code == 2 and "LAT and LON must be numbers" in res.output
    res = runner.invoke(
        app, ["mission", "convert", str(start), str(tmp_path / "s.plan"), "--origin", "53.5,-113"]
    )
    assert res.exit_code == 2 and "--start-heading-deg" in res.output


ORIGIN = (53.52325, -113.52632)


def test_convert_places_a_local_ned_mission_through_the_origin(tmp_path: Path) -> None:
    """A local_ned mission for a ground station, with the EKF origin a run recorded."""
    src = tmp_path / "lane.yaml"
    src.write_text(
        "name: lane\nmode: roll\nframe: local_ned\ntime_limit_s: 600\n"
        "ground: {roll_fraction: 0.5}\n"
        "keep_out_polygons: [[[3, 3], [3, 5], [5, 5], [5, 3]]]\n"
        "waypoints: [{north: 6, east: 0}, {north: 6, east: 6, heading_deg: 90}]\n"
    )
    out = tmp_path / "lane.plan"
    origin = f"{ORIGIN[0]},{ORIGIN[1]}"
    res = runner.invoke(app, ["mission", "convert", str(src), str(out), "--origin", origin])
    assert res.exit_code == 0, res.output
    back = load_mission_file(out, mode=MotionMode.ROLL).mission
    ne = [latlon_to_ne(a, b, *ORIGIN) for a, b in back.points()]
    assert ne == [pytest.approx((6.0, 0.0), abs=1e-6), pytest.approx((6.0, 6.0), abs=1e-6)]
    assert back.time_limit_s == 600.0  # the .plan keeps the mission's time limit
    assert "has no place for ground" in res.output and back.ground is None  # said, not silent
    gcs = read_gcs(out)
    assert [p.inclusion for p in gcs.polygons] == [False]  # the keep-out: an exclusion zone


def test_convert_to_a_plan_keeps_the_media_map(tmp_path: Path) -> None:
    """Before: `convert` to .plan dropped the mission's media_map ("the format has no place
    for media_map"); it is kept in the plan's helixd key as time_limit_s is, the path made
    relative to the new file's folder, and read back; a .waypoints file still says it drops
    it."""
    out = tmp_path / "sub" / "pond.plan"
    out.parent.mkdir()
    src = MISSIONS / "pond-survey.yaml"
    res = runner.invoke(app, ["mission", "convert", str(src), str(out)])
    assert res.exit_code == 0, res.output
    assert "media_map" not in res.output
    back = load_mission_file(out, mode=MotionMode.SCROLL).mission
    assert back.media_map is not None and not back.media_map.is_absolute()
    pond = (src.parent / "../maps/pond-media.geojson").resolve()
    assert (out.parent / back.media_map).resolve() == pond
    assert back.time_limit_s == load_mission_file(src).mission.time_limit_s
    res = runner.invoke(app, ["mission", "convert", str(src), str(tmp_path / "p.waypoints")])
    assert res.exit_code == 0 and "has no place for media_map" in res.output


def test_convert_places_a_start_mission_at_a_start_pose(tmp_path: Path) -> None:
    out = tmp_path / "sq.yaml"
    args = ["--origin", f"{ORIGIN[0]},{ORIGIN[1]}", "--start-heading-deg", "90"]
    res = runner.invoke(
        app, ["mission", "convert", str(MISSIONS / "square.yaml"), str(tmp_path / "sq.plan"), *args]
    )
    assert res.exit_code == 0, res.output
    res = runner.invoke(
        app, ["mission", "convert", str(tmp_path / "sq.plan"), str(out), "--mode", "roll"]
    )
    assert res.exit_code == 0, res.output
    ne = [latlon_to_ne(a, b, *ORIGIN) for a, b in load_mission_file(out).mission.points()]
    # facing East: x forward is east, y left is north
    expected = [(0.0, 10.0), (10.0, 10.0), (10.0, 0.0), (0.0, 0.0)]
    assert ne == [pytest.approx(p, abs=1e-6) for p in expected]


def test_waypoints_to_plan_keeps_the_home_and_its_altitude(tmp_path: Path) -> None:
    """It used to put home on the first waypoint at altitude 0."""
    out = tmp_path / "sq.plan"
    res = runner.invoke(
        app,
        ["mission", "convert", str(DATA / "square.waypoints"), str(out), "--mode", "roll"],
    )  # fmt: skip  (conversion keeps every item; convert has no --skip-unsupported)
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    assert doc["mission"]["plannedHomePosition"] == [53.52325, -113.52611, 668.0]
    back = tmp_path / "sq.waypoints"
    assert (
        runner.invoke(app, ["mission", "convert", str(out), str(back), "--mode", "roll"]).exit_code
        == 0
    )
    assert back.read_text().splitlines()[1].split("\t")[8:11] == [
        "53.52325000", "-113.52611000", "668.00000000",
    ]  # fmt: skip


def test_waypoints_through_yaml_keep_the_home_row(tmp_path: Path) -> None:
    """.waypoints → YAML → .waypoints: the home row comes back the same, altitude included
    (it used to come back at altitude 0)."""
    mid, back = tmp_path / "sq.yaml", tmp_path / "sq.waypoints"
    res = runner.invoke(app, ["mission", "convert", str(WPL), str(mid), "--mode", "roll"])
    assert res.exit_code == 0, res.output
    assert yaml.safe_load(mid.read_text())["home_alt_m"] == 668.0
    res = runner.invoke(app, ["mission", "convert", str(mid), str(back)])
    assert res.exit_code == 0, res.output
    home = next(ln for ln in WPL.read_text().splitlines() if ln.startswith("0\t"))
    assert back.read_text().splitlines()[1].split("\t")[8:11] == [
        f"{float(v):.8f}" for v in home.split("\t")[8:11]
    ]


def test_whole_number_parameters_are_written_as_integers(tmp_path: Path) -> None:
    """DO_SET_SERVO's channel and DO_JUMP's repeat are integers in ArduPilot: `channel: 9`,
    not `channel: 9.0`; a float parameter stays a float."""
    src = tmp_path / "s.waypoints"
    src.write_text(
        "QGC WPL 110\n"
        "0\t1\t0\t16\t0\t0\t0\t0\t53.52325\t-113.52611\t668\t1\n"
        "1\t0\t3\t16\t0\t0\t0\t0\t53.5233\t-113.52605\t0\t1\n"
        "2\t0\t0\t183\t9\t1500\t0\t0\t0\t0\t0\t1\n"
        "3\t0\t3\t16\t0\t0\t0\t0\t53.5233\t-113.5259\t0\t1\n"
        "4\t0\t0\t177\t1\t2\t0\t0\t0\t0\t0\t1\n"
    )
    out = tmp_path / "s.yaml"
    res = runner.invoke(app, ["mission", "convert", str(src), str(out), "--mode", "roll"])
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert "channel: 9," in text and "repeat: 2," in text, text
    servo, jump = yaml.safe_load(text)["waypoints"][1::2]
    assert type(servo["channel"]) is int and type(jump["repeat"]) is int
    back = tmp_path / "back.waypoints"
    res = runner.invoke(app, ["mission", "convert", str(out), str(back)])
    assert res.exit_code == 0, res.output
    rows = [ln.split("\t") for ln in back.read_text().splitlines()[2:]]
    assert [float(v) for v in rows[1][4:6]] == [9.0, 1500.0]
    assert [float(v) for v in rows[3][4:6]] == [1.0, 2.0]


def test_ignored_qgc_fields_are_said_naming_the_item(tmp_path: Path) -> None:
    """Acceptance radius (param2) and cruiseSpeed are not used yet; the hold time (param1) is
    flown since mission commands: not said to be ignored, shown as a hold."""
    doc = json.loads(PLAN.read_text())
    first = doc["mission"]["items"][0]
    first["params"][0], first["params"][1] = 5, 2.5
    doc["mission"]["cruiseSpeed"] = 1.2
    plan = tmp_path / "p.plan"
    plan.write_text(json.dumps(doc))
    res = runner.invoke(app, ["check", "-m", str(plan), "--mode", "roll", "--skip-unsupported"])
    assert res.exit_code == 0, res.output
    assert "hold time 5 s (param1) ignored" not in res.output
    assert "item 1 (mission.items.0): acceptance radius 2.5 m (param2) ignored" in res.output
    assert "cruiseSpeed 1.2 m/s ignored" in res.output
