"""``check --mode`` with a YAML mission says that the flag wins over the file's mode, and a
SCROLL mission that turns in place is warned about sand."""

from __future__ import annotations

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
    assert "--mode omni wins over the mission's own mode: roll; it is flown in omni" in out + err
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
