"""``helixd ground``: the profile shown, a fraction pinned and the profile reset by the crew,
the figure drawn; bad input is one error line and exit 2."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from helixd.base.media import Medium
from helixd.base.plan import MotionMode
from helixd.control.ground_fit import AxisSums, CellSums
from helixd.recorder.ground_profile import GroundProfile, read_profile, write_profile
from tests.support.cli import run_main
from tests.support.paths import REPO_ROOT


def config(tmp_path: Path, profile: Path) -> Path:
    path = tmp_path / "helixd.yaml"
    path.write_text(yaml.safe_dump({"ground": {"profile_file": str(profile)}}))
    return path


def test_the_profile_is_shown_pinned_plotted_and_reset(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    profile = tmp_path / "ground-profile.yaml"
    cell = CellSums(
        roll=AxisSums(2.0, 1.8, 1.63, 20.0, 1000), metres=15.0, energy_j=3000.0, runs=("r1",)
    )
    write_profile(profile, GroundProfile({(Medium.HARD, MotionMode.ROLL): cell}))
    cfg = ["--config", str(config(tmp_path, profile))]
    code, out, err = run_main(["ground", *cfg, "--plot", str(tmp_path / "g.png")], capsys)
    assert code == 0, err
    assert "0.900 ±" in out and "1000" in out and "200" in out  # fraction, samples, J/m
    assert "hard   roll    (the default: too little learnt)" in out
    assert (tmp_path / "g.png").read_bytes()[:4] == b"\x89PNG"
    code, out, err = run_main(["ground", *cfg, "--pin", "hard/scroll/scroll=0.5"], capsys)
    assert code == 0, err
    assert read_profile(profile).pins == {(Medium.HARD, MotionMode.SCROLL, "scroll"): 0.5}
    assert "0.500 ± 0.000 (pinned)" in out
    assert "hard   roll    (by the profile)" in out  # both axes known: 0.9 rolls faster
    code, out, err = run_main(["ground", *cfg, "--reset"], capsys)
    assert code == 0 and not profile.exists()


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--pin", "hard/roll"], "expected MEDIUM/MODE/AXIS=FRACTION"),
        (["--pin", "lava/roll/roll=0.5"], "expected MEDIUM/MODE/AXIS=FRACTION"),
        (["--pin", "hard/roll/heave=0.5"], "axis must be one of roll, scroll, yaw"),
        (["--pin", "hard/roll/roll=0"], "fraction must be within"),
        (["some-run"], "needs --media MAP"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], expected: str
) -> None:
    cfg = ["--config", str(config(tmp_path, tmp_path / "p.yaml"))]
    code, _, err = run_main(["ground", *cfg, *args], capsys)
    assert code == 2 and expected in err, err


def test_a_broken_profile_is_refused_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    profile = tmp_path / "p.yaml"
    profile.write_text("cells: [{medium: hard, mode: roll, metres: -1}]\n")
    code, _, err = run_main(["ground", "--config", str(config(tmp_path, profile))], capsys)
    assert code == 2 and f"{profile}: cells.0.metres: Input should be greater" in err


def test_check_under_the_learned_policy_refuses_a_broken_profile(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    profile = tmp_path / "p.yaml"
    profile.write_text("cells: [{medium: lava, mode: roll}]\n")
    cfg = tmp_path / "helixd.yaml"
    cfg.write_text(
        yaml.safe_dump({"media": {"modes": "learned"}, "ground": {"profile_file": str(profile)}})
    )
    survey = REPO_ROOT / "config/missions/pond-survey.yaml"
    code, _, err = run_main(["check", "--mission", str(survey), "--config", str(cfg)], capsys)
    assert code == 2
    assert f"error: media.modes learned: {profile}: cells.0.medium: Input should be" in err
    profile.unlink()  # no profile yet: the defaults, and the check passes
    code, out, err = run_main(["check", "--mission", str(survey), "--config", str(cfg)], capsys)
    assert code == 0, err
    assert "change  : roll → scroll" in out
