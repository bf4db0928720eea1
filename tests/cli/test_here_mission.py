"""A ground-station file whose only item is a NAV_WAYPOINT at latitude/longitude 0, 0.

ArduPilot Rover reads 0, 0 as "here" (Location::sanitize): it reaches the item at once and
completes the mission. helixd used to refuse the file ("nothing to fly"); it now flies it as one
waypoint where the rover starts, completed at once. A "here" with a hold, or beside other
items, is judged as before.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.plan import MissionFrameKind, MotionMode
from helixd.files.models import ConfigFileError
from helixd.mission.formats import load_mission_file
from tests.support.cli import run_main

HOME_ROW = "0\t1\t0\t16\t0\t0\t0\t0\t53.52325\t-113.52611\t668.0\t1"


def here_file(tmp_path: Path, hold_s: float = 0.0) -> Path:
    path = tmp_path / "here.waypoints"
    item = f"1\t0\t3\t16\t{hold_s:g}\t0\t0\t0\t0\t0\t0.0\t1"
    path.write_text(f"QGC WPL 110\n{HOME_ROW}\n{item}\n", encoding="utf-8")
    return path


def test_the_only_here_item_is_one_waypoint_at_the_start(tmp_path: Path) -> None:
    loaded = load_mission_file(here_file(tmp_path), mode=MotionMode.SCROLL)
    msn = loaded.mission
    assert msn.frame is MissionFrameKind.START and msn.mode is MotionMode.SCROLL
    assert [(w.x, w.y) for w in msn.waypoints] == [(0.0, 0.0)]
    assert any("'here' to ArduPilot Rover" in n for n in loaded.notes)


def test_a_here_with_a_hold_is_still_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigFileError, match="nothing to fly"):
        load_mission_file(here_file(tmp_path, hold_s=5.0), mode=MotionMode.ROLL)


def test_run_completes_the_here_mission_at_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = run_main(
        ["run", "--sim", "--sim-clock", "simulated", "--sim-seed", "1",
         "--mission", str(here_file(tmp_path)),
         "--mode", "roll", "--log-level", "warning", "--run-dir", str(tmp_path / "runs")],
        capsys,
    )  # fmt: skip
    assert code == 0, out + err
    lines = [line for line in err.splitlines() if line.strip()]
    assert lines[-1].startswith("helixd: RESULT ok — 1/1 waypoints"), lines[-1]
