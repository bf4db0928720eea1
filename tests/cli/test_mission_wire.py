"""``helixd mission download|upload``: what is refused before any link is opened (exit 2, one
line each), and the download summary (pure)."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from helixd.cli.app import app
from helixd.cli.mission import describe_gcs
from helixd.mission.formats import read_gcs
from tests.support.paths import REPO_ROOT

ROOT = REPO_ROOT
DATA = ROOT / "tests" / "data"
# nobody listens there: a test that reached the link would fail with exit 6, not 2
NOWHERE = "udpout:127.0.0.1:9"
runner = CliRunner()


def test_download_to_an_unknown_suffix_is_a_usage_error(tmp_path: Path) -> None:
    res = runner.invoke(app, ["mission", "download", str(tmp_path / "x.kml"), "--connect", NOWHERE])
    assert res.exit_code == 2
    assert "unknown mission file type '.kml'" in res.output


def test_download_to_yaml_needs_a_mode(tmp_path: Path) -> None:
    res = runner.invoke(
        app, ["mission", "download", str(tmp_path / "x.yaml"), "--connect", NOWHERE]
    )
    assert res.exit_code == 2
    assert "needs a motion mode: give --mode" in res.output


def test_upload_of_a_start_mission_with_an_origin_needs_its_heading(tmp_path: Path) -> None:
    """Without --origin a start/local_ned mission is placed through the autopilot's EKF
    origin (tests/integration/test_mission_wire.py); with it, a start mission needs its
    heading too: refused before any link is opened."""
    res = runner.invoke(
        app,
        [
            "mission",
            "upload",
            str(ROOT / "config" / "missions" / "square.yaml"),
            "--connect",
            NOWHERE,
            "--origin",
            "53.52325,-113.52632",
        ],
    )
    assert res.exit_code == 2
    assert "--start-heading-deg" in res.output


def test_upload_of_a_broken_plan_names_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.plan"
    bad.write_text('{"fileType": "Plan", "mission": {"items": []}}')
    res = runner.invoke(app, ["mission", "upload", str(bad), "--connect", NOWHERE])
    assert res.exit_code == 2
    assert res.output.count("error:") == 1 and "no mission items to upload" in res.output
    assert str(bad) in res.output


def test_bad_connect_url_is_a_usage_error() -> None:
    res = runner.invoke(app, ["mission", "download", "--connect", "bogus://x"])
    assert res.exit_code == 2
    assert "--connect" in res.output and "bogus://x" in res.output


def test_summary_names_items_and_fence() -> None:
    lines = describe_gcs(read_gcs(DATA / "pond_survey.plan"))
    assert lines[0] == "home    : 53.5232500, -113.5261100"
    assert lines[1] == (
        "mission : 8 items (5 NAV_WAYPOINT, 2 DO_SET_CAM_TRIGG_DIST, 1 NAV_RETURN_TO_LAUNCH)"
    )
    assert lines[-1] == "fence   : 2 polygons, 1 circles (1 inclusion, 2 exclusion)"
    assert len(lines) == 2 + 8 + 1
