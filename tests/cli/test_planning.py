"""``helixd check --map``: the planned legs printed, refusals as exit 2 naming leg and waypoint."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from PIL import Image

from tests.support.cli import run_main
from tests.support.missions import mission_file, points_items
from tests.support.paths import REPO_ROOT

ROOT = REPO_ROOT
POND_MAP = ROOT / "config" / "maps" / "pond.yaml"
POND_MISSION = ROOT / "config" / "missions" / "pond-crossing.yaml"


def mission(tmp_path: Path, points: list[tuple[float, float]], frame: str = "local_ned") -> Path:
    doc = {"name": "t", "mode": "roll", "frame": frame, "waypoints": points_items(frame, points)}
    return mission_file(tmp_path / "m.yaml", doc)


def test_check_prints_the_planned_legs_and_draws_the_plan(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    png = tmp_path / "plan.png"
    code, out, err = run_main(
        ["check", "--mission", str(POND_MISSION), "--map", str(POND_MAP), "--plot", str(png)],
        capsys,
    )
    assert code == 0, err
    assert "planned : clearance 0.93 m" in out
    assert "leg start → wp 1:" in out and "intermediate" in out  # numbered from 1
    assert "leg wp 1 → wp 2: 20.0 m (straight)" in out
    assert "via north" in out
    with Image.open(png) as img:
        assert img.size[0] > 500


def test_check_says_why_it_draws_no_plot_without_a_planned_route(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: `check --plot plan.png` on a mission with nothing to plan around exited 0 and
    wrote nothing, without a word."""
    png = tmp_path / "plan.png"
    square = POND_MISSION.parent / "square.yaml"
    code, out, err = run_main(["check", "--mission", str(square), "--plot", str(png)], capsys)
    assert code == 0, err
    assert f"plot    : {png} not written: --plot draws a route planned around obstacles" in out
    assert not png.exists()


def test_check_refuses_a_waypoint_in_an_obstacle_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # north 19.5 east 0: on the pontoon
    path = mission(tmp_path, [(10.0, 0.0), (19.5, 0.0), (40.0, 0.0)])
    code, _, err = run_main(["check", "--mission", str(path), "--map", str(POND_MAP)], capsys)
    assert code == 2
    assert err.strip() == (
        f"error: {path}: waypoint 2 (north 19.50 m, east 0.00 m) lies inside an obstacle "
        "(inflated by rover half-width + planning.margin_m)"
    )


def test_check_refuses_an_unreachable_leg_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocked = np.zeros((100, 100), dtype=bool)
    blocked[50:53, :] = True  # a wall right across the map
    Image.fromarray(np.where(blocked[::-1], 0, 254).astype(np.uint8), mode="L").save(
        tmp_path / "wall.pgm"
    )
    (tmp_path / "wall.yaml").write_text(
        "image: wall.pgm\nresolution: 0.2\norigin: [-10.0, -2.0, 0.0]\n", encoding="utf-8"
    )
    path = mission(tmp_path, [(2.0, 0.0), (15.0, 0.0)])
    code, _, err = run_main(
        ["check", "--mission", str(path), "--map", str(tmp_path / "wall.yaml")], capsys
    )
    assert code == 2
    assert err.strip() == (
        f"error: {path}: leg waypoint 1 → waypoint 2: unreachable, no path keeps 0.93 m clearance"
    )


def test_keep_out_shapes_from_the_config_plan_without_a_map(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cfg = tmp_path / "helixd.yaml"
    cfg.write_text(
        yaml.safe_dump(
            {"planning": {"keep_out_circles": [{"north_m": 5.0, "east_m": 0.0, "radius_m": 2.0}]}}
        ),
        encoding="utf-8",
    )
    path = mission(tmp_path, [(10.0, 0.0)])
    code, out, err = run_main(["check", "--mission", str(path), "--config", str(cfg)], capsys)
    assert code == 0, err
    assert "leg start → wp 1:" in out and "(straight)" not in out


def test_map_errors_and_frames_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = run_main(
        ["check", "--mission", str(POND_MISSION), "--map", str(tmp_path / "none.yaml")], capsys
    )
    assert code == 2 and "none.yaml: file not found" in err
    start = mission(tmp_path, [(5.0, 0.0)], frame="start")
    code, _, err = run_main(["check", "--mission", str(start), "--map", str(POND_MAP)], capsys)
    assert code == 2 and "needs a local_ned mission" in err


def test_check_without_map_or_shapes_is_unchanged(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_main(["check", "--mission", str(POND_MISSION)], capsys)
    assert code == 0 and "planned :" not in out
