"""Loading a flight's inputs: the config and the mission together, every problem at once; what
the run directory records of the mission and of the config (a comment is no change, a value
is). The corpus of ground-station files: tests/prepare/test_inputs_corpus.py."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.base.plan import MotionMode
from helixd.prepare.inputs import (
    InputsRefused,
    config_sha256,
    load_inputs,
    recorded_mission_yaml,
)
from tests.support.recorder_runs import SQUARE_YAML

MISSION = "# a square, by hand\n" + SQUARE_YAML


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_a_good_pair_loads_with_its_plan(tmp_path: Path) -> None:
    mission = write(tmp_path, "square.yaml", MISSION)
    got = load_inputs(None, mission)
    assert got.path == mission and got.mission.name == "square"
    assert [(w.x_m, w.y_m) for w in got.plan.waypoints] == [(10, 0), (10, 10), (0, 10), (0, 0)]
    assert not got.provisional and got.notes == () and got.fence is None


def test_a_bad_config_and_a_bad_mission_are_refused_together(tmp_path: Path) -> None:
    config = write(tmp_path, "helixd.yaml", "safety:\n  no_such_key: 1\n")
    mission = write(tmp_path, "bad.yaml", MISSION.replace("mode: roll", "mode: hover"))
    with pytest.raises(InputsRefused) as refused:
        load_inputs(config, mission)
    assert refused.value.code is ExitCode.USAGE
    text = "\n".join(refused.value.problems)
    assert "no_such_key" in text and "hover" in text  # both, not the first only


def test_a_missing_mission_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(InputsRefused) as refused:
        load_inputs(None, tmp_path / "nowhere.yaml")
    assert len(refused.value.problems) == 1 and "nowhere.yaml" in refused.value.problems[0]


def test_the_record_keeps_a_yaml_file_as_written_unless_the_mode_was_forced(
    tmp_path: Path,
) -> None:
    mission = write(tmp_path, "square.yaml", MISSION)
    got = load_inputs(None, mission)
    assert recorded_mission_yaml(mission, got.mission, None) == MISSION  # comment and all
    forced = load_inputs(None, mission, MotionMode.SCROLL)
    text = recorded_mission_yaml(mission, forced.mission, MotionMode.SCROLL)
    assert "# a square" not in text and "scroll" in text  # what is flown, as helixd YAML


def test_the_config_hash_ignores_comments_and_sees_values(tmp_path: Path) -> None:
    plain = write(tmp_path, "a.yaml", "safety:\n  mission_time_limit_s: 600\n")
    commented = write(
        tmp_path, "b.yaml", "# ours\nsafety:\n  mission_time_limit_s: 600  # 10 min\n"
    )
    changed = write(tmp_path, "c.yaml", "safety:\n  mission_time_limit_s: 601\n")
    assert config_sha256(plain) == config_sha256(commented)
    assert config_sha256(plain) != config_sha256(changed)
    assert config_sha256(None) != config_sha256(changed)  # the defaults are a config too
    bad = write(tmp_path, "d.yaml", "safety: [\n")
    with pytest.raises(InputsRefused):
        config_sha256(bad)
