"""``check --mode`` with a YAML mission says that the flag wins over the file's mode, and a
SCROLL mission that turns in place is warned about sand."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support.cli import run_main
from tests.support.paths import REPO_ROOT

SQUARE = str(REPO_ROOT / "config" / "missions" / "square.yaml")  # mode: roll, four corners
CONFIG = str(REPO_ROOT / "config" / "helixd.yaml")


def test_mode_flag_over_a_yaml_missions_mode_wins_and_says_so(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, out, err = run_main(
        ["check", "--config", CONFIG, "--mission", SQUARE, "--mode", "omni"], capsys
    )
    assert code == 0, out + err
    assert (
        "--mode omni wins over the mission's mode (roll): every leg is flown in omni" in out + err
    )
    assert "mode=omni" in out


def test_the_same_mode_as_the_file_says_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_main(
        ["check", "--config", CONFIG, "--mission", SQUARE, "--mode", "roll"], capsys
    )
    assert code == 0, out + err
    assert "wins over" not in out + err


def test_scroll_that_turns_in_place_warns_of_sand(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_main(
        ["check", "--config", CONFIG, "--mission", SQUARE, "--mode", "scroll"], capsys
    )
    assert code == 0, out + err
    warning = [line for line in out.splitlines() if "digs the scrolls in" in line]
    assert len(warning) == 1 and warning[0].startswith("warning : scroll turns in place ")
    assert "on sand" in warning[0] and "fault stall" in warning[0]


def test_roll_on_the_same_corners_has_no_sand_warning(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_main(["check", "--config", CONFIG, "--mission", SQUARE], capsys)
    assert code == 0, out + err
    assert "digs the scrolls in" not in out


POND_SURVEY = str(REPO_ROOT / "config" / "missions" / "pond-survey.yaml")  # scroll, media map


def test_mode_flag_wins_over_the_media_map_and_the_waypoints_modes(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, out, err = run_main(["check", "--mission", POND_SURVEY, "--mode", "roll"], capsys)
    assert code == 0, out + err
    notes = [ln for ln in (out + err).splitlines() if "wins over" in ln]
    assert len(notes) == 1, out + err  # said once
    assert (
        "--mode roll wins over the mission's mode (scroll) and media map (the mode follows no "
        "medium): every leg is flown in roll" in notes[0]
    )
    assert "mode=roll " in out and "stretch : " not in out and "(stop)" not in out, out


def test_mode_flag_turns_the_configs_media_map_off_too(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    config = tmp_path / "helixd.yaml"
    media = REPO_ROOT / "config" / "maps" / "pond-media.geojson"
    config.write_text(f"media:\n  media_map: {media}\n", encoding="utf-8")
    mission = tmp_path / "survey.yaml"
    text = (REPO_ROOT / "config" / "missions" / "pond-survey.yaml").read_text(encoding="utf-8")
    mission.write_text(text.replace("media_map: ../maps/pond-media.geojson\n", ""), "utf-8")
    args = ["check", "--config", str(config), "--mission", str(mission)]
    code, out, err = run_main(args, capsys)
    assert code == 0 and "stretch : " in out, out + err  # the config's map is followed
    code, out, err = run_main([*args, "--mode", "scroll"], capsys)
    assert code == 0, out + err
    assert "--mode scroll wins over the mission's media map" in out + err
    assert "stretch : " not in out and "mode=scroll " in out, out
