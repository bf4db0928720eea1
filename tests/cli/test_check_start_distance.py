"""A ground-station file planned for another place is refused before anything connects.

A ``.waypoints`` file carries its home (row 0): a first waypoint ~794 m from it is refused by
``helixd check`` with the exit code and the reason ``helixd run`` gives, and ``run`` refuses it
before connecting (the link URL below answers nobody).
"""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from helixd.base.exitcodes import ExitCode
from helixd.cli.app import app

HOME = (53.523250, -113.526110)
NORTH_DEG_PER_M = 1 / 111_320.0  # close enough at this latitude for "~794 m"
REASON = "item 1: 794.0 m from the mission's home"


def _far_waypoints(tmp_path: Path) -> Path:
    lat0 = HOME[0] + 794.0 * NORTH_DEG_PER_M
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
    assert len(first) == 2, errors  # beyond the range limit, and too far to start from
    assert "allowed at most mission.max_range_m = 500.0 m" in first[0]
    assert "mission.max_start_distance_m = 100.0 m away" in first[1]
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
