"""The CLI with ground-station files: check --mode/--skip-unsupported, mission convert."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from helixd.cli.app import app
from helixd.mission.formats import load_mission_file
from helixd.mission.model import MotionMode
from tests.support.paths import DATA_DIR

DATA = DATA_DIR
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
    assert res.exit_code == 2 and "only global" in res.output
    assert not (tmp_path / "s.plan").exists()
