"""A ground-station file's home row is where it was planned, not where the rover starts.

A ``.waypoints`` file carries its home (row 0). A first waypoint far beyond
``mission.max_range_m`` (~794 m) from it is still refused by ``helixd check`` — and by
``helixd run`` before connecting (the link URL below answers nobody) — as the EKF origin is set
where the rover gets its fix. A first waypoint beyond ``mission.max_start_distance_m`` but within
range (ArduPilot's path-planning example: 275 m) is only a warning in ``check``: preflight judges
the distance from the rover's real position.
"""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from helixd.base.exitcodes import ExitCode
from helixd.cli.app import app

HOME = (53.523250, -113.526110)
NORTH_DEG_PER_M = 1 / 111_320.0  # close enough at this latitude for "~794 m"
REASON = "item 1: 794.0 m from the mission's home"


def _far_waypoints(tmp_path: Path, north_m: float = 794.0) -> Path:
    lat0 = HOME[0] + north_m * NORTH_DEG_PER_M
    rows = [
        "QGC WPL 110",
        f"0\t1\t0\t16\t0\t0\t0\t0\t{HOME[0]:.8f}\t{HOME[1]:.8f}\t668.0\t1",
        f"1\t0\t3\t16\t0\t0\t0\t0\t{lat0:.8f}\t{HOME[1]:.8f}\t0.0\t1",
        f"2\t0\t3\t16\t0\t0\t0\t0\t{lat0 + 20 * NORTH_DEG_PER_M:.8f}\t{HOME[1]:.8f}\t0.0\t1",
    ]
    path = tmp_path / "far.waypoints"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def _errors(output: str) -> list[str]:
    return [line for line in output.splitlines() if line.startswith("error: ")]


def test_check_refuses_a_first_waypoint_far_from_the_files_home(tmp_path: Path) -> None:
    path = _far_waypoints(tmp_path)
    args = ["--mission", str(path), "--mode", "roll"]
    checked = CliRunner().invoke(app, ["check", *args])
    assert checked.exit_code == ExitCode.USAGE, checked.output
    errors = _errors(checked.output)
    first = [e for e in errors if REASON in e]
    assert len(first) == 1, errors  # beyond the range limit (the start distance: a warning)
    assert "allowed at most mission.max_range_m = 500.0 m" in first[0]
    ran = CliRunner().invoke(app, ["run", *args, "--connect", "udpout:127.0.0.1:9"])
    assert ran.exit_code == checked.exit_code, ran.output
    assert _errors(ran.output) == errors  # the same reasons, before any link


def test_check_passes_the_same_file_near_its_home(tmp_path: Path) -> None:
    path = _far_waypoints(tmp_path)
    text = path.read_text(encoding="utf-8").splitlines()
    for row, north_m in ((2, 50.0), (3, 70.0)):
        lat = HOME[0] + north_m * NORTH_DEG_PER_M
        text[row] = f"{row - 1}\t0\t3\t16\t0\t0\t0\t0\t{lat:.8f}\t{HOME[1]:.8f}\t0.0\t1"
    path.write_text("\n".join(text) + "\n", encoding="utf-8")
    checked = CliRunner().invoke(app, ["check", "--mission", str(path), "--mode", "roll"])
    assert checked.exit_code == 0, checked.output
    assert "distance from the rover to waypoint 1" in checked.output


def test_a_first_waypoint_275_m_from_the_files_home_is_a_warning_not_a_refusal(
    tmp_path: Path,
) -> None:
    """ArduPilot's path-planning example mission and QGroundControl's SectionTest.plan (118 m)
    were refused: their home is where the planner stood."""
    path = _far_waypoints(tmp_path, north_m=275.0)
    checked = CliRunner().invoke(app, ["check", "--mission", str(path), "--mode", "roll"])
    assert checked.exit_code == 0, checked.output
    assert _errors(checked.output) == []
    warned = [ln for ln in checked.output.splitlines() if "275.0 m from the file's home" in ln]
    assert len(warned) == 1 and warned[0].startswith("warning: ")
    assert "mission.max_start_distance_m = 100.0 m" in warned[0]
    assert "preflight checks the distance from the rover's real position" in warned[0]
    assert "distance from the rover to waypoint 1" in checked.output  # pending, for run
