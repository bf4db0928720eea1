"""The one-line-per-problem errors: exact allowed ranges, whole allowed-key lists."""

from __future__ import annotations

from pathlib import Path

import pytest
from pydantic import Field, ValidationError

from helixd.config.link import LinkConfig
from helixd.config.load import load_config
from helixd.config.safety import SafetyConfig
from helixd.files.models import ConfigFileError, InputModel, format_validation_error
from helixd.mission.model import load_mission


class Bounded(InputModel):
    open_low: float = Field(1.0, gt=0.0, le=10.0)
    open_high: float = Field(1.0, ge=0.0, lt=10.0)
    closed: int = Field(1, ge=1, le=18)


@pytest.mark.parametrize(
    ("key", "value", "allowed"),
    [
        # "greater than 0 … allowed range 0.0 .. 10.0" contradicted itself (a regression)
        ("open_low", -3, "allowed: > 0.0 and <= 10.0)"),
        ("open_high", 10, "allowed: >= 0.0 and < 10.0)"),
        ("closed", 19, "allowed range 1 .. 18)"),
    ],
)
def test_the_allowed_range_is_exact(key: str, value: float, allowed: str) -> None:
    with pytest.raises(ValidationError) as info:
        Bounded.model_validate({key: value})
    [line] = format_validation_error("f.yaml", info.value, Bounded)
    assert line.startswith(f"f.yaml: {key}: ") and f"(got {value}; " in line
    assert line.endswith(allowed)


def test_an_unknown_key_lists_every_allowed_key_whole(tmp_path: Path) -> None:
    cfg = tmp_path / "c.yaml"
    cfg.write_text("safety:\n  slowdown: 1\n", encoding="utf-8")
    with pytest.raises(ConfigFileError) as info:
        load_config(cfg)
    [line] = info.value.problems
    assert "…" not in line
    assert line.endswith(", ".join(sorted(SafetyConfig.model_fields)) + ")")


def test_a_misspelt_top_level_key_gets_a_did_you_mean(tmp_path: Path) -> None:
    """Before: `mdoe: roll` in a mission listed the allowed keys, but only a waypoint's keys
    said "did you mean"; a config file's keys now say it too."""
    mission = tmp_path / "m.yaml"
    mission.write_text(
        "name: t\nmdoe: roll\nframe: start\nwaypoints:\n  - {x: 1.0, y: 0.0}\n",
        encoding="utf-8",
    )
    with pytest.raises(ConfigFileError) as info:
        load_mission(mission)
    (line,) = [p for p in info.value.problems if "mdoe" in p]
    assert "mdoe: unknown key (got 'roll'; did you mean mode? allowed keys here: " in line
    cfg = tmp_path / "c.yaml"
    cfg.write_text("safety:\n  pose_stael_s: 1\n", encoding="utf-8")
    with pytest.raises(ConfigFileError) as info:
        load_config(cfg)
    assert "did you mean pose_stale_s? allowed keys here: " in info.value.problems[0]


def test_only_what_came_from_the_file_is_cut(tmp_path: Path) -> None:
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"link:\n  {'k' * 1000}: 1\n", encoding="utf-8")  # YAML's longest key
    with pytest.raises(ConfigFileError) as info:
        load_config(cfg)
    [line] = info.value.problems
    link_keys = ", ".join(sorted(LinkConfig.model_fields))
    assert line.endswith(f"allowed keys here: {link_keys})")
    assert len(line) < 400 + len(link_keys) + 50  # the 1000-character key name was cut
